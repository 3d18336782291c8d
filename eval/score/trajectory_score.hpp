#pragma once
// A traverse's poses scored against the truth: the rover stops along a path, one pose T_WS per
// stop, and an estimate (registered or dead-reckoned) gives its own pose for every stop.
//
// - The absolute trajectory error (ATE) is the distance between the estimated and the true
//   position at each stop, with no alignment: the rover starts at a known pose, so both
//   trajectories share a frame and the error of the start is part of what is measured (TUM's ATE
//   first fits an SE(3) alignment, which would hide a drift that is the same at every stop).
// - The relative errors are those of the KITTI odometry devkit (evaluate_odometry.cpp): for each
//   first stop i (stepping by `step` stops) and each length L, the segment ends at the first stop j
//   whose distance along the true path exceeds dist[i] + L (strictly); the error of the segment is
//   E = (T_est,i⁻¹·T_est,j)⁻¹·(T_gt,i⁻¹·T_gt,j), scored as ‖t(E)‖/L and angle(E)/L, and averaged
//   over the segments of that length. KITTI steps by 10 frames (one second of its 10 Hz video); a
//   traverse has few stops, so the step here defaults to 1 (every stop starts a segment).
// - The final drift is the last stop's position error over the true path's length.
#include <Eigen/Geometry>
#include <nlohmann/json.hpp>
#include <optional>
#include <vector>

namespace ambler::eval {

// Which relative errors to compute: the segment lengths (metres, positive) and the stride of the
// first stops (at least 1).
struct RelativeErrorSpec {
  std::vector<double> lengths_m{5, 10, 20, 50};
  int step = 1;
};

// The relative error of one segment length, averaged over its segments; with no segment (the
// traverse is not longer than the length) both figures are NaN.
struct SegmentErrors {
  double length_m = 0;
  int segments = 0;
  double translation_pct = 0;     // 100 · mean(‖t(E)‖ / L)
  double rotation_deg_per_m = 0;  // mean(angle(E) / L), in degrees
};

struct TrajectoryErrors {
  double ate_rms_m = 0, ate_max_m = 0;  // over all stops, start included
  double final_drift_pct = 0;           // 100 · last stop's position error / true path length
  std::vector<SegmentErrors> relative;  // one per length, in the spec's order
};

// The distance along the path at each stop: 0 at the first, then the cumulative sum of
// ‖t_k − t_{k−1}‖ (KITTI's trajectoryDistances). Empty for no poses.
std::vector<double> pathDistances(const std::vector<Eigen::Isometry3d>& poses);

// The stop that ends a segment of `length_m` starting at `first` (KITTI's
// lastFrameFromSegmentLength): the first stop j ≥ first with dist[j] > dist[first] + length_m;
// nullopt when the path ends before that.
std::optional<std::size_t> segmentEnd(const std::vector<double>& dist, std::size_t first, double length_m);

// The figures above for `estimate` against `truth` (pose per stop, sensor in the world frame).
// Throws std::invalid_argument if the two differ in length, hold fewer than 2 poses, or the spec
// has a step below 1 or a length that is not positive and finite. The final drift is NaN when the
// true path has zero length; a NaN position makes NaN every figure it enters.
TrajectoryErrors trajectoryErrors(const std::vector<Eigen::Isometry3d>& truth,
                                  const std::vector<Eigen::Isometry3d>& estimate, const RelativeErrorSpec& spec = {});

// The relative errors alone (one entry per spec length); throws as trajectoryErrors.
std::vector<SegmentErrors> relativeErrors(const std::vector<Eigen::Isometry3d>& truth,
                                          const std::vector<Eigen::Isometry3d>& estimate,
                                          const RelativeErrorSpec& spec = {});

// ate_rms_m, ate_max_m, final_drift_pct, then rte_pct, rotation_deg_per_m and segments, each an
// object keyed by the length in metres ("5", "10", "2.5"); NaN → null.
nlohmann::ordered_json toJson(const TrajectoryErrors& e);

}  // namespace ambler::eval
