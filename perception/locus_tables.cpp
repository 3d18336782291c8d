// The locus mapper's per-image part: the constructor's tables (returns, edge pixels and the
// inputs of σ per 2×2 pixel cell; asin in row and column units) and σ along a line
// (docs/locus.md). The search is in locus_mapper.cpp.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "perception/locus_mapper.hpp"
#include "perception/locus_sample.hpp"

namespace ambler::perception {

using namespace locus;
using Sample = LocusSample;

namespace {

bool checkEven(const std::vector<double>& a, double step) {
  for (std::size_t i = 1; i < a.size(); ++i)
    if (std::abs((a[i] - a[0]) - double(i) * step) > 1e-9) return false;
  return true;
}

// Per pixel, once per image: its surface point in the sensor frame (eq. 1) and the squared
// second differences D² = (a(−1) − 2a(0) + a(+1))² of the ranges centred on it, across scanlines
// and along them (NaN where a pixel of the three did not return or is off the image).
struct PixelTables {
  int rows, cols;
  std::vector<Eigen::Vector3d> point;
  std::vector<char> returned;
  std::vector<double> d2_rows, d2_cols;

  PixelTables(const RangeImage& img, const std::vector<double>& sin_phi, const std::vector<double>& cos_phi,
              const std::vector<double>& sin_theta, const std::vector<double>& cos_theta)
      : rows(img.rows()), cols(img.cols()), point(std::size_t(rows) * cols), returned(point.size()),
        d2_rows(point.size()), d2_cols(point.size()) {
    const auto range = [&](int r, int c) {
      return r < 0 || c < 0 || r >= rows || c >= cols ? kNaN : double(img.range(r, c));
    };
    tbb::parallel_for(tbb::blocked_range<int>(0, rows), [&](const tbb::blocked_range<int>& rs) {
      for (int r = rs.begin(); r != rs.end(); ++r)
        for (int c = 0; c < cols; ++c) {
          const std::size_t i = std::size_t(r) * cols + c;
          returned[i] = img.valid(r, c);
          const double rho = img.range(r, c), ct = cos_theta[c];
          point[i] = Eigen::Vector3d(rho * sin_theta[c], rho * cos_phi[r] * ct, rho * sin_phi[r] * ct);
          const double d_rows = range(r - 1, c) - 2 * range(r, c) + range(r + 1, c);
          const double d_cols = range(r, c - 1) - 2 * range(r, c) + range(r, c + 1);
          d2_rows[i] = d_rows * d_rows;  // NaN propagates: a missing pixel makes no difference
          d2_cols[i] = d_cols * d_cols;
        }
    });
  }
  // The surface point of pixel (r, c), if it is on the image and returned.
  bool pixelPoint(int r, int c, Eigen::Vector3d& p) const {
    if (r < 0 || c < 0 || r >= rows || c >= cols || !returned[std::size_t(r) * cols + c]) return false;
    p = point[std::size_t(r) * cols + c];
    return true;
  }
};

// The median of w[0..n), n ≥ 1 (sorted in place; n is small).
inline double medianOf(double* w, int n) {
  for (int i = 1; i < n; ++i)
    for (int j = i; j > 0 && w[j] < w[j - 1]; --j) std::swap(w[j], w[j - 1]);
  return n % 2 ? w[n / 2] : 0.5 * (w[n / 2 - 1] + w[n / 2]);
}

// The local surface normal (sensor frame) around the 2×2 cell at (r0, c0), from the widest
// returned span across it in each image direction (wider spans average out range noise).
Eigen::Vector3d localNormal(const PixelTables& px, int r0, int c0, const Eigen::Vector3d& up) {
  Eigen::Vector3d t[2];
  bool ok[2] = {false, false};
  for (int dir = 0; dir < 2; ++dir)
    for (int span = 2; span >= 0 && !ok[dir]; --span)
      for (int k = 0; k < 2 && !ok[dir]; ++k) {
        Eigen::Vector3d p = Eigen::Vector3d::Zero(), q = Eigen::Vector3d::Zero();
        if (dir == 0)  // along the scanline (θ)
          ok[dir] = px.pixelPoint(r0 + k, c0 - span / 2, p) && px.pixelPoint(r0 + k, c0 + 1 + (span + 1) / 2, q);
        else  // across scanlines (φ)
          ok[dir] = px.pixelPoint(r0 - span / 2, c0 + k, p) && px.pixelPoint(r0 + 1 + (span + 1) / 2, c0 + k, q);
        if (ok[dir]) t[dir] = q - p;
      }
  if (!ok[0] || !ok[1]) return up;
  const Eigen::Vector3d n = t[0].cross(t[1]);
  return n.norm() > 0 ? Eigen::Vector3d(n.normalized()) : up;
}

// The mean squared second difference of the ranges around the 2×2 cell at (r0, c0), across
// scanlines or along them: over the differences centred on both samples of both pixel lines
// bounding the cell. NaN if none is available.
double meanSecondDifference2(const PixelTables& px, int r0, int c0, bool across_rows) {
  double sum = 0;
  int n = 0;
  for (int side = 0; side < 2; ++side)            // the two pixel lines bounding the cell
    for (int centre = 0; centre < 2; ++centre) {  // second differences centred on each sample
      const int r = across_rows ? r0 + centre : r0 + side, c = across_rows ? c0 + side : c0 + centre;
      const double d2 = (across_rows ? px.d2_rows : px.d2_cols)[std::size_t(r) * px.cols + c];
      if (std::isnan(d2)) continue;
      sum += d2;
      ++n;
    }
  return n == 0 ? kNaN : sum / n;
}

// The variance of linear interpolation between samples of a rough surface, as a range error at
// fraction f ∈ [0, 1]. The surface between pixels is modelled as fractional Brownian motion with
// Hurst exponent H: for samples h apart, Var[interpolation error] = σ²h^2H·g(f), with
// g(f) = f^2H(1−f) + (1−f)^2H·f − f(1−f), and the second difference has
// E[D²] = σ²h^2H·(4 − 2^2H) plus the noise's 6σ_p² (docs/locus.md). g_table holds
// g/(4 − 2^2H) at kRoughnessSteps + 1 points.
inline double roughnessVariance(double mean_d2, double f, double var_pixel, const double* g_table) {
  if (std::isnan(mean_d2)) return 0.0;
  const double x = f * kRoughnessSteps;
  const int i = std::min(int(x), kRoughnessSteps - 1);
  const double g = g_table[i] + (x - i) * (g_table[i + 1] - g_table[i]);
  return g * std::max(0.0, mean_d2 - 6.0 * var_pixel);
}

}  // namespace

LocusMapper::LocusMapper(const RangeImage& image, const SensorModel& sensor, const Raster<std::uint8_t>* edges,
                         const LocusConfig& config, const Eigen::Isometry3d& T_WM)
    : image_(image), edges_(edges), sensor_(sensor), config_(config), T_WM_(T_WM), rows_(image.rows()),
      cols_(image.cols()) {
  if (rows_ < 2 || cols_ < 2)
    throw std::invalid_argument("LocusMapper: the range image needs at least 2x2 pixels");
  if (edges && (edges->rows() != rows_ || edges->cols() != cols_))
    throw std::invalid_argument("LocusMapper: the edge mask and the range image differ in size");
  if (!(config.far_gap_scanlines >= 0 && config.far_gap_scanlines <= 1))
    throw std::invalid_argument("LocusMapper: far_gap_scanlines must be in [0, 1]");
  phi0_ = image.phi[0];
  dphi_ = image.phi[0] - image.phi[1];
  theta0_ = image.theta[0];
  dtheta_ = image.theta[1] - image.theta[0];
  if (!(dphi_ > 0) || !(dtheta_ > 0) || !checkEven(image.phi, -dphi_) || !checkEven(image.theta, dtheta_))
    throw std::invalid_argument("LocusMapper: scan angles must be evenly spaced, φ falling, θ rising");
  // The sensor's pose in the map frame M; M is the world when T_WM is the identity (then nothing
  // is multiplied, so the bits are those of the world-frame mapper).
  if (!isGravityAligned(T_WM)) throw std::invalid_argument("LocusMapper: the map frame is not gravity-aligned");
  const Eigen::Isometry3d T_MS = isWorldFrame(T_WM) ? image.T_WS : Eigen::Isometry3d(T_WM.inverse() * image.T_WS);
  const Eigen::Isometry3d T_SW = T_MS.inverse();
  rot_SW_ = T_SW.linear();
  trans_SW_ = T_SW.translation();
  // World z in the sensor frame, summed as lineOf sums R·v (lineOf returns it for vertical lines).
  for (int i = 0; i < 3; ++i) up_[i] = (rot_SW_(i, 0) * 0.0 + rot_SW_(i, 1) * 0.0) + rot_SW_(i, 2) * 1.0;
  // g(f)/(4 − 2^2H) of the fBm roughness term, tabulated (f in [0, 1]; g is smooth): one table
  // across scanlines, one along them. They differ by the footprint's term alone (docs/locus.md,
  // "The footprint"): with mixed pixels the sensor reports the mean range over its footprint, a
  // disk of radius a = divergence/2 sampled at its centre (weight 1/4) and six points on a ring of
  // radius b = √(2/3)·a (1/8 each). On fBm with structure function S(δ) = C·δ^2H that mean departs
  // from the centre's range with variance K·S(b), K = (36 − 3·(2 + 2·3^H + 2^2H))/64 (0.143 at
  // H = 0.7). C comes from each direction's D² as for the interpolation (E[D²] = C·h^2H·(4 − 2^2H),
  // h the pixel spacing), half the footprint's term from each direction.
  const double h2 = 2 * config.roughness_hurst;
  const double K = (36 - 3 * (2 + 2 * std::pow(3.0, config.roughness_hurst) + std::pow(2.0, h2))) / 64;
  const double b = std::sqrt(2.0 / 3.0) * 0.5 * sensor.beamDivergence();
  for (int dir = 0; dir < 2; ++dir) {
    const double spacing = dir == 0 ? dphi_ : dtheta_;
    const double footprint =
        config.footprint_sigma && sensor.mixed_pixels ? 0.5 * K * std::pow(b / spacing, h2) : 0.0;
    for (int i = 0; i <= kRoughnessSteps; ++i) {
      const double f = double(i) / kRoughnessSteps;
      roughness_g_.push_back((std::pow(f, h2) * (1 - f) + std::pow(1 - f, h2) * f - f * (1 - f) + footprint) /
                             (4 - std::pow(2.0, h2)));
    }
  }
  for (double phi : image.phi) {
    sin_phi_.push_back(std::sin(phi));
    cos_phi_.push_back(std::cos(phi));
  }
  for (double theta : image.theta) {
    sin_theta_.push_back(std::sin(theta));
    cos_theta_.push_back(std::cos(theta));
  }
  inv_dtheta_ = 1.0 / dtheta_;
  inv_dphi_ = 1.0 / dphi_;
  quantization_var_ = sensor.quantizationVariance();
  last_row_ = rows_ - 1;
  last_col_ = cols_ - 1;
  column_of_ = AngleTable(true, 3.0, theta0_, inv_dtheta_);  // |θ| ≤ 71.6°
  row_of_ = AngleTable(false, 0.95, phi0_, -1.0 / dphi_);     // |φ| ≤ 71.8°
  // The vertical direction's crossing denominators, shared by every map of this image.
  for (int r = 0; r < rows_; ++r) {
    const double den = up_.z() * cos_phi_[r] - up_.y() * sin_phi_[r];
    vertical_inv_den_.push_back(std::abs(den) < 1e-15 ? 0.0 : 1.0 / den);
  }
  const PixelTables pixels(image, sin_phi_, cos_phi_, sin_theta_, cos_theta_);
  for (std::size_t i = 0; i < pixels.point.size(); ++i)
    if (pixels.returned[i]) bounds_.extend(T_MS * pixels.point[i]);
  if (!bounds_.isEmpty()) {
    bounds_.min().array() -= config.z_margin_m;
    bounds_.max().array() += config.z_margin_m;
  }
  // The nearest return above each pixel, over column bands of 2^k pixels (clearAbove).
  above_levels_ = 1;
  while ((2 << (above_levels_ - 1)) <= cols_) ++above_levels_;
  const std::size_t plane = std::size_t(rows_) * cols_;
  above_min_.assign(plane * above_levels_, std::numeric_limits<float>::infinity());
  for (int r = 1; r < rows_; ++r)
    for (int c = 0; c < cols_; ++c) {
      const float q = image.range(r - 1, c);
      above_min_[std::size_t(r) * cols_ + c] =
          std::min(above_min_[std::size_t(r - 1) * cols_ + c], std::isnan(q) ? std::numeric_limits<float>::infinity() : q);
    }
  for (int k = 1; k < above_levels_; ++k) {
    const int half = 1 << (k - 1);
    const float* prev = above_min_.data() + (k - 1) * plane;
    float* cur = above_min_.data() + k * plane;
    for (std::size_t r = 0; r < std::size_t(rows_); ++r)
      for (int c = 0; c < cols_; ++c)
        cur[r * cols_ + c] = c + half < cols_ ? std::min(prev[r * cols_ + c], prev[r * cols_ + c + half]) : prev[r * cols_ + c];
  }
  // Per 2×2 cell: which pixels returned and which are edge pixels, and the inputs of σ.
  const std::size_t cells = std::size_t(rows_ - 1) * (cols_ - 1);
  cell_flags_.assign(cells + 3, 0);  // 3 bytes of padding: the lanes gather flags 4 bytes at a time
  cell_sigma_.resize(cells);
  tbb::parallel_for(tbb::blocked_range<int>(0, rows_ - 1), [&](const tbb::blocked_range<int>& rows) {
    for (int r = rows.begin(); r != rows.end(); ++r)
      for (int c = 0; c + 1 < cols_; ++c) {
        std::uint8_t flags = kAllReturned;
        for (int k = 0; k < 4; ++k) {
          const int rr = r + k / 2, cc = c + k % 2;
          if (!image.valid(rr, cc)) flags &= ~kAllReturned;
          if (edges && (*edges)(rr, cc)) flags |= std::uint8_t(1u << k);
        }
        cell_flags_[cellIndex(r, c)] = flags;
        CellSigma& cs = cell_sigma_[cellIndex(r, c)];
        cs.normal = localNormal(pixels, r, c, up_);
        cs.d2_rows = config.roughness ? meanSecondDifference2(pixels, r, c, true) : kNaN;
        cs.d2_cols = config.roughness ? meanSecondDifference2(pixels, r, c, false) : kNaN;
      }
  });
  if (!config.bridge_sigma) return;
  // The inputs of bridge σ (docs/locus.md, "Bridged occlusions"), per 2×2 cell. Heights are the
  // returns' world z (their component along up_); a cell's mean squared height second difference
  // is over the same four differences as meanSecondDifference2's. A link's jump is its range
  // difference's departure from the trend, the median of the four differences around it along
  // its line (two either side): across scanlines only a far side farther than the trend counts
  // (a surface turned towards the sensor hides nothing), along them either sign.
  const auto height = [&](int r, int c) {
    Eigen::Vector3d p;
    return pixels.pixelPoint(r, c, p) ? p.dot(up_) : kNaN;
  };
  const auto meanD2z = [&](int r0, int c0, bool across_rows) {
    const int dr = across_rows ? 1 : 0, dc = across_rows ? 0 : 1;
    double sum = 0;
    int n = 0;
    for (int side = 0; side < 2; ++side)
      for (int centre = 0; centre < 2; ++centre) {
        const int r = across_rows ? r0 + centre : r0 + side, c = across_rows ? c0 + side : c0 + centre;
        const double d = height(r - dr, c - dc) - 2 * height(r, c) + height(r + dr, c + dc);
        if (std::isnan(d)) continue;  // a missing pixel makes no difference
        sum += d * d;
        ++n;
      }
    return n == 0 ? kNaN : sum / n;
  };
  const auto range = [&](int r, int c) {
    return r < 0 || c < 0 || r >= rows_ || c >= cols_ || !image.valid(r, c) ? kNaN : double(image.range(r, c));
  };
  // The jump of the link from (r, c) to the next pixel across scanlines (r + 1) or along them.
  const auto jump = [&](int r, int c, bool across_rows) {
    const int dr = across_rows ? 1 : 0, dc = across_rows ? 0 : 1;
    // Across scanlines the difference is far minus near (row r is above row r + 1, farther).
    const auto diff = [&](int k) {
      const double a = range(r + k * dr, c + k * dc), b = range(r + (k + 1) * dr, c + (k + 1) * dc);
      return across_rows ? a - b : b - a;
    };
    const double x = diff(0);
    double w[4];
    int n = 0;
    for (const int k : {-2, -1, 1, 2})
      if (const double v = diff(k); !std::isnan(v)) w[n++] = v;
    if (std::isnan(x) || n == 0) return 0.0;
    const double t = medianOf(w, n);
    return across_rows ? std::max(0.0, x - t) : std::abs(x - t);
  };
  cell_bridge_.resize(cell_sigma_.size());
  tbb::parallel_for(tbb::blocked_range<int>(0, rows_ - 1), [&](const tbb::blocked_range<int>& rows) {
    for (int r = rows.begin(); r != rows.end(); ++r)
      for (int c = 0; c + 1 < cols_; ++c) {
        CellBridge& cb = cell_bridge_[cellIndex(r, c)];
        cb.d2z_rows = config.roughness ? meanD2z(r, c, true) : kNaN;
        cb.d2z_cols = config.roughness ? meanD2z(r, c, false) : kNaN;
        cb.jump_rows = std::max(jump(r, c, true), jump(r, c + 1, true));
        cb.jump_cols = std::max(jump(r, c, false), jump(r + 1, c, false));
      }
  });
}

// f = asin or atan as a quadratic Taylor polynomial about the middle of each of 4096 intervals of
// x over [−limit, limit]. The cubic term f‴·d³/6, |d| ≤ limit/4096, is the error: for atan
// (|f‴| ≤ 2, limit 3) below 1.3e-10 rad; for asin (f‴ = (1 + 2x²)/(1 − x²)^(5/2), limit 0.95)
// below 3e-11 rad for |x| ≤ sin 45° and 2e-9 rad at the table's end (asinf errs by 6e-8).
LocusMapper::AngleTable::AngleTable(bool atan, double limit_, double offset_, double scale_)
    : is_atan(atan), offset(offset_), scale(scale_), limit(limit_), index_scale(kSize / (2 * limit_)),
      step(2 * limit_ / kSize) {
  for (int k = 0; k < kSize; ++k) {
    const double x = -limit + (k + 0.5) * step;  // the lanes compute it the same way
    double f, d1, d2;  // f, f′ and f″/2 at x
    if (atan) {
      const double q = 1.0 + x * x;
      f = std::atan(x), d1 = 1.0 / q, d2 = -x / (q * q);
    } else {
      const double q = 1.0 - x * x;
      f = std::asin(x), d1 = 1.0 / std::sqrt(q), d2 = x / (2.0 * q * std::sqrt(q));
    }
    polys.push_back({x, (f - offset) * scale, d1 * scale, d2 * scale});
  }
  polys.push_back(polys.back());  // x = limit exactly indexes one past the last interval
}


// σ of the position along the line (docs/locus.md): the range error of the interpolated image —
// the pixels' noise, σ_p² = (kρ²)² + q²/12, weighted by Σw², plus the surface's roughness between
// pixels that interpolation cannot know — carried along the beam d = p/ρ onto the local surface
// (normal n) and from there onto the line b: σ_s = σ_I·|d·n| / |b·n|. The point p (sensor frame)
// is at range rho, in the 2×2 cell (r0, c0) at fractions fr, fc ∈ [0, 1].
double LocusMapper::sigmaAlongLine(int r0, int c0, double fr, double fc, double rho, const Eigen::Vector3d& p,
                                   const Eigen::Vector3d& b) const {
  // Σw² of the bilinear weights factorises: ((1−fr)² + fr²)·((1−fc)² + fc²).
  const double gr = 1 - fr, gc = 1 - fc;
  const double sum_w2 = (gr * gr + fr * fr) * (gc * gc + fc * fc);
  const double var_pixel = sensor_.rangeVariance(rho);
  const CellSigma& cs = cell_sigma_[cellIndex(r0, c0)];
  const double rough = roughnessVariance(cs.d2_rows, fr, var_pixel, roughness_g_.data()) +
                       roughnessVariance(cs.d2_cols, fc, var_pixel, roughness_g_.data() + kRoughnessSteps + 1);
  if (config_.bridge_sigma) return bridgeSigmaAlongLine(r0, c0, fr, fc, rho, p, b, sum_w2, var_pixel, rough);
  const double var_rho = var_pixel * sum_w2 + rough;
  const Eigen::Vector3d& n = cs.normal;
  const double pn = (p.x() * n.x() + p.y() * n.y()) + p.z() * n.z(), bn = (b.x() * n.x() + b.y() * n.y()) + b.z() * n.z();
  return std::sqrt(var_rho) * std::abs(pn) / (rho * std::max(std::abs(bn), 0.05));
}

// σ with LocusConfig::bridge_sigma (docs/locus.md, "Bridged occlusions"). The pixels' noise as in
// sigmaAlongLine. The roughness between pixels: the larger of sigmaAlongLine's term (the fBm model
// on the ranges' second differences, carried to the line through the local normal) and the same
// model on the returns' heights (less the noise's 6σ_p²·d_z², d_z the beam's vertical component),
// carried as a height error: where an occlusion the map bridges tilts the local normal towards the
// rays, the first shrinks and the second does not; on a plane the ranges' curvature, which
// interpolation in range errs by, shows in the first only. And a bracket whose link jumps beyond
// its trend by J (range) may hide ground down to about J·|d_z| below the interpolation: with the
// edge anywhere in the bracket, the interpolation at fraction f errs by f(1 − f)·(J·d_z)² in
// variance. J is taken less 2·√2·σ_p, twice the noise of a difference of two pixels. A height error
// δz of the surface moves the line's crossing by δz·(n·up)/(b·n).
double LocusMapper::bridgeSigmaAlongLine(int r0, int c0, double fr, double fc, double rho, const Eigen::Vector3d& p,
                                         const Eigen::Vector3d& b, double sum_w2, double var_pixel, double rough) const {
  const Eigen::Vector3d& n = cell_sigma_[cellIndex(r0, c0)].normal;
  const CellBridge& cb = cell_bridge_[cellIndex(r0, c0)];
  const double abs_bn = std::max(std::abs(b.dot(n)), 0.05);
  const double to_range = p.dot(n) / (rho * abs_bn), to_line = n.dot(up_) / abs_bn;
  const double dz = p.dot(up_) / rho, var_z = var_pixel * dz * dz;
  const double rough_z = roughnessVariance(cb.d2z_rows, fr, var_z, roughness_g_.data()) +
                         roughnessVariance(cb.d2z_cols, fc, var_z, roughness_g_.data() + kRoughnessSteps + 1);
  const double slack = 2 * std::sqrt(2 * var_pixel);
  const double hr = std::max(0.0, cb.jump_rows - slack) * dz, hc = std::max(0.0, cb.jump_cols - slack) * dz;
  const double hidden = fr * (1 - fr) * hr * hr + fc * (1 - fc) * hc * hc;
  const double roughness = std::max(rough * to_range * to_range, rough_z * to_line * to_line);
  return std::sqrt(var_pixel * sum_w2 * to_range * to_range + roughness + hidden * to_line * to_line);
}

}  // namespace ambler::perception
