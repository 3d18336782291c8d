#include "sim/leg.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <vector>


namespace ambler::sim {

namespace {

constexpr double kGravity = 9.81;
constexpr double kDeg = 180.0 / std::numbers::pi;
// Stiff contacts everywhere the foot touches (the foot's priority makes its parameters win):
// MuJoCo 2.2.2's static penetration of a soft contact does not follow the load, so softness is
// never the soil model. timeconst 4 ms = 4 timesteps.
constexpr const char* kSolref = "0.004 1";
constexpr const char* kSolimp = "0.99 0.99 0.001";

std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.9g", v);
  return buf;
}

void validate(const LegConfig& c) {
  auto need = [](bool ok, const char* what) {
    if (!ok) throw std::invalid_argument(std::string("LegConfig: ") + what);
  };
  need(c.foot_diameter_m > 0 && c.foot_thickness_m > 0, "foot size must be positive");
  need(c.foot_tile_m > 0, "foot_tile_m must be positive");
  need(c.load_n > (c.leg_mass_kg + c.foot_mass_kg) * kGravity,
       "load_n must exceed the weight of leg and foot");
  need(c.bekker_n > 0 && c.bekker_kphi + c.bekker_kc > 0, "Bekker parameters must be positive");
  need(c.timestep_s > 0 && c.time_limit_s > 0 && c.load_ramp_s > 0, "times must be positive");
  need(c.hold_s >= 0, "hold_s must not be negative");
  need(c.descent_speed_m_s > 0 && c.lateral_stiffness_n_per_m > 0, "servo gains must be positive");
}

// The foot's collision pieces: the disk (a 48-gon) cut by a square grid of foot_tile_m into
// convex prisms, as inline meshes in the foot frame (ankle at the origin, sole at z = -thickness).
std::vector<std::string> footTiles(const LegConfig& c) {
  const double r = 0.5 * c.foot_diameter_m, t = c.foot_thickness_m;
  std::vector<Eigen::Vector2d> disk;
  for (int i = 0; i < 48; ++i) {
    const double a = 2 * std::numbers::pi * i / 48;
    disk.emplace_back(r * std::cos(a), r * std::sin(a));
  }
  // Sutherland–Hodgman: keep the side of the line where n·p <= d.
  auto clip = [](const std::vector<Eigen::Vector2d>& poly, const Eigen::Vector2d& n, double d) {
    std::vector<Eigen::Vector2d> out;
    for (std::size_t i = 0; i < poly.size(); ++i) {
      const auto& p = poly[i];
      const auto& q = poly[(i + 1) % poly.size()];
      const double sp = n.dot(p) - d, sq = n.dot(q) - d;
      if (sp <= 0) out.push_back(p);
      if ((sp < 0) != (sq < 0) && sp != 0 && sq != 0) out.push_back(p + (q - p) * (sp / (sp - sq)));
    }
    return out;
  };
  const int n = std::max(1, int(std::ceil(c.foot_diameter_m / c.foot_tile_m - 1e-9)));
  const double s = c.foot_diameter_m / n;
  std::vector<std::string> tiles;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const double x0 = -r + i * s, y0 = -r + j * s;
      auto poly = clip(disk, {-1, 0}, -x0);
      poly = clip(poly, {1, 0}, x0 + s);
      poly = clip(poly, {0, -1}, -y0);
      poly = clip(poly, {0, 1}, y0 + s);
      if (poly.size() < 3) continue;
      std::ostringstream v;
      for (double z : {-t, 0.0})
        for (const auto& p : poly) v << num(p.x()) << ' ' << num(p.y()) << ' ' << num(z) << ' ';
      tiles.push_back(v.str());
    }
  return tiles;
}

}  // namespace

double bekkerSinkage(double load_n, const LegConfig& c) {
  const double radius = 0.5 * c.foot_diameter_m;
  const double pressure = std::max(0.0, load_n) / (std::numbers::pi * radius * radius);
  return std::pow(pressure / (c.bekker_kc / radius + c.bekker_kphi), 1.0 / c.bekker_n);
}

std::string legXml(const std::string& world_file, const std::string& world_xml_text,
                   const LegConfig& c) {
  validate(c);
  const double r = 0.5 * c.foot_diameter_m, t = c.foot_thickness_m;
  const double mass = c.leg_mass_kg + c.foot_mass_kg;
  // The world's <compiler angle> also governs the leg's joint ranges.
  const bool radian = world_xml_text.find("angle=\"radian\"") != std::string::npos;
  const std::string ankle = radian ? num(1.0) : num(1.0 * kDeg);  // ±57°
  const double lateral_damping = 2.0 * std::sqrt(c.lateral_stiffness_n_per_m * mass);
  const double foot_ixx = c.foot_mass_kg * (3 * r * r + t * t) / 12, foot_izz = c.foot_mass_kg * r * r / 2;
  std::ostringstream x;
  x << "<mujoco model=\"leg\">\n"
    << "  <!-- written by ambler (sim/leg.cpp): the world plus one Ambler leg, see docs/leg.md.\n"
    << "       The leg is at the origin; stepLeg moves it with the leg_x/leg_y/leg_z joints. -->\n"
    << "  <include file=\"" << world_file << "\"/>\n"
    << "  <size nconmax=\"1000\" njmax=\"3000\"/>\n"
    << "  <option timestep=\"" << num(c.timestep_s) << "\"><flag multiccd=\"enable\"/></option>\n"
    << "  <asset>\n";
  const auto tiles = footTiles(c);
  for (std::size_t k = 0; k < tiles.size(); ++k)
    x << "    <mesh name=\"foot_tile_" << k << "\" vertex=\"" << tiles[k] << "\"/>\n";
  x << "  </asset>\n  <worldbody>\n"
    << "    <body name=\"leg\" pos=\"0 0 0\">\n"
    << "      <joint name=\"leg_x\" type=\"slide\" axis=\"1 0 0\" damping=\"" << num(lateral_damping) << "\"/>\n"
    << "      <joint name=\"leg_y\" type=\"slide\" axis=\"0 1 0\" damping=\"" << num(lateral_damping) << "\"/>\n"
    << "      <joint name=\"leg_z\" type=\"slide\" axis=\"0 0 1\"/>\n"
    << "      <inertial pos=\"0 0 0.5\" mass=\"" << num(c.leg_mass_kg) << "\" diaginertia=\"1.7 1.7 0.03\"/>\n"
    << "      <geom name=\"leg_shaft\" type=\"capsule\" fromto=\"0 0 0.02 0 0 1\" size=\"0.04\" group=\"2\""
    << " contype=\"0\" conaffinity=\"0\" rgba=\"0.7 0.7 0.75 1\"/>\n"
    << "      <body name=\"foot\" pos=\"0 0 0\">\n"
    << "        <joint name=\"ankle_x\" type=\"hinge\" axis=\"1 0 0\" limited=\"true\" range=\"-" << ankle
    << ' ' << ankle << "\" damping=\"2\" armature=\"0.01\"/>\n"
    << "        <joint name=\"ankle_y\" type=\"hinge\" axis=\"0 1 0\" limited=\"true\" range=\"-" << ankle
    << ' ' << ankle << "\" damping=\"2\" armature=\"0.01\"/>\n"
    << "        <inertial pos=\"0 0 " << num(-t / 2) << "\" mass=\"" << num(c.foot_mass_kg)
    << "\" diaginertia=\"" << num(foot_ixx) << ' ' << num(foot_ixx) << ' ' << num(foot_izz) << "\"/>\n"
    << "        <geom name=\"foot_disk\" type=\"cylinder\" pos=\"0 0 " << num(-t / 2) << "\" size=\""
    << num(r) << ' ' << num(t / 2) << "\" group=\"2\" contype=\"0\" conaffinity=\"0\" rgba=\"0.3 0.3 0.35 1\"/>\n";
  for (std::size_t k = 0; k < tiles.size(); ++k)
    x << "        <geom name=\"foot_tile_" << k << "\" type=\"mesh\" mesh=\"foot_tile_" << k
      << "\" group=\"3\" priority=\"1\" condim=\"3\" friction=\"" << num(c.friction)
      << " 0.005 0.0001\" solref=\"" << kSolref << "\" solimp=\"" << kSolimp
      << "\" rgba=\"0.3 0.3 0.35 1\"/>\n";
  x << "      </body>\n    </body>\n  </worldbody>\n"
    << "  <actuator>\n"
    << "    <position name=\"leg_x\" joint=\"leg_x\" kp=\"" << num(c.lateral_stiffness_n_per_m) << "\"/>\n"
    << "    <position name=\"leg_y\" joint=\"leg_y\" kp=\"" << num(c.lateral_stiffness_n_per_m) << "\"/>\n"
    << "    <motor name=\"leg_z\" joint=\"leg_z\" ctrllimited=\"true\" ctrlrange=\"" << num(-4 * c.load_n)
    << ' ' << num(4 * c.load_n) << "\"/>\n"
    << "  </actuator>\n</mujoco>\n";
  return x.str();
}

LegOutcome stepLeg(const std::filesystem::path& world_xml, double x, double y, const LegConfig& c) {
  return Leg(world_xml, c).step(x, y);
}

namespace {

struct Point {
  double u, v, z;  // relative to the disk centre
};

// The height of the triangulated grid at (x, y) (cells split along (r,c)–(r+1,c+1)); NaN outside.
double gridHeight(const Eigen::MatrixXf& h, double cell, double x0, double y0, double x, double y) {
  const double fc = (x - x0) / cell, fr = (y - y0) / cell;
  if (fc < 0 || fr < 0 || fc > h.cols() - 1 || fr > h.rows() - 1)
    return std::numeric_limits<double>::quiet_NaN();
  const int c = std::min(int(fc), int(h.cols()) - 2), r = std::min(int(fr), int(h.rows()) - 2);
  const double a = fc - c, b = fr - r;
  const double z00 = h(r, c), z11 = h(r + 1, c + 1);
  // Lower-right triangle (r,c),(r,c+1),(r+1,c+1) when a >= b, else (r,c),(r+1,c),(r+1,c+1).
  if (a >= b) return z00 + a * (h(r, c + 1) - z00) + b * (z11 - h(r, c + 1));
  return z00 + b * (h(r + 1, c) - z00) + a * (z11 - h(r + 1, c));
}

// The plane z = a + b·u + c·v (u, v from the disk centre) on which a disk supported by `pts`
// rests: lowest at the centre with no point above it.
Eigen::Vector3d restingPlane(const std::vector<Point>& pts, double r) {
  // Plane z = a + b·u + c·v over the disk; start level on the highest point.
  double a = -std::numeric_limits<double>::infinity(), b = 0, cc = 0;
  std::vector<int> S;
  for (int i = 0; i < int(pts.size()); ++i)
    if (pts[i].z > a) { a = pts[i].z; S = {i}; }
  auto plane = [&](const Point& p) { return a + b * p.u + cc * p.v; };
  const double eps = 1e-9;
  // Rotate the plane about the line through the contacts that lowers the centre: δ(p) = -t·w(p),
  // w(p) = (p - p0)·n with n the horizontal unit vector from the contacts toward the centre.
  // Each step keeps the contacts and adds the first point that touches (ties: the farthest).
  for (int iter = 0; iter < 200; ++iter) {
    Eigen::Vector2d n;
    const Point& p0 = pts[S[0]];
    if (S.size() == 1) {
      n = -Eigen::Vector2d(p0.u, p0.v);
      if (n.norm() < 1e-9 * r) break;  // the contact is under the centre
    } else if (S.size() == 2) {
      const Eigen::Vector2d A(p0.u, p0.v), B(pts[S[1]].u, pts[S[1]].v);
      const Eigen::Vector2d e = (B - A).normalized();
      const Eigen::Vector2d foot = A + e * (-A).dot(e);  // the centre's projection on the line
      n = -foot;
      if (n.norm() < 1e-9 * r) {
        const double s = (-A).dot(e), len = (B - A).norm();
        if (s >= -1e-9 && s <= len + 1e-9) break;  // the centre lies on the segment
        S = {s < 0 ? S[0] : S[1]};                 // pivot about the nearer end
        continue;
      }
    } else {
      // Three contacts: done if the centre lies inside; else drop the one opposite the edge
      // the centre lies beyond.
      Eigen::Vector2d P[3];
      for (int k = 0; k < 3; ++k) P[k] = {pts[S[k]].u, pts[S[k]].v};
      const double area = (P[1] - P[0]).x() * (P[2] - P[0]).y() - (P[1] - P[0]).y() * (P[2] - P[0]).x();
      if (std::abs(area) < 1e-12 * r * r) {  // collinear: keep the two farthest apart
        int drop = 0;
        double best = -1;
        for (int k = 0; k < 3; ++k) {
          const double len = (P[(k + 1) % 3] - P[(k + 2) % 3]).norm();
          if (len > best) { best = len; drop = k; }
        }
        S.erase(S.begin() + drop);
        continue;
      }
      double lam[3];
      for (int k = 0; k < 3; ++k) {
        const Eigen::Vector2d Q = P[(k + 1) % 3], R = P[(k + 2) % 3];
        lam[k] = (Q.x() * R.y() - Q.y() * R.x()) / area;  // area of (centre, Q, R)
      }
      const int worst = int(std::min_element(lam, lam + 3) - lam);
      if (lam[worst] >= -1e-9) break;
      S.erase(S.begin() + worst);
      continue;
    }
    n.normalize();
    double tmin = std::numeric_limits<double>::infinity(), wbest = 0;
    int next = -1;
    for (int i = 0; i < int(pts.size()); ++i) {
      const double w = (pts[i].u - p0.u) * n.x() + (pts[i].v - p0.v) * n.y();
      if (w <= 1e-9 * r) continue;
      const double ti = std::max(0.0, plane(pts[i]) - pts[i].z) / w;
      if (ti < tmin - eps || (ti < tmin + eps && w > wbest)) {
        tmin = ti;
        wbest = w;
        next = i;
      }
    }
    if (next < 0) break;  // nothing beyond: cannot happen with a full footprint
    // δ(p) = -t·((p - p0)·n) = -t·(n·p) + t·(n·p0)
    a += tmin * (n.x() * p0.u + n.y() * p0.v);
    b -= tmin * n.x();
    cc -= tmin * n.y();
    S.push_back(next);
  }
  return {a, b, cc};
}

}  // namespace

std::optional<DiskRest> restingDisk(const Eigen::MatrixXf& heights, double cell_m, double x0,
                                    double y0, double x, double y, double diameter_m) {
  if (heights.rows() < 2 || heights.cols() < 2 || !(cell_m > 0) || !(diameter_m > 0))
    throw std::invalid_argument("restingDisk: need a 2x2 grid, a positive cell and diameter");
  const double r = 0.5 * diameter_m;
  // The supporting points: grid samples under the disk and points under its rim (between
  // samples the surface is linear, so a cell's highest points lie at samples or on the rim).
  // A disk tilted by θ covers an ellipse, r·cosθ along the slope: start level, then refit on the
  // footprint of the tilt found until the tilt stops changing.
  Eigen::Vector3d plane(0, 0, 0);
  for (int pass = 0; pass < 8; ++pass) {
    const Eigen::Vector2d grad(plane.y(), plane.z());
    const double g = grad.norm(), cos_t = 1.0 / std::sqrt(1.0 + g * g);
    const Eigen::Vector2d e = g > 0 ? Eigen::Vector2d(grad / g) : Eigen::Vector2d(1, 0);
    const Eigen::Vector2d f(-e.y(), e.x());
    auto inside = [&](double u, double v) {
      const double s = (u * e.x() + v * e.y()) / cos_t, q = u * f.x() + v * f.y();
      return s * s + q * q <= r * r * (1 + 1e-12);
    };
    std::vector<Point> pts;
    const int c0 = int(std::floor((x - r - x0) / cell_m)), c1 = int(std::ceil((x + r - x0) / cell_m));
    const int r0 = int(std::floor((y - r - y0) / cell_m)), r1 = int(std::ceil((y + r - y0) / cell_m));
    for (int i = std::max(0, r0); i <= std::min(int(heights.rows()) - 1, r1); ++i)
      for (int j = std::max(0, c0); j <= std::min(int(heights.cols()) - 1, c1); ++j) {
        const double u = x0 + j * cell_m - x, v = y0 + i * cell_m - y;
        if (inside(u, v) && std::isfinite(heights(i, j))) pts.push_back({u, v, heights(i, j)});
      }
    const int rim = std::max(72, int(std::ceil(2 * std::numbers::pi * r / (0.25 * cell_m))));
    for (int k = 0; k < rim; ++k) {
      const double a = 2 * std::numbers::pi * k / rim;
      const Eigen::Vector2d p = e * (r * cos_t * std::cos(a)) + f * (r * std::sin(a));
      const double z = gridHeight(heights, cell_m, x0, y0, x + p.x(), y + p.y());
      if (std::isfinite(z)) pts.push_back({p.x(), p.y(), z});
    }
    if (pts.empty()) return std::nullopt;
    const Eigen::Vector3d next = restingPlane(pts, r);
    const bool converged = pass > 0 && (next - plane).cwiseAbs().maxCoeff() < 1e-9;
    plane = next;
    if (converged) break;
  }
  return DiskRest{plane.x(), std::atan(std::hypot(plane.y(), plane.z())) * kDeg};
}

}  // namespace ambler::sim
