#pragma once
// A registration scored against the truth (docs/matching.md): its error from the true relative
// pose, a success when both the translation and the rotation error are within the scenario's
// bounds (matching.success), and the rover's verdict against that: a false accept is accepted but
// not a success, a false reject a success refused.
#include <nlohmann/json.hpp>
#include <string>

#include "eval/scenario/scenario.hpp"
#include "perception/acceptance.hpp"
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

}  // namespace ambler::eval
