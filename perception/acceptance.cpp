#include "perception/acceptance.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

namespace ambler::perception {

double correctionMahalanobis2(const Eigen::Isometry3d& believed_WS, const Eigen::Isometry3d& estimated_WS,
                              const PriorSigma& prior) {
  const Eigen::Isometry3d delta = believed_WS.inverse() * estimated_WS;
  const double t = delta.translation().norm();
  const double theta = Eigen::AngleAxisd(delta.linear()).angle();
  const double st = prior.translation_m, sr = prior.rotation_deg * M_PI / 180;
  return t * t / (st * st) + theta * theta / (sr * sr);
}

namespace {

std::string format(const char* fmt, double a, double b = 0, double c = 0) {
  char buf[200];
  std::snprintf(buf, sizeof buf, fmt, a, b, c);
  return buf;
}

long knownCells(const ElevationMap& map) {
  long n = 0;
  for (long i = 0; i < map.state().size(); ++i) n += map.state().data()[i] == std::uint8_t(CellState::Known);
  return n;
}

}  // namespace

Assessment assessRegistration(const ElevationMap& map1, const LocusMapper& image2, const PoseVector& nu,
                              const Eigen::Isometry3d& believed_WS, const Matrix6d* covariance,
                              const Degeneracy* degeneracy_at_nu, const AcceptanceConfig& config,
                              const std::vector<double>* residuals, double step_mahalanobis2) {
  Assessment a;
  // The lines' agreement at ν.
  const std::vector<double> u = residuals && residuals->size() == std::size_t(map1.grid().cells())
                                    ? *residuals
                                    : normalizedResiduals(map1, image2, nu);
  long inliers = 0;
  double sum_u2 = 0;
  for (const double x : u) {
    if (std::isnan(x)) continue;
    ++a.overlap;
    if (std::abs(x) <= config.inlier_sigmas) ++inliers, sum_u2 += x * x;
  }
  const long known = knownCells(map1);
  a.overlap_fraction = known ? double(a.overlap) / double(known) : 0.0;
  a.inlier_fraction = a.overlap ? double(inliers) / double(a.overlap) : 0.0;
  a.rms_normalized = inliers ? std::sqrt(sum_u2 / double(inliers)) : 0.0;
  if (a.overlap < config.min_overlap_lines || a.overlap_fraction < config.min_overlap_fraction)
    a.reject_reasons.push_back(format("overlap: %.0f lines, %.1f%% of map I's known cells", double(a.overlap),
                                      100 * a.overlap_fraction) +
                               format(" (at least %.0f and %.1f%%)", double(config.min_overlap_lines),
                                      100 * config.min_overlap_fraction));
  if (a.overlap > 0 && a.inlier_fraction < config.min_inlier_fraction)
    a.reject_reasons.push_back(format("residuals: %.1f%% of the overlap within %.1f sigma (at least %.0f%%)",
                                      100 * a.inlier_fraction, config.inlier_sigmas, 100 * config.min_inlier_fraction));
  // The correction under the prior.
  const Eigen::Isometry3d estimated_WS = poseFromVector(nu).inverse() * believed_WS;
  const Eigen::Isometry3d delta = believed_WS.inverse() * estimated_WS;
  a.correction_m = delta.translation().norm();
  a.correction_deg = Eigen::AngleAxisd(delta.linear()).angle() * 180 / M_PI;
  a.mahalanobis2 = correctionMahalanobis2(believed_WS, estimated_WS, config.prior);
  if (!(a.mahalanobis2 <= config.max_mahalanobis2))
    a.reject_reasons.push_back(format("prior: the correction (%.3f m, %.2f deg) is %.1f", a.correction_m, a.correction_deg,
                                      a.mahalanobis2) +
                               format(" in squared Mahalanobis distance (at most %.2f)", config.max_mahalanobis2));
  // The surface's degeneracy at ν (rotations weigh as the motion they give at half map 1's
  // diagonal, as the iconic methods weigh them).
  Degeneracy d;
  if (degeneracy_at_nu) {
    d = *degeneracy_at_nu;
  } else if (a.overlap > 6) {
    const IconicError e = iconicError(map1, image2, nu, true);
    const MapGrid& g = map1.grid();
    d = degeneracy(e.JtJ, 0.5 * std::hypot(g.cols * g.cell, g.rows * g.cell), knownCentroid(map1));
  }
  a.degenerate = d.degenerate;
  a.free_directions = d.free_directions;
  if (d.degenerate) {
    std::string free;
    for (const std::string& f : d.free_directions) free += (free.empty() ? "" : " ") + f;
    a.reject_reasons.push_back("degenerate: " + free + " free");
  }
  if (covariance && !d.degenerate) {  // along a free direction it is unbounded, said above
    const Eigen::LLT<Matrix6d> llt(*covariance);
    if (!covariance->allFinite() || llt.info() != Eigen::Success)
      a.reject_reasons.push_back("covariance: not positive definite");
  }
  a.step_mahalanobis2 = step_mahalanobis2;
  if (step_mahalanobis2 > config.max_step_mahalanobis2)  // NaN: not known, no reason
    a.reject_reasons.push_back(format("not converged: a Gauss-Newton step of its cost from the estimate is %.1f", step_mahalanobis2) +
                               format(" in squared Mahalanobis distance (at most %.2f)", config.max_step_mahalanobis2));
  a.accepted = a.reject_reasons.empty();
  return a;
}

std::vector<double> commonOverlapCosts(const std::vector<std::vector<double>>& residuals, double c, long* common) {
  const auto rho = [&](double u) { return c * c * std::log1p(u * u / (c * c)); };
  std::vector<double> cost(residuals.size(), 0.0);
  long n = 0;
  if (!residuals.empty()) {
    const std::size_t cells = residuals.front().size();
    for (std::size_t k = 0; k < cells; ++k) {
      bool all = true;
      for (const std::vector<double>& u : residuals) all = all && !std::isnan(u[k]);
      if (!all) continue;
      ++n;
      for (std::size_t h = 0; h < residuals.size(); ++h) cost[h] += rho(residuals[h][k]);
    }
  }
  for (double& x : cost) x = n ? x / double(n) : std::numeric_limits<double>::infinity();
  if (common) *common = n;
  return cost;
}

}  // namespace ambler::perception
