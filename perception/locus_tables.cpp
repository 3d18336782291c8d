// The locus mapper's per-image part: the constructor's tables (returns, edge pixels and the
// inputs of σ per 2×2 pixel cell; asin in row and column units) and σ along a line
// (docs/locus.md). The search is in locus_mapper.cpp.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
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

// The mean squared second difference D = a(−1) − 2a(0) + a(+1) of the ranges around the 2×2 cell
// at (r0, c0), across scanlines or along them: over the differences centred on both samples of
// both pixel lines bounding the cell. NaN if none is available.
double meanSecondDifference2(const RangeImage& img, int r0, int c0, bool across_rows) {
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
  return n == 0 ? kNaN : sum / n;
}

// The variance of linear interpolation between samples of a rough surface, as a range error at
// fraction f. The surface between pixels is modelled as fractional Brownian motion with Hurst
// exponent H: for samples h apart, Var[interpolation error] = σ²h^2H·g(f), with
// g(f) = f^2H(1−f) + (1−f)^2H·f − f(1−f), and the second difference has
// E[D²] = σ²h^2H·(4 − 2^2H) plus the noise's 6σ_p² (docs/locus.md).
double roughnessVariance(double mean_d2, double f, double var_pixel, const std::vector<double>& g_table) {
  if (std::isnan(mean_d2)) return 0.0;
  const double x = std::clamp(f, 0.0, 1.0) * double(g_table.size() - 1);
  const std::size_t i = std::min(std::size_t(x), g_table.size() - 2);
  const double g = g_table[i] + (x - double(i)) * (g_table[i + 1] - g_table[i]);
  return g * std::max(0.0, mean_d2 - 6.0 * var_pixel);
}

}  // namespace

LocusMapper::LocusMapper(const RangeImage& image, const EdgeMask* edges, const LocusConfig& config)
    : image_(image), edges_(edges), config_(config), T_SW_(image.T_WS.inverse()), rows_(image.rows()),
      cols_(image.cols()) {
  if (rows_ < 2 || cols_ < 2)
    throw std::invalid_argument("LocusMapper: the range image needs at least 2x2 pixels");
  if (edges && (edges->rows() != rows_ || edges->cols() != cols_))
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
  inv_dtheta_ = 1.0 / dtheta_;
  last_row_ = rows_ - 1;
  last_col_ = cols_ - 1;
  column_of_ = AsinTable(theta0_, inv_dtheta_);
  row_of_ = AsinTable(phi0_, -1.0 / dphi_);
  for (int r = 0; r < rows_; ++r)
    for (int c = 0; c < cols_; ++c)
      if (image.valid(r, c)) bounds_.extend(image.pointWorld(r, c));
  if (!bounds_.isEmpty()) {
    bounds_.min().array() -= config.z_margin_m;
    bounds_.max().array() += config.z_margin_m;
  }
  // Per 2×2 cell: which pixels returned and which are edge pixels, and the inputs of σ.
  cell_flags_.assign(std::size_t(rows_ - 1) * (cols_ - 1), 0);
  cell_sigma_.resize(cell_flags_.size());
  const AngleTables angles{sin_phi_, cos_phi_, sin_theta_, cos_theta_};
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
        cs.normal = localNormal(image, angles, r, c, up_);
        cs.d2_rows = config.roughness ? meanSecondDifference2(image, r, c, true) : kNaN;
        cs.d2_cols = config.roughness ? meanSecondDifference2(image, r, c, false) : kNaN;
      }
  });
}

// asin as a quadratic Taylor polynomial about the middle of each of 2048 intervals of x: the
// cubic term, (1 + 2x²)/(1 − x²)^(5/2)·d³/6 with |d| ≤ 1/2048, is below 2e-10 rad for
// |x| ≤ sin 45° and 2e-8 rad at the table's end (asinf errs by 6e-8).
LocusMapper::AsinTable::AsinTable(double offset_, double scale_) : offset(offset_), scale(scale_) {
  for (int k = 0; k < AsinTable::kSize; ++k) {
    const double x = -1.0 + (k + 0.5) * (2.0 / AsinTable::kSize), q = 1.0 - x * x;
    polys.push_back({x, (std::asin(x) - offset) * scale, scale / std::sqrt(q), scale * x / (2.0 * q * std::sqrt(q))});
  }
}


// σ of the position along the line (docs/locus.md): the range error of the interpolated image —
// the pixels' noise, σ_p² = (kρ²)² + q²/12, weighted by Σw², plus the surface's roughness between
// pixels that interpolation cannot know — carried along the beam d onto the local surface
// (normal n) and from there onto the line b: σ_s = σ_I·|d·n| / |b·n|.
double LocusMapper::sigmaAlongLine(const Sample& at, const Eigen::Vector3d& p, const Eigen::Vector3d& b) const {
  const double w[4] = {(1 - at.fr) * (1 - at.fc), (1 - at.fr) * at.fc, at.fr * (1 - at.fc), at.fr * at.fc};
  const double sum_w2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2] + w[3] * w[3];
  const double noise = config_.noise_k * at.rho * at.rho;
  const double var_pixel = noise * noise + config_.quantization_m * config_.quantization_m / 12.0;
  const CellSigma& cs = cell_sigma_[cellIndex(at.r0, at.c0)];
  const double rough = roughnessVariance(cs.d2_rows, at.fr, var_pixel, roughness_g_) +
                       roughnessVariance(cs.d2_cols, at.fc, var_pixel, roughness_g_);
  const double var_rho = var_pixel * sum_w2 + rough;
  const Eigen::Vector3d d = p / at.rho;
  return std::sqrt(var_rho) * std::abs(d.dot(cs.normal)) / std::max(std::abs(b.dot(cs.normal)), 0.05);
}

}  // namespace ambler::perception
