#pragma once
// One pair of views as the rover has it, registered by any matching method from any believed pose:
// what the match stage, `ambler bench match` and `ambler basin` call. The paper's methods go
// through perception::registerViews; the Open3D peers (eval/peers/) get the two scans' returns,
// each in its view's believed frame. Every method starts from the same T_0 and is scored the same
// way against the true relative pose.
#include <Eigen/Geometry>
#include <functional>
#include <optional>
#include <string>
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
  // A user's own method's covariance of sensor J's pose (the pair JSON's covariance_pose), when it
  // gives one; the paper's methods give ν's, in reg.iconic.
  std::optional<perception::Matrix6d> covariance_pose;
};

class PairRegistration;

// What a user's own method (CustomMethod) returns: its estimate of sensor J in sensor I's frame,
// optionally a covariance of it (6 × 6, the error e of T·exp(e), rx ry rz tx ty tz in sensor J's
// frame: the pair JSON's covariance_pose) and its iteration count. `registered`: when the method
// returned a built-in registration of this very pair (the Python module's ambler.register), that
// result whole, so it is scored with its own verdict as the built-in method is.
struct CustomEstimate {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  std::optional<perception::Matrix6d> covariance_pose;
  int iterations = 0;
  std::optional<PairResult> registered;
};

// A registration method from outside the project (docs/python.md, "Your own method"): from the
// pair (view I mapped at its pose, scan J; PairRegistration::viewI, scanJ) and the believed
// relative pose T_0, an estimate. Scored as a peer is: its error against the truth, and the
// rover's verdict by the tests that need nothing of the method's internals (the lines' residuals
// and overlap at the estimate, the correction under the prior, and a given covariance positive
// definite). May throw std::invalid_argument to give up (counted as a failure, as a built-in
// method's), anything else to stop the run.
struct CustomMethod {
  std::string name;  // not a built-in method's; letters, digits, '_', '-', '+' and '.'
  std::function<CustomEstimate(const PairRegistration& pair, const Eigen::Isometry3d& T_0)> fn;
};
using CustomMethods = std::vector<CustomMethod>;

// Throws std::invalid_argument naming `where` and the method for a name that is empty, has other
// characters, is a built-in method's, or is repeated, and for a method without a function.
void checkCustomMethods(const CustomMethods& methods, const std::string& where);

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
  // What a user's own method is given: view I (its scan, and its map at `poseI()`, the world
  // frame) and scan J (image.T_WS is its true pose: a method must not read it).
  const perception::ScanMap& viewI() const { return i_; }
  const Eigen::Isometry3d& poseI() const { return T_WS_i_; }
  const perception::ScanMap& scanJ() const { return j_; }

  // Registers view J from the believed relative pose T_0 by `method`. Thread-safe: concurrent
  // calls share only read-only state. Deterministic.
  PairResult run(MatchMethod method, const Eigen::Isometry3d& T_0) const;
  // The same by a user's own method: its estimate scored against the truth and judged by the
  // rover (CustomMethod). Thread-safe when `method.fn` is. A `registered` result is scored with
  // its own verdict only when it started from this pair's believed pose (T_0); otherwise its T
  // is judged as any estimate.
  PairResult run(const CustomMethod& method, const Eigen::Isometry3d& T_0) const;

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
