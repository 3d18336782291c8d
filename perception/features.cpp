#include "perception/features.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace ambler::perception {

namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
// σ_z below this (ground truth has 0) is taken as this: the sensor model's 1 mm floor.
constexpr double kSigmaFloor = 1e-3;

struct Fit {
  bool ok = false;
  double k_convex = 0, k_other = 0, sigma = 0;
};

// The weighted quadratic fit of half-width h about cell (r, c), and its principal curvatures.
Fit fitAt(const ElevationMap& map, int r, int c, int h) {
  const MapGrid& g = map.grid();
  using Mat6 = Eigen::Matrix<double, 6, 6>;
  using Vec6 = Eigen::Matrix<double, 6, 1>;
  Mat6 N = Mat6::Zero();
  Vec6 rhs = Vec6::Zero();
  int n = 0;
  const double z0 = map.elevation()(r, c);
  for (int rr = std::max(0, r - h); rr <= std::min(g.rows - 1, r + h); ++rr)
    for (int cc = std::max(0, c - h); cc <= std::min(g.cols - 1, c + h); ++cc) {
      if (map.stateAt(rr, cc) != CellState::Known) continue;
      const double x = (cc - c) * g.cell, y = (r - rr) * g.cell;  // north-up: row r − 1 is +y
      const double s = std::max(double(map.sigma()(rr, cc)), kSigmaFloor);
      const double w = std::isfinite(s) ? 1.0 / (s * s) : 1.0 / (kSigmaFloor * kSigmaFloor);
      Vec6 a;
      a << 1, x, y, x * x, x * y, y * y;
      N += w * a * a.transpose();
      rhs += w * a * (double(map.elevation()(rr, cc)) - z0);
      ++n;
    }
  Fit f;
  if (n < 6) return f;
  const Eigen::LDLT<Mat6> ldlt(N);
  if (ldlt.info() != Eigen::Success || !(ldlt.rcond() > 1e-12)) return f;
  const Vec6 coef = ldlt.solve(rhs);
  const Mat6 cov = ldlt.solve(Mat6::Identity());
  // z_x, z_y, z_xx, z_xy, z_yy at the cell centre.
  const double p = coef(1), q = coef(2), zxx = 2 * coef(3), zxy = coef(4), zyy = 2 * coef(5);
  const double g1 = 1 + p * p + q * q;
  const double K = (zxx * zyy - zxy * zxy) / (g1 * g1);
  const double H = ((1 + q * q) * zxx - 2 * p * q * zxy + (1 + p * p) * zyy) / (2 * std::pow(g1, 1.5));
  const double disc = std::sqrt(std::max(H * H - K, 0.0));
  f.ok = true;
  f.k_convex = H - disc;
  f.k_other = H + disc;
  // σ of the second derivatives (z_xx, z_yy: twice the coefficients), the larger.
  f.sigma = 2 * std::sqrt(std::max(cov(3, 3), cov(5, 5)));
  return f;
}

void checkConfig(const FeatureConfig& c) {
  const bool ok = c.curvature_min > 0 && c.noise_sigmas >= 0 && c.window_max >= 1 && c.window_max <= 20 &&
                  c.min_cells >= 1 && c.point_extent_m >= 0 && c.line_elongation >= 1;
  if (!ok) throw std::invalid_argument("FeatureConfig: a value is out of range");
}

}  // namespace

CurvatureField principalCurvatures(const ElevationMap& map, const FeatureConfig& config) {
  checkConfig(config);
  const MapGrid& g = map.grid();
  CurvatureField out{Raster<float>::Constant(g.rows, g.cols, kNaN), Raster<float>::Constant(g.rows, g.cols, kNaN),
                     Raster<float>::Constant(g.rows, g.cols, kNaN), Raster<std::uint8_t>::Zero(g.rows, g.cols)};
  const double wanted = config.curvature_min / std::max(config.noise_sigmas, 1e-12);
  for (int r = 0; r < g.rows; ++r)
    for (int c = 0; c < g.cols; ++c) {
      if (map.stateAt(r, c) != CellState::Known) continue;
      Fit best;
      int used = 0;
      for (int h = 1; h <= config.window_max; ++h) {
        const Fit f = fitAt(map, r, c, h);
        if (!f.ok) continue;
        best = f, used = h;
        if (f.sigma <= wanted) break;
      }
      if (!best.ok) continue;
      out.k_convex(r, c) = float(best.k_convex);
      out.k_other(r, c) = float(best.k_other);
      out.sigma(r, c) = float(best.sigma);
      out.half_width(r, c) = std::uint8_t(used);
    }
  return out;
}

std::vector<Feature> extractFeatures(const ElevationMap& map, const FeatureConfig& config) {
  const CurvatureField k = principalCurvatures(map, config);
  const MapGrid& g = map.grid();
  Raster<std::uint8_t> flag = Raster<std::uint8_t>::Zero(g.rows, g.cols);
  for (int r = 0; r < g.rows; ++r)
    for (int c = 0; c < g.cols; ++c) {
      const float kc = k.k_convex(r, c);
      flag(r, c) = kc <= -config.curvature_min && kc <= -config.noise_sigmas * k.sigma(r, c);
    }
  std::vector<Feature> features;
  std::vector<Eigen::Vector2i> stack, set;
  for (int r0 = 0; r0 < g.rows; ++r0)
    for (int c0 = 0; c0 < g.cols; ++c0) {
      if (flag(r0, c0) != 1) continue;
      // The 8-connected set of flagged cells from (r0, c0); visited cells are marked 2.
      set.clear();
      stack.assign(1, {r0, c0});
      flag(r0, c0) = 2;
      while (!stack.empty()) {
        const Eigen::Vector2i p = stack.back();
        stack.pop_back();
        set.push_back(p);
        for (int dr = -1; dr <= 1; ++dr)
          for (int dc = -1; dc <= 1; ++dc) {
            const int rr = p.x() + dr, cc = p.y() + dc;
            if (rr < 0 || rr >= g.rows || cc < 0 || cc >= g.cols || flag(rr, cc) != 1) continue;
            flag(rr, cc) = 2;
            stack.push_back({rr, cc});
          }
      }
      if (int(set.size()) < config.min_cells) continue;
      std::sort(set.begin(), set.end(), [](const auto& a, const auto& b) {
        return a.x() != b.x() ? a.x() < b.x() : a.y() < b.y();
      });
      // Centre: curvature-weighted; shape: the cells' horizontal spread.
      Feature f;
      f.cells = int(set.size());
      double wsum = 0;
      Eigen::Vector2d mean_xy = Eigen::Vector2d::Zero();
      for (const auto& p : set) {
        const double w = -double(k.k_convex(p.x(), p.y()));
        const Eigen::Vector2d xy = g.center(p.x(), p.y());
        f.position += w * Eigen::Vector3d(xy.x(), xy.y(), map.elevation()(p.x(), p.y()));
        wsum += w;
        mean_xy += xy;
        f.strength += w;
      }
      f.position /= wsum;
      f.strength /= double(set.size());
      mean_xy /= double(set.size());
      Eigen::Matrix2d C = Eigen::Matrix2d::Zero();
      for (const auto& p : set) {
        const Eigen::Vector2d d = g.center(p.x(), p.y()) - mean_xy;
        C += d * d.transpose();
      }
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> pca(C);
      const Eigen::Vector2d axis = pca.eigenvectors().col(1), across = pca.eigenvectors().col(0);
      double lo = 1e300, hi = -1e300, lo2 = 1e300, hi2 = -1e300, st = 0, stt = 0, sz = 0, stz = 0;
      for (const auto& p : set) {
        const Eigen::Vector2d xy = g.center(p.x(), p.y());
        const double t = (xy - mean_xy).dot(axis), u = (xy - mean_xy).dot(across);
        const double z = map.elevation()(p.x(), p.y());
        lo = std::min(lo, t), hi = std::max(hi, t), lo2 = std::min(lo2, u), hi2 = std::max(hi2, u);
        st += t, stt += t * t, sz += z, stz += t * z;
        f.extent_m = std::max(f.extent_m, (xy - f.position.head<2>()).norm());
      }
      const double length = hi - lo + g.cell, width = hi2 - lo2 + g.cell;
      if (f.extent_m <= config.point_extent_m) {
        f.type = FeatureType::Point;
      } else if (length >= config.line_elongation * width) {
        f.type = FeatureType::Line;
        f.length_m = length;
        // The axis in 3-D: its slope from a least-squares line of z along it.
        const double n = double(set.size()), var_t = stt - st * st / n;
        const double slope = var_t > 0 ? (stz - st * sz / n) / var_t : 0.0;
        Eigen::Vector3d d(axis.x(), axis.y(), slope);
        d.normalize();
        if (d.x() < 0 || (d.x() == 0 && d.y() < 0)) d = -d;
        f.direction = d;
      } else {
        f.type = FeatureType::Region;
      }
      features.push_back(f);
    }
  return features;
}

}  // namespace ambler::perception
