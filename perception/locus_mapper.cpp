#include "perception/locus_mapper.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "perception/sensor_geometry.hpp"

namespace ambler::perception {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The part [s0, s1] of the line u + s·v inside `box` (slab method); false if it misses.
bool clipToBox(const Eigen::AlignedBox3d& box, const Eigen::Vector3d& u, const Eigen::Vector3d& v,
               double& s0, double& s1) {
  s0 = -std::numeric_limits<double>::infinity();
  s1 = std::numeric_limits<double>::infinity();
  for (int i = 0; i < 3; ++i) {
    if (std::abs(v[i]) < 1e-15) {
      if (u[i] < box.min()[i] || u[i] > box.max()[i]) return false;
      continue;
    }
    double a = (box.min()[i] - u[i]) / v[i], b = (box.max()[i] - u[i]) / v[i];
    if (a > b) std::swap(a, b);
    s0 = std::max(s0, a);
    s1 = std::min(s1, b);
  }
  return s0 <= s1;
}

bool checkEven(const std::vector<double>& a, double step) {
  for (std::size_t i = 1; i < a.size(); ++i)
    if (std::abs((a[i] - a[0]) - double(i) * step) > 1e-9) return false;
  return true;
}

// Crossing-number point-in-polygon test.
bool insidePolygon(const std::vector<Eigen::Vector2d>& poly, const Eigen::Vector2d& p) {
  bool inside = false;
  for (std::size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++) {
    const auto& a = poly[i];
    const auto& b = poly[j];
    if ((a.y() > p.y()) != (b.y() > p.y()) &&
        p.x() < (b.x() - a.x()) * (p.y() - a.y()) / (b.y() - a.y()) + a.x())
      inside = !inside;
  }
  return inside;
}

}  // namespace

// One evaluation of Δ = ρ_l − I at a scan angle: where it looked and with what weights.
struct Sample {
  bool valid = false;   // the line is in front of the sensor, inside the image, all pixels returned
  unsigned edges = 0;   // bit k: pixel k (of the 2×2 cell, weighted) is an occluding-edge pixel
  double delta = 0, s = 0, rho = 0, theta = 0;
  int r0 = 0, c0 = 0;   // the top-left pixel of the 2×2 cell
  double w[4] = {0, 0, 0, 0};  // bilinear weights of (r0,c0), (r0,c0+1), (r0+1,c0), (r0+1,c0+1)
};

LocusMapper::LocusMapper(const RangeImage& image, const EdgeMask* edges, const LocusConfig& config)
    : image_(image), edges_(edges), config_(config), T_SW_(image.T_WS.inverse()) {
  if (image.rows() < 2 || image.cols() < 2)
    throw std::invalid_argument("LocusMapper: the range image needs at least 2x2 pixels");
  if (edges && (edges->rows() != image.rows() || edges->cols() != image.cols()))
    throw std::invalid_argument("LocusMapper: the edge mask and the range image differ in size");
  phi0_ = image.phi[0];
  dphi_ = image.phi[0] - image.phi[1];
  theta0_ = image.theta[0];
  dtheta_ = image.theta[1] - image.theta[0];
  if (!(dphi_ > 0) || !(dtheta_ > 0) || !checkEven(image.phi, -dphi_) || !checkEven(image.theta, dtheta_))
    throw std::invalid_argument("LocusMapper: scan angles must be evenly spaced, φ falling, θ rising");
  up_ = T_SW_.linear() * Eigen::Vector3d::UnitZ();
  // g(f)/(4 − 2^2H) of the fBm roughness term, tabulated (f in [0, 1], 1024 steps; g is smooth).
  const double h2 = 2 * config.roughness_hurst;
  for (int i = 0; i <= 1024; ++i) {
    const double f = i / 1024.0;
    roughness_g_.push_back((std::pow(f, h2) * (1 - f) + std::pow(1 - f, h2) * f - f * (1 - f)) /
                           (4 - std::pow(2.0, h2)));
  }
  for (double phi : image.phi) {
    sin_phi_.push_back(std::sin(phi));
    cos_phi_.push_back(std::cos(phi));
  }
  for (double theta : image.theta) {
    sin_theta_.push_back(std::sin(theta));
    cos_theta_.push_back(std::cos(theta));
  }
  for (int r = 0; r < image.rows(); ++r)
    for (int c = 0; c < image.cols(); ++c)
      if (image.valid(r, c)) bounds_.extend(image.pointWorld(r, c));
  if (!bounds_.isEmpty()) {
    bounds_.min().array() -= config.z_margin_m;
    bounds_.max().array() += config.z_margin_m;
  }
}

namespace {

// Δ at fractional row rf (scan angle with sin sp, cos cp) for the sensor-frame line a + s·b.
Sample evaluate(const RangeImage& img, const EdgeMask* edges, double theta0, double dtheta, double rf,
                double sp, double cp, const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  Sample out;
  // The point of the line on the plane of scan angle φ: z·cosφ − y·sinφ = 0.
  const double den = b.z() * cp - b.y() * sp;
  if (std::abs(den) < 1e-15) return out;
  out.s = -(a.z() * cp - a.y() * sp) / den;
  const Eigen::Vector3d p = a + out.s * b;
  if (p.y() * cp + p.z() * sp <= 0) return out;  // behind the sensor
  out.rho = p.norm();
  // Single precision is ample here (≈ 4e-8 rad, a few 1e-7 m of range) and asinf costs a third.
  out.theta = std::asin(std::clamp(float(p.x() / out.rho), -1.0f, 1.0f));
  const double cf = (out.theta - theta0) / dtheta;
  const int rows = img.rows(), cols = img.cols();
  if (!(cf >= 0.0 && cf <= cols - 1) || !(rf >= 0.0 && rf <= rows - 1)) return out;
  out.r0 = std::min(int(rf), rows - 2);
  out.c0 = std::min(int(cf), cols - 2);
  const double fr = rf - out.r0, fc = cf - out.c0;
  out.w[0] = (1 - fr) * (1 - fc);
  out.w[1] = (1 - fr) * fc;
  out.w[2] = fr * (1 - fc);
  out.w[3] = fr * fc;
  double I = 0;
  for (int k = 0; k < 4; ++k) {
    if (out.w[k] == 0.0) continue;  // a pixel with no weight is not used, returned or not
    const int r = out.r0 + k / 2, c = out.c0 + k % 2;
    const float range = img.range(r, c);
    if (!std::isfinite(range)) return out;  // never bridge a pixel that returned nothing
    I += out.w[k] * range;
    if (edges && (*edges)(r, c)) out.edges |= 1u << k;
  }
  out.delta = out.rho - I;
  out.valid = true;
  return out;
}

// Sines and cosines of the scan angles, so eq. 1 needs no libm call per pixel.
struct AngleTables {
  const std::vector<double>& sin_phi;
  const std::vector<double>& cos_phi;
  const std::vector<double>& sin_theta;
  const std::vector<double>& cos_theta;
};

// A surface point of the image in the sensor frame (eq. 1), if that pixel returned.
bool pixelPoint(const RangeImage& img, const AngleTables& t, int r, int c, Eigen::Vector3d& p) {
  if (r < 0 || c < 0 || r >= img.rows() || c >= img.cols() || !img.valid(r, c)) return false;
  const double rho = img.range(r, c), ct = t.cos_theta[c];
  p = Eigen::Vector3d(rho * t.sin_theta[c], rho * t.cos_phi[r] * ct, rho * t.sin_phi[r] * ct);
  return true;
}

// The local surface normal (sensor frame) around the 2×2 cell at (r0, c0), from the widest
// returned span across it in each image direction (wider spans average out range noise).
Eigen::Vector3d localNormal(const RangeImage& img, const AngleTables& angles, int r0, int c0, const Eigen::Vector3d& up) {
  Eigen::Vector3d t[2];
  bool ok[2] = {false, false};
  for (int dir = 0; dir < 2; ++dir)
    for (int span = 2; span >= 0 && !ok[dir]; --span)
      for (int k = 0; k < 2 && !ok[dir]; ++k) {
        Eigen::Vector3d p = Eigen::Vector3d::Zero(), q = Eigen::Vector3d::Zero();
        if (dir == 0)  // along the scanline (θ)
          ok[dir] = pixelPoint(img, angles, r0 + k, c0 - span / 2, p) && pixelPoint(img, angles, r0 + k, c0 + 1 + (span + 1) / 2, q);
        else  // across scanlines (φ)
          ok[dir] = pixelPoint(img, angles, r0 - span / 2, c0 + k, p) && pixelPoint(img, angles, r0 + 1 + (span + 1) / 2, c0 + k, q);
        if (ok[dir]) t[dir] = q - p;
      }
  if (!ok[0] || !ok[1]) return up;
  const Eigen::Vector3d n = t[0].cross(t[1]);
  return n.norm() > 0 ? Eigen::Vector3d(n.normalized()) : up;
}

// The variance of linear interpolation between samples of a rough surface, as a range error at
// fraction f. The surface between pixels is modelled as fractional Brownian motion with Hurst
// exponent H: for samples h apart, Var[interpolation error] = σ²h^2H·g(f), with
// g(f) = f^2H(1−f) + (1−f)^2H·f − f(1−f), and the second difference D = a(−1) − 2a(0) + a(+1) has
// E[D²] = σ²h^2H·(4 − 2^2H) plus the noise's 6σ_p² (docs/locus.md). D² is averaged over the
// second differences centred on both samples and both sides of the cell.
double roughnessVariance(const RangeImage& img, int r0, int c0, bool across_rows, double f, double var_pixel,
                         const std::vector<double>& g_table) {
  double sum = 0;
  int n = 0;
  for (int side = 0; side < 2; ++side)    // the two pixel lines bounding the cell
    for (int centre = 0; centre < 2; ++centre) {  // second differences centred on each sample
      double a[3];
      bool ok = true;
      for (int k = 0; k < 3 && ok; ++k) {
        const int rr = across_rows ? r0 + centre + k - 1 : r0 + side;
        const int cc = across_rows ? c0 + side : c0 + centre + k - 1;
        ok = rr >= 0 && cc >= 0 && rr < img.rows() && cc < img.cols() && img.valid(rr, cc);
        if (ok) a[k] = img.range(rr, cc);
      }
      if (!ok) continue;
      const double d = a[0] - 2 * a[1] + a[2];
      sum += d * d;
      ++n;
    }
  if (n == 0) return 0.0;
  const double x = std::clamp(f, 0.0, 1.0) * double(g_table.size() - 1);
  const std::size_t i = std::min(std::size_t(x), g_table.size() - 2);
  const double g = g_table[i] + (x - double(i)) * (g_table[i + 1] - g_table[i]);
  return g * std::max(0.0, sum / n - 6.0 * var_pixel);
}

}  // namespace

// σ of the position along the line (docs/locus.md): the range error of the interpolated image —
// the pixels' noise, σ_p² = (kρ²)² + q²/12, weighted by Σw², plus the surface's roughness between
// pixels that interpolation cannot know — carried along the beam d onto the local surface
// (normal n) and from there onto the line b: σ_s = σ_I·|d·n| / |b·n|.
double LocusMapper::sigmaAlongLine(int r0, int c0, const double* w, double rho, const Eigen::Vector3d& p,
                                   const Eigen::Vector3d& b) const {
  const double sum_w2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2] + w[3] * w[3];
  const double noise = config_.noise_k * rho * rho;
  const double var_pixel = noise * noise + config_.quantization_m * config_.quantization_m / 12.0;
  const double fr = w[2] + w[3], fc = w[1] + w[3];
  const double rough = !config_.roughness ? 0.0
                                           : roughnessVariance(image_, r0, c0, true, fr, var_pixel, roughness_g_) +
                                                 roughnessVariance(image_, r0, c0, false, fc, var_pixel, roughness_g_);
  const double var_rho = var_pixel * sum_w2 + rough;
  const Eigen::Vector3d n = localNormal(image_, {sin_phi_, cos_phi_, sin_theta_, cos_theta_}, r0, c0, up_);
  const Eigen::Vector3d d = p / rho;
  return std::sqrt(var_rho) * std::abs(d.dot(n)) / std::max(std::abs(b.dot(n)), 0.05);
}

LocusHit LocusMapper::intersect(const Eigen::Vector3d& u, const Eigen::Vector3d& v) const {
  return intersect(u, v, nullptr);
}

// sin and cos of φ_r − δ for |δ| within a scanline (≤ 0.01 rad): angle addition with Taylor series
// of sin δ and cos δ to δ⁵ and δ⁶ (error < 1e-16), cheaper than a libm call per evaluation.
static void sinCosNear(double sr, double cr, double delta, double& sp, double& cp) {
  const double d2 = delta * delta;
  const double sd = delta * (1 - d2 / 6 * (1 - d2 / 20));
  const double cd = 1 - d2 / 2 * (1 - d2 / 12 * (1 - d2 / 30));
  sp = sr * cd - cr * sd;
  cp = cr * cd + sr * sd;
}

LocusHit LocusMapper::intersect(const Eigen::Vector3d& u, const Eigen::Vector3d& v, int* hint) const {
  LocusHit hit;
  const Eigen::Vector3d a = T_SW_ * u, b = T_SW_.linear() * v;
  const int rows = image_.rows();
  auto at = [&](int r) {
    ++hit.evaluations;
    return evaluate(image_, edges_, theta0_, dtheta_, r, sin_phi_[r], cos_phi_[r], a, b);
  };

  // Stage 1: two neighbouring scanlines between which Δ turns from negative (the line in front of
  // the surface) to non-negative (behind it). Along a line pointing up out of 2.5-D terrain, Δ
  // changes sign once: every point below the visible surface point is underground or hidden. So
  // a neighbouring cell's bracket (the hint) is the place to start, and any (−, +) pair of
  // consecutive scanlines is the crossing; without a hint, or when the hint's neighbourhood has
  // gaps, the walk goes down the line from its top (the paper's first stage).
  int r1 = -1, r2 = -1;
  Sample s1, s2;
  if (hint && *hint >= 0 && *hint + 1 < rows) {
    int r = *hint;
    Sample up = at(r), down = at(r + 1);
    int step = 0;
    if (up.valid && down.valid) {
      if (up.delta < 0 && down.delta >= 0) r1 = r, r2 = r + 1, s1 = up, s2 = down;
      else step = down.delta < 0 ? 1 : -1;  // the crossing is further down the image, or up
    }
    for (int k = 0; step != 0 && r1 < 0 && k < rows; ++k) {
      if (step > 0) {
        if (r + 2 >= rows) break;
        ++r, up = down, down = at(r + 1);
      } else {
        if (r - 1 < 0) break;
        --r, down = up, up = at(r);
      }
      if (!up.valid || !down.valid) break;
      if (up.delta < 0 && down.delta >= 0) r1 = r, r2 = r + 1, s1 = up, s2 = down;
    }
  }
  if (r1 < 0) {
    double s_lo, s_hi;
    if (bounds_.isEmpty() || !clipToBox(bounds_, u, v, s_lo, s_hi)) return hit;
    // Scan angles of the segment's ends; φ(s) is monotonic along a line.
    const Eigen::Vector3d top = a + s_hi * b, bottom = a + s_lo * b;
    // A line wholly to one side of the field of view meets no pixel: θ = asin(x/ρ) of both ends
    // beyond the same image edge (θ is monotonic along the segment's projection too).
    const double t_top = std::asin(top.x() / top.norm()), t_bottom = std::asin(bottom.x() / bottom.norm());
    const double t_last = theta0_ + dtheta_ * (image_.cols() - 1);
    if ((t_top < theta0_ && t_bottom < theta0_) || (t_top > t_last && t_bottom > t_last)) return hit;
    const double rf_top = (phi0_ - std::atan2(top.z(), top.y())) / dphi_;
    const double rf_bottom = (phi0_ - std::atan2(bottom.z(), bottom.y())) / dphi_;
    const int step = rf_bottom >= rf_top ? 1 : -1;
    int r = step > 0 ? std::max(int(std::ceil(rf_top)), 0) : std::min(int(std::floor(rf_top)), rows - 1);
    const int r_end = step > 0 ? int(std::floor(rf_bottom)) : int(std::ceil(rf_bottom));
    Sample prev;
    int prev_row = -1;
    for (; step > 0 ? (r <= r_end && r < rows) : (r >= r_end && r >= 0); r += step) {
      const Sample cur = at(r);
      if (!cur.valid) {
        prev_row = -1;  // a gap (no return, out of view) is never bridged
        continue;
      }
      if (cur.delta >= 0) {
        // Below its first point behind the surface, a line stays behind it (single crossing):
        // either the scanline above brackets the crossing, or the line has no visible point.
        if (prev_row >= 0 && prev.delta < 0) r1 = prev_row, r2 = r, s1 = prev, s2 = cur;
        break;
      }
      prev = cur;
      prev_row = r;
    }
    if (r1 < 0) return hit;
  }
  if (hint) *hint = std::min(r1, r2);

  // Stage 2: search between the two scanlines until the bracket in φ is below ε.
  const double phi_r1 = image_.phi[r1];
  double phi1 = phi_r1, phi2 = image_.phi[r2];
  double d1 = s1.delta, d2 = s2.delta;
  // The crossing is at an occluding edge when edge pixels lie on both sides of it — on both
  // scanlines of the bracket, or in both columns of the final cell. Edge pixels come in pairs
  // across a discontinuity, so a visible point beside one (on a ledge's lip) has edge pixels on
  // one side only and stays known.
  const bool row1_edge = s1.edges != 0, row2_edge = s2.edges != 0;
  Sample last = s2;
  int kept_side = 0;
  auto evalPhi = [&](double phi) {
    double sp, cp;
    sinCosNear(sin_phi_[r1], cos_phi_[r1], phi_r1 - phi, sp, cp);
    ++hit.evaluations;
    return evaluate(image_, edges_, theta0_, dtheta_, (phi0_ - phi) / dphi_, sp, cp, a, b);
  };
  auto take = [&](double phi, const Sample& m) {  // narrow the bracket to the side m is on
    last = m;
    if (m.delta < 0) {
      phi1 = phi, d1 = m.delta;
      if (kept_side == -1) d2 *= 0.5;  // Illinois: the far end stayed twice, halve it
      kept_side = -1;
    } else {
      phi2 = phi, d2 = m.delta;
      if (kept_side == 1) d1 *= 0.5;
      kept_side = 1;
    }
  };
  const double eps = config_.epsilon_rad;
  for (int it = 0; it < 200 && std::abs(phi2 - phi1) >= eps && d2 != 0.0; ++it) {
    double phi = 0.5 * (phi1 + phi2);
    if (!config_.bisection) {
      const double secant = phi1 - d1 * (phi2 - phi1) / (d2 - d1);
      const double lo = std::min(phi1, phi2), hi = std::max(phi1, phi2);
      if (secant > lo && secant < hi) phi = secant;
    }
    const Sample m = evalPhi(phi);
    if (!m.valid) return hit;  // the bracket reaches a pixel without a return: unknown
    take(phi, m);
    // Within a pixel cell Δ(φ) is nearly linear, so a secant step lands within ε of the root:
    // probe ε/2 to its far side, and the bracket closes to below ε in one more evaluation.
    if (!config_.bisection && std::abs(phi2 - phi1) >= eps) {
      const double toward = m.delta < 0 ? phi2 : phi1;
      const double probe = phi + std::copysign(0.499 * eps, toward - phi);
      if ((probe - phi1) * (probe - phi2) < 0) {
        const Sample q = evalPhi(probe);
        if (!q.valid) return hit;
        take(probe, q);
      }
    }
  }
  // Which way the final cell's discontinuity runs: edge pixels mark both sides of a break but not
  // its direction, so compare the cell's largest range jump across scanlines with that across
  // columns.
  const unsigned e = last.edges;
  double jump_rows = 0, jump_cols = 0;
  if (e) {
    const auto rng = [&](int k) { return double(image_.range(last.r0 + k / 2, last.c0 + k % 2)); };
    if (image_.valid(last.r0, last.c0) && image_.valid(last.r0, last.c0 + 1) &&
        image_.valid(last.r0 + 1, last.c0) && image_.valid(last.r0 + 1, last.c0 + 1)) {
      jump_rows = std::max(std::abs(rng(0) - rng(2)), std::abs(rng(1) - rng(3)));
      jump_cols = std::max(std::abs(rng(0) - rng(1)), std::abs(rng(2) - rng(3)));
    }
  }
  const bool across_rows = (row1_edge && row2_edge) || ((e & 3u) && (e & 12u) && jump_rows >= jump_cols);
  const bool across_cols = (e & 5u) && (e & 10u) && jump_cols > jump_rows;
  if (across_rows || across_cols) {
    hit.state = CellState::Shadow;  // the locus meets the image at an occluding edge
    return hit;
  }
  // The root of the final bracket's chord (its midpoint under plain bisection).
  const double phi =
      config_.bisection || d2 == d1 ? 0.5 * (phi1 + phi2) : phi1 - d1 * (phi2 - phi1) / (d2 - d1);
  const Sample f = evalPhi(phi);
  const Sample& fin = f.valid ? f : last;
  hit.state = CellState::Known;
  hit.s = fin.s;
  hit.point = u + fin.s * v;
  hit.phi = phi;
  hit.theta = fin.theta;
  hit.rho = fin.rho;
  hit.sigma = sigmaAlongLine(fin.r0, fin.c0, fin.w, fin.rho, a + fin.s * b, b);
  return hit;
}

ElevationMap LocusMapper::map(const MapGrid& grid) const {
  ElevationMap out(grid);
  tbb::parallel_for(tbb::blocked_range<int>(0, grid.rows), [&](const tbb::blocked_range<int>& rows) {
    for (int r = rows.begin(); r != rows.end(); ++r) {
      int hint = -1;  // the previous cell's scanline: neighbours cross the image close together
      for (int c = 0; c < grid.cols; ++c) {
        const Eigen::Vector2d xy = grid.center(r, c);
        const LocusHit hit = intersect({xy.x(), xy.y(), 0.0}, Eigen::Vector3d::UnitZ(), &hint);
        if (hit.state == CellState::Known) out.setKnown(r, c, float(hit.point.z()), float(hit.sigma));
        else out.setUnknown(r, c, hit.state);
      }
    }
  });
  return out;
}

ElevationMap LocusMapper::mapPolygon(const std::vector<Eigen::Vector2d>& polygon, double cell_m) const {
  if (polygon.size() < 3) throw std::invalid_argument("LocusMapper::mapPolygon: needs at least 3 vertices");
  Eigen::AlignedBox2d box;
  for (const auto& p : polygon) box.extend(p);
  const MapGrid grid = MapGrid::covering(box.min().x(), box.max().x(), box.min().y(), box.max().y(), cell_m);
  ElevationMap out(grid);
  tbb::parallel_for(tbb::blocked_range<int>(0, grid.rows), [&](const tbb::blocked_range<int>& rows) {
    for (int r = rows.begin(); r != rows.end(); ++r)
      for (int c = 0; c < grid.cols; ++c) {
        const Eigen::Vector2d xy = grid.center(r, c);
        if (!insidePolygon(polygon, xy)) continue;
        const LocusHit hit = elevationAt(xy.x(), xy.y());
        if (hit.state == CellState::Known) out.setKnown(r, c, float(hit.point.z()), float(hit.sigma));
        else out.setUnknown(r, c, hit.state);
      }
  });
  return out;
}

}  // namespace ambler::perception
