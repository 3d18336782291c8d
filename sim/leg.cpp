#include "sim/leg.hpp"

#include <mujoco/mujoco.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <memory>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "base/atomic_file.hpp"
#include "base/read_file.hpp"

namespace ambler::sim {

namespace {

constexpr double kGravity = 9.81;
constexpr double kDeg = 180.0 / std::numbers::pi;
// Stiff contacts everywhere the foot touches (the foot's priority makes its parameters win):
// MuJoCo 2.2.2's static penetration of a soft contact does not follow the load, so softness is
// never the soil model. timeconst 4 ms = 4 timesteps.
constexpr const char* kSolref = "0.004 1";
constexpr const char* kSolimp = "0.99 0.99 0.001";
constexpr double kSandStep = 1e-4;  // m: the sand under the foot yields in steps this large

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

struct ModelDeleter { void operator()(mjModel* m) const { mj_deleteModel(m); } };
struct DataDeleter { void operator()(mjData* d) const { mj_deleteData(d); } };

std::unique_ptr<mjModel, ModelDeleter> loadText(const std::string& xml,
                                                const std::filesystem::path& dir) {
  // MuJoCo 2.2.2 loads only from files; <include> resolves against the file's directory.
  static std::atomic<int> counter{0};
  const auto tmp = dir / ("leg_" + std::to_string(getpid()) + "_" +
                          std::to_string(counter++) + ".xml");
  std::ofstream(tmp) << xml;
  std::array<char, 1000> err{};
  mjModel* m = mj_loadXML(tmp.c_str(), nullptr, err.data(), int(err.size()));
  std::filesystem::remove(tmp);
  if (!m) throw std::runtime_error(dir.string() + ": MuJoCo could not load the leg world: " +
                                   err.data());
  return std::unique_ptr<mjModel, ModelDeleter>(m);
}

// The leg's handles into a loaded model.
struct Rig {
  int leg = -1, foot = -1, hfield_geom = -1;
  int qx = -1, qy = -1, qz = -1, vz = -1;  // qpos / qvel addresses of the leg's slides
  int act_x = -1, act_y = -1, act_z = -1;
  std::vector<int> hfield_vertices;  // hfield data indices lowered so far (sand)
};

int require(int id, const char* what) {
  if (id < 0) throw std::runtime_error(std::string("leg world: no ") + what);
  return id;
}

Rig rig(const mjModel* m) {
  Rig r;
  r.leg = require(mj_name2id(m, mjOBJ_BODY, "leg"), "body leg");
  r.foot = require(mj_name2id(m, mjOBJ_BODY, "foot"), "body foot");
  r.hfield_geom = mj_name2id(m, mjOBJ_GEOM, "terrain");
  if (r.hfield_geom < 0 || m->geom_type[r.hfield_geom] != mjGEOM_HFIELD)
    for (int g = 0; g < m->ngeom && r.hfield_geom < 0; ++g)
      if (m->geom_type[g] == mjGEOM_HFIELD) r.hfield_geom = g;
  auto joint = [m](const char* name) { return require(mj_name2id(m, mjOBJ_JOINT, name), name); };
  r.qx = m->jnt_qposadr[joint("leg_x")];
  r.qy = m->jnt_qposadr[joint("leg_y")];
  r.qz = m->jnt_qposadr[joint("leg_z")];
  r.vz = m->jnt_dofadr[joint("leg_z")];
  r.act_x = require(mj_name2id(m, mjOBJ_ACTUATOR, "leg_x"), "actuator leg_x");
  r.act_y = require(mj_name2id(m, mjOBJ_ACTUATOR, "leg_y"), "actuator leg_y");
  r.act_z = require(mj_name2id(m, mjOBJ_ACTUATOR, "leg_z"), "actuator leg_z");
  return r;
}

struct FootPose {
  Eigen::Vector3d sole;  // sole centre
  Eigen::Vector3d axis;  // foot z axis
};

FootPose footPose(const mjModel* m, const mjData* d, int foot, double thickness) {
  (void)m;
  const double* p = d->xpos + 3 * foot;
  const double* R = d->xmat + 9 * foot;
  const Eigen::Vector3d axis(R[2], R[5], R[8]);
  return {Eigen::Vector3d(p[0], p[1], p[2]) - thickness * axis, axis};
}

// Highest point of the world's own geoms (group 0: terrain and rocks, not the leg) on a grid of
// vertical rays over the disk of radius r about (x, y); with `plane`, the deepest point above
// the plane through `sole` with normal `axis` instead. nullopt if no ray hits.
std::optional<double> probeFootprint(const mjModel* m, const mjData* d, double x, double y,
                                     double r, double step, const FootPose* plane = nullptr) {
  const mjtByte groups[mjNGROUP] = {1, 0, 0, 0, 0, 0};
  const double top = m->stat.center[2] + 2 * m->stat.extent + 10.0;
  const int n = int(std::ceil(r / step));
  std::optional<double> best;
  for (int i = -n; i <= n; ++i)
    for (int j = -n; j <= n; ++j) {
      const double dx = i * step, dy = j * step;
      if (dx * dx + dy * dy > r * r) continue;
      const mjtNum pnt[3] = {x + dx, y + dy, top}, dir[3] = {0, 0, -1};
      int geom = -1;
      const mjtNum t = mj_ray(m, d, pnt, dir, groups, 1, -1, &geom);
      if (t < 0) continue;
      double v = top - t;
      if (plane) {
        const auto& s = plane->sole;
        const auto& a = plane->axis;
        v -= s.z() - (a.x() * (pnt[0] - s.x()) + a.y() * (pnt[1] - s.y())) / a.z();
      }
      best = best ? std::max(*best, v) : v;
    }
  return best;
}

// Vertical force on the foot from its contacts (all, or only those with geom `only`), and the
// most contacts of any one foot-geom/other-geom pair.
struct ContactSum {
  double fz = 0;
  int max_pair = 0;
  bool touching = false;
};

ContactSum footContacts(const mjModel* m, mjData* d, int foot, int only = -1) {
  ContactSum s;
  std::vector<std::pair<int, int>> pairs;
  for (int i = 0; i < d->ncon; ++i) {
    const mjContact& c = d->contact[i];
    const bool foot1 = m->geom_bodyid[c.geom1] == foot, foot2 = m->geom_bodyid[c.geom2] == foot;
    if (!foot1 && !foot2) continue;
    s.touching = true;
    pairs.emplace_back(c.geom1, c.geom2);
    if (only >= 0 && c.geom1 != only && c.geom2 != only) continue;
    mjtNum f[6];
    mj_contactForce(m, d, i, f);
    // f is in the contact frame; its normal points from geom1 to geom2, the force on geom2.
    double fz = f[0] * c.frame[2] + f[1] * c.frame[5] + f[2] * c.frame[8];
    s.fz += foot2 ? fz : -fz;
  }
  std::sort(pairs.begin(), pairs.end());
  for (std::size_t i = 0; i < pairs.size();) {
    std::size_t j = i;
    while (j < pairs.size() && pairs[j] == pairs[i]) ++j;
    s.max_pair = std::max(s.max_pair, int(j - i));
    i = j;
  }
  return s;
}

// Sand: lowers every heightfield vertex whose triangles can reach under the foot (within
// radius + one cell diagonal of the sole centre) to `sink` below its original height.
void lowerSand(mjModel* m, const mjData* d, int geom, const std::vector<float>& original,
               double cx, double cy, double reach, double sink) {
  const int h = m->geom_dataid[geom];
  const int nrow = m->hfield_nrow[h], ncol = m->hfield_ncol[h];
  const double* size = m->hfield_size + 4 * h;
  const double* g = d->geom_xpos + 3 * geom;
  const double dx = 2 * size[0] / (ncol - 1), dy = 2 * size[1] / (nrow - 1);
  const double lower = sink / size[2];  // in normalised units
  float* data = m->hfield_data + m->hfield_adr[h];
  const int c0 = std::max(0, int(std::floor((cx - reach - g[0] + size[0]) / dx)));
  const int c1 = std::min(ncol - 1, int(std::ceil((cx + reach - g[0] + size[0]) / dx)));
  const int r0 = std::max(0, int(std::floor((cy - reach - g[1] + size[1]) / dy)));
  const int r1 = std::min(nrow - 1, int(std::ceil((cy + reach - g[1] + size[1]) / dy)));
  for (int r = r0; r <= r1; ++r)
    for (int c = c0; c <= c1; ++c) {
      const double x = g[0] - size[0] + c * dx, y = g[1] - size[1] + r * dy;
      if (std::hypot(x - cx, y - cy) > reach) continue;
      const std::size_t i = std::size_t(r) * ncol + c;
      data[i] = std::min(data[i], float(original[i] - lower));
    }
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

namespace {

// The world's MJCF text; a file that cannot be read is named in the one line.
std::string worldText(const std::filesystem::path& world_xml) {
  try {
    return base::readFile(world_xml);
  } catch (const base::ReadError& e) {
    throw std::runtime_error(world_xml.string() + ": " + e.what());
  }
}

}  // namespace

std::filesystem::path writeLegWorld(const std::filesystem::path& world_xml, const LegConfig& c) {
  const std::string text = worldText(world_xml);
  const auto out = world_xml.parent_path() / "leg.xml";
  base::writeFileAtomic(out, legXml(world_xml.filename().string(), text, c));
  return out;
}

LegOutcome stepLeg(const std::filesystem::path& world_xml, double x, double y, const LegConfig& c) {
  validate(c);
  auto model = loadText(legXml(world_xml.filename().string(), worldText(world_xml), c), world_xml.parent_path());
  mjModel* m = model.get();
  std::unique_ptr<mjData, DataDeleter> data(mj_makeData(m));
  mjData* d = data.get();
  Rig g = rig(m);
  if (c.soil == Soil::Sand && g.hfield_geom < 0)
    throw std::runtime_error(world_xml.string() + ": sand needs a heightfield geom");
  mj_forward(m, d);

  const double radius = 0.5 * c.foot_diameter_m, t = c.foot_thickness_m;
  double probe_step = 0.01;
  if (g.hfield_geom >= 0) {
    const int h = m->geom_dataid[g.hfield_geom];
    probe_step = std::min(probe_step, m->hfield_size[4 * h] / (m->hfield_ncol[h] - 1));
  }
  const auto top = probeFootprint(m, d, x, y, radius, probe_step);
  if (!top) throw std::runtime_error(world_xml.string() + ": no terrain under the foot at (" +
                                     num(x) + ", " + num(y) + ")");

  const double weight = (c.leg_mass_kg + c.foot_mass_kg) * kGravity;
  const double z0 = *top + c.clearance_m + t;  // ankle height at the start
  d->qpos[g.qx] = x;
  d->qpos[g.qy] = y;
  d->qpos[g.qz] = z0;
  d->ctrl[g.act_x] = x;
  d->ctrl[g.act_y] = y;
  mj_forward(m, d);

  // Sand: the original heightfield, to lower from and to restore for the sinkage probe.
  std::vector<float> original;
  int hid = -1;
  double cell = 0;
  if (g.hfield_geom >= 0) {
    hid = m->geom_dataid[g.hfield_geom];
    const float* p = m->hfield_data + m->hfield_adr[hid];
    original.assign(p, p + std::size_t(m->hfield_nrow[hid]) * m->hfield_ncol[hid]);
    cell = std::max(2 * m->hfield_size[4 * hid] / (m->hfield_ncol[hid] - 1),
                    2 * m->hfield_size[4 * hid + 1] / (m->hfield_nrow[hid] - 1));
  }
  const double reach = radius + std::sqrt(2.0) * cell;
  double soil_force = 0, sink_applied = 0;
  const double filter_tau = 0.02, sink_rate = 0.25;  // s, m/s: sand yields no faster

  // Vertical servo: a position command descending at descent_speed, tracked by a PD loop with
  // gravity compensation, whose push is capped at the load allowed so far (0 before contact, a
  // ramp to load_n after it): the leg lowers until the foot carries the allowed load.
  const double kp = 2e4, kd = 2 * std::sqrt(kp * (c.leg_mass_kg + c.foot_mass_kg));
  double z_cmd = z0;
  double t_contact = -1, settle_since = -1;
  Eigen::Vector2d first_contact = Eigen::Vector2d::Zero();
  LegOutcome out;
  auto pose = [&] { return footPose(m, d, g.foot, t); };

  auto measure = [&] {
    const FootPose p = pose();
    out.x_m = p.sole.x();
    out.y_m = p.sole.y();
    out.z_m = p.sole.z();
    out.tilt_deg = std::acos(std::clamp(p.axis.z(), -1.0, 1.0)) * kDeg;
    out.slip_m = t_contact >= 0 ? (p.sole.head<2>() - first_contact).norm() : 0.0;
    out.load_n = footContacts(m, d, g.foot).fz;
    out.time_s = d->time;
    // Sinkage against the true terrain: probe with the heightfield as the world gave it.
    std::vector<float> modified;
    if (hid >= 0) {
      float* p0 = m->hfield_data + m->hfield_adr[hid];
      modified.assign(p0, p0 + original.size());
      std::copy(original.begin(), original.end(), p0);
    }
    out.sink_m = probeFootprint(m, d, p.sole.x(), p.sole.y(), radius, probe_step, &p).value_or(0.0);
    if (hid >= 0) std::copy(modified.begin(), modified.end(), m->hfield_data + m->hfield_adr[hid]);
  };

  const double dt = m->opt.timestep;
  double hold_until = -1;
  Eigen::Vector3d settled_at = Eigen::Vector3d::Zero();
  while (d->time < c.time_limit_s + c.hold_s) {
    const double vz = d->qvel[g.vz];
    const double allowed = t_contact < 0 ? 0.0 : c.load_n * std::min(1.0, (d->time - t_contact) / c.load_ramp_s);
    // After contact the command runs ahead by 2× load/kp, so the cap, not the PD, sets the load.
    z_cmd = t_contact < 0 ? z_cmd - c.descent_speed_m_s * dt : d->qpos[g.qz] - 2 * c.load_n / kp;
    const double u = weight + kp * (z_cmd - d->qpos[g.qz]) + kd * (-c.descent_speed_m_s - vz);
    // Before contact the servo may push with the foot's weight only (free descent).
    d->ctrl[g.act_z] = std::clamp(u, t_contact < 0 ? 0.0 : weight - allowed, weight + c.load_n);
    mj_step(m, d);

    const ContactSum contacts = footContacts(m, d, g.foot);
    out.max_pair_contacts = std::max(out.max_pair_contacts, contacts.max_pair);
    out.max_contacts = std::max(out.max_contacts, d->ncon);
    out.max_rows = std::max(out.max_rows, d->nefc);
    if (contacts.max_pair >= mjMAXCONPAIR || d->warning[mjWARN_CONTACTFULL].number > 0 ||
        d->warning[mjWARN_CNSTRFULL].number > 0)
      out.contact_cap_reached = true;
    if (contacts.touching && t_contact < 0) {
      t_contact = d->time;
      first_contact = pose().sole.head<2>();
    }

    if (c.soil == Soil::Sand && t_contact >= 0) {
      const double fz = footContacts(m, d, g.foot, g.hfield_geom).fz;
      // Quasi-static Bekker: the soil sees the contact force, but never more than the load the
      // leg commands, so impacts of the foot following the yielding sand do not dig it deeper.
      soil_force += (std::clamp(fz, 0.0, allowed) - soil_force) * dt / filter_tau;
      const double target = bekkerSinkage(soil_force, c);
      // Yield in steps of at least 0.1 mm: each step drops the foot a little, and a creep of
      // ever smaller steps as the force converges would keep it from ever settling.
      if (target > sink_applied + kSandStep) {
        sink_applied = std::min(target, sink_applied + sink_rate * dt);
        const FootPose p = pose();
        lowerSand(m, d, g.hfield_geom, original, p.sole.x(), p.sole.y(), reach, sink_applied);
        mj_forward(m, d);
      }
    }

    if (hold_until >= 0) {
      out.drift_m = std::max(out.drift_m, (pose().sole - settled_at).norm());
      if (d->time >= hold_until) break;
      continue;
    }
    mjtNum vel[6];
    mj_objectVelocity(m, d, mjOBJ_BODY, g.foot, vel, 0);
    const bool slow = Eigen::Vector3d(vel[3], vel[4], vel[5]).norm() < c.settle_speed_m_s &&
                      Eigen::Vector3d(vel[0], vel[1], vel[2]).norm() < c.settle_angular_speed_rad_s;
    const bool loaded = t_contact >= 0 && d->time >= t_contact + c.load_ramp_s;
    settle_since = (slow && loaded) ? (settle_since < 0 ? d->time : settle_since) : -1;
    const bool settled = settle_since >= 0 && d->time - settle_since >= c.settle_window_s;
    if (settled || d->time >= c.time_limit_s) {
      out.settled = settled;
      measure();
      settled_at = pose().sole;
      hold_until = d->time + c.hold_s;
      if (!settled) break;
    }
  }
  return out;
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
