#pragma once
// A registration scored against the truth (docs/matching.md): its error from the true relative
// pose, a success when both the translation and the rotation error are within the scenario's
// bounds (matching.success), and the rover's verdict against that: a false accept is accepted but
// not a success, a false reject a success refused.
#include <Eigen/Geometry>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "eval/scenario/scenario.hpp"
#include "perception/acceptance.hpp"
#include "perception/feature_matching.hpp"
#include "perception/map_grid.hpp"
#include "perception/registration.hpp"
#include "perception/rigid_transform.hpp"

namespace ambler::eval {

// Both errors at most their bound (matching.success: translation_m, rotation_deg).
bool isSuccess(const perception::PoseError& error, const MatchingSpec& spec);

struct RegistrationScore {
  int i = 0, j = 0;  // the pair: view J registered against view I
  std::string method;
  perception::PoseError error, start;  // of the estimate and of the rover's belief
  bool success = false;
  perception::Assessment assessment;  // the rover's verdict, made without truth
  int iterations = 0;
  double seconds = 0;
  bool falseAccept() const { return assessment.accepted && !success; }
};

// The verdict's figures (a pair JSON's and metrics.json's "assessment"); step_mahalanobis2 only
// where the method has one.
nlohmann::ordered_json assessmentJson(const perception::Assessment& a);

// metrics.json's "registration" entry: pair, method, translation_error_m, rotation_error_deg,
// success, accepted, false_accept, reject_reasons, assessment, iterations, time_s,
// initial_translation_error_m, initial_rotation_error_deg.
nlohmann::ordered_json toJson(const RegistrationScore& s);

// One method's registration of a pair as matching/pair_I_J_METHOD.json records it: the score, the
// poses it was scored from, and the method's result with what scoring it needs of the truth.
struct PairRecord {
  RegistrationScore score;  // reg scored: its verdict and iterations are reg's
  // Sensor J in sensor I's frame: the truth, what the rover believed (T_0), the method's estimate.
  Eigen::Isometry3d T_true = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_initial = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_estimated = Eigen::Isometry3d::Identity();
  const perception::RegistrationResult* reg = nullptr;  // the method's result: not null, outlives the record
  Eigen::Isometry3d believed_WS = Eigen::Isometry3d::Identity();  // sensor J where the rover believes it
  Eigen::Isometry3d T_WS_i = Eigen::Isometry3d::Identity();       // the views' true poses
  Eigen::Isometry3d T_WS_j = Eigen::Isometry3d::Identity();
  perception::MapGrid grid_j;            // map J's grid (perception::believedGrid)
  perception::FeatureMatchConfig match;  // the feature stage's: D_true_m is eq. 3 under it
  bool covariance_calibrated = false;    // the method's covariance is calibrated for the sensor
  // A user's own method's covariance of sensor J's pose, written as covariance_pose as it is
  // (the paper's methods' is computed from ν's).
  std::optional<perception::Matrix6d> covariance_pose;
};

// The pair JSON: pair, method, T_true, T_initial, T_estimated (4 × 4 rows), translation_error_m,
// rotation_error_deg, success, iterations, time_s, covariance (of ν; null unless the iconic stage
// ran and is not degenerate), degenerate, free_directions, overlap, covariance_pose (of sensor J's
// pose; null also when the covariance is not finite), covariance_calibrated, accepted,
// reject_reasons, false_accept, assessment, then "verification" when the method verified
// hypotheses, "feature_matching" when feature matching ran, and the iconic "trace".
nlohmann::ordered_json toJson(const PairRecord& r);

}  // namespace ambler::eval
