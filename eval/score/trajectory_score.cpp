#include "eval/score/trajectory_score.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>

#include "base/text.hpp"
#include "eval/scenario/io.hpp"

namespace ambler::eval {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
using Poses = std::vector<Eigen::Isometry3d>;

void checkInput(const Poses& truth, const Poses& estimate, const RelativeErrorSpec& spec, const char* who) {
  const std::string name(who);
  if (truth.size() != estimate.size())
    throw std::invalid_argument(name + ": the truth has " + std::to_string(truth.size()) + " poses and the estimate " +
                                std::to_string(estimate.size()) + "; they need one pose per stop each");
  if (truth.size() < 2)
    throw std::invalid_argument(name + ": a trajectory needs at least 2 poses, got " + std::to_string(truth.size()));
  if (spec.step < 1)
    throw std::invalid_argument(name + ": the step between first stops must be at least 1, got " +
                                std::to_string(spec.step));
  for (const double length : spec.lengths_m)
    if (!(std::isfinite(length) && length > 0))
      throw std::invalid_argument(name + ": segment lengths must be positive and finite, got " +
                                  base::plainText(length) + " m");
}

// The rotation angle of R in [0, π]. KITTI takes acos((tr R − 1)/2) clamped to [−1, 1]; this is
// the same angle from atan2 of its sine (half the norm of R − Rᵀ's axial vector) and cosine, which
// keeps full precision near 0, where acos of a cosine rounded to 1 loses half the digits.
double rotationAngle(const Eigen::Matrix3d& R) {
  const Eigen::Vector3d axial(R(2, 1) - R(1, 2), R(0, 2) - R(2, 0), R(1, 0) - R(0, 1));
  return std::atan2(0.5 * axial.norm(), 0.5 * (R.trace() - 1.0));
}

}  // namespace

std::vector<double> pathDistances(const Poses& poses) {
  std::vector<double> dist;
  dist.reserve(poses.size());
  for (std::size_t k = 0; k < poses.size(); ++k)
    dist.push_back(k == 0 ? 0.0 : dist.back() + (poses[k].translation() - poses[k - 1].translation()).norm());
  return dist;
}

std::optional<std::size_t> segmentEnd(const std::vector<double>& dist, std::size_t first, double length_m) {
  for (std::size_t j = first; j < dist.size(); ++j)
    if (dist[j] > dist[first] + length_m) return j;
  return std::nullopt;
}

std::vector<SegmentErrors> relativeErrors(const Poses& truth, const Poses& estimate, const RelativeErrorSpec& spec) {
  checkInput(truth, estimate, spec, "relativeErrors");
  const std::vector<double> dist = pathDistances(truth);
  const std::size_t n_lengths = spec.lengths_m.size();
  std::vector<double> t_sum(n_lengths, 0.0), r_sum(n_lengths, 0.0);
  std::vector<int> count(n_lengths, 0);
  for (std::size_t i = 0; i < truth.size(); i += static_cast<std::size_t>(spec.step)) {
    for (std::size_t l = 0; l < n_lengths; ++l) {
      const double length = spec.lengths_m[l];
      const std::optional<std::size_t> j = segmentEnd(dist, i, length);
      if (!j) continue;
      const Eigen::Isometry3d delta_gt = truth[i].inverse() * truth[*j];
      const Eigen::Isometry3d delta_est = estimate[i].inverse() * estimate[*j];
      const Eigen::Isometry3d error = delta_est.inverse() * delta_gt;
      t_sum[l] += error.translation().norm() / length;
      r_sum[l] += rotationAngle(error.linear()) / length;
      ++count[l];
    }
  }
  std::vector<SegmentErrors> out(n_lengths);
  for (std::size_t l = 0; l < n_lengths; ++l) {
    out[l].length_m = spec.lengths_m[l];
    out[l].segments = count[l];
    out[l].translation_pct = count[l] > 0 ? 100.0 * t_sum[l] / count[l] : kNaN;
    out[l].rotation_deg_per_m = count[l] > 0 ? r_sum[l] / count[l] * 180.0 / std::numbers::pi : kNaN;
  }
  return out;
}

TrajectoryErrors trajectoryErrors(const Poses& truth, const Poses& estimate, const RelativeErrorSpec& spec) {
  checkInput(truth, estimate, spec, "trajectoryErrors");
  TrajectoryErrors e;
  double sum_sq = 0;
  for (std::size_t k = 0; k < truth.size(); ++k) {
    const double error = (estimate[k].translation() - truth[k].translation()).norm();
    sum_sq += error * error;
    e.ate_max_m = std::max(e.ate_max_m, error);
  }
  e.ate_rms_m = std::sqrt(sum_sq / static_cast<double>(truth.size()));
  if (std::isnan(sum_sq)) e.ate_max_m = kNaN;  // std::max passes over a NaN position
  const double path_m = pathDistances(truth).back();
  const double final_error = (estimate.back().translation() - truth.back().translation()).norm();
  e.final_drift_pct = path_m > 0 ? 100.0 * final_error / path_m : kNaN;
  e.relative = relativeErrors(truth, estimate, spec);
  return e;
}

nlohmann::ordered_json toJson(const TrajectoryErrors& e) {
  nlohmann::ordered_json j;
  j["ate_rms_m"] = jsonNumber(e.ate_rms_m);
  j["ate_max_m"] = jsonNumber(e.ate_max_m);
  j["final_drift_pct"] = jsonNumber(e.final_drift_pct);
  nlohmann::ordered_json rte = nlohmann::ordered_json::object(), rotation = nlohmann::ordered_json::object(),
                         segments = nlohmann::ordered_json::object();
  for (const SegmentErrors& s : e.relative) {
    const std::string key = base::plainText(s.length_m);
    rte[key] = jsonNumber(s.translation_pct);
    rotation[key] = jsonNumber(s.rotation_deg_per_m);
    segments[key] = s.segments;
  }
  j["rte_pct"] = rte;
  j["rotation_deg_per_m"] = rotation;
  j["segments"] = segments;
  return j;
}

}  // namespace ambler::eval
