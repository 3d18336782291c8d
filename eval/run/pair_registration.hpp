#pragma once
// One pair of views as the rover has it, registered by any matching method from any believed pose:
// what the match stage, `ambler bench match` and `ambler basin` call. The paper's methods go
// through perception::registerViews; the Open3D peers (eval/peers/) get the two scans' returns,
// each in its view's believed frame. Every method starts from the same T_0 and is scored the same
// way against the true relative pose.
#include <Eigen/Geometry>
#include <optional>
#include <vector>

#include "eval/scenario/scenario.hpp"
#include "perception/registration.hpp"
#include "perception/rigid_transform.hpp"
#include "perception/scan_to_map.hpp"

namespace ambler::eval {

struct PairResult {
  Eigen::Isometry3d believed_WS = Eigen::Isometry3d::Identity();  // sensor J where the rover believes it
  Eigen::Isometry3d T_est = Eigen::Isometry3d::Identity();        // sensor J in sensor I's frame, estimated
  // ν (world → the believed world of J), the corrected pose of sensor J and, for the paper's
  // methods, everything registerViews returns (the iconic trace and covariance, feature
  // matching's products). A peer fills nu, correction, corrected_WS, iterations and the assessment
  // alone.
  perception::RegistrationResult reg;
  perception::PoseError error, start;  // of T_est and of T_0 against the truth
  double seconds = 0;                  // wall time of the registration alone
};

class PairRegistration {
 public:
  // View I's scan mapped at its true pose (its map in the world frame; its image for the weighted
  // method's covariance and the peers), view J's scan (the unwrapped image and its edges; its
  // pose is what the methods look for). Nothing a method sees depends on T_WS_j; it only scores.
  // `methods`: those that will run, so the per-pair set-up they need is made once here.
  PairRegistration(const perception::ScanMap& view_i, const Eigen::Isometry3d& T_WS_i,
                   const perception::ScanMap& view_j, const Eigen::Isometry3d& T_WS_j,
                   perception::RegistrationConfig config, const std::vector<MatchMethod>& methods);
  PairRegistration(const PairRegistration&) = delete;
  PairRegistration& operator=(const PairRegistration&) = delete;

  // The truth: sensor J in sensor I's frame.
  const Eigen::Isometry3d& trueRelative() const { return T_IJ_; }
  const perception::RegistrationConfig& config() const { return config_; }

  // Registers view J from the believed relative pose T_0 by `method`. Thread-safe: concurrent
  // calls share only read-only state. Deterministic.
  PairResult run(MatchMethod method, const Eigen::Isometry3d& T_0) const;

 private:
  // Sensor J in sensor I's frame by a registration's corrected pose.
  Eigen::Isometry3d relativeEstimate(const perception::RegistrationResult& reg,
                                     const Eigen::Isometry3d& believed_WS) const;

  const perception::ScanMap& i_;
  const perception::ScanMap& j_;
  Eigen::Isometry3d T_WS_i_, T_IJ_;
  perception::RegistrationConfig config_;
  // View I as registration reads it, on the grid of the run's map I (the weighted methods' map
  // and its mapper only when one of them runs). Every result is assessed on its map, the peers' too.
  perception::ReferenceView reference_;
  std::vector<Eigen::Vector3d> returns_i_;  // the peers' target: scan I's returns in the world
};

}  // namespace ambler::eval
