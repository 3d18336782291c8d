#include "eval/score/registration_score.hpp"

#include <cmath>

namespace ambler::eval {

bool isSuccess(const perception::PoseError& error, const MatchingSpec& spec) {
  return error.translation_m <= spec.success_translation_m && error.rotation_deg <= spec.success_rotation_deg;
}

nlohmann::ordered_json assessmentJson(const perception::Assessment& a) {
  nlohmann::ordered_json j;
  j["overlap"] = a.overlap;
  j["overlap_fraction"] = a.overlap_fraction;
  j["inlier_fraction"] = a.inlier_fraction;
  j["rms_normalized"] = a.rms_normalized;
  j["correction_m"] = a.correction_m;
  j["correction_deg"] = a.correction_deg;
  j["mahalanobis2"] = a.mahalanobis2;
  j["degenerate"] = a.degenerate;
  if (std::isfinite(a.step_mahalanobis2)) j["step_mahalanobis2"] = a.step_mahalanobis2;
  return j;
}

nlohmann::ordered_json toJson(const RegistrationScore& s) {
  nlohmann::ordered_json m;
  m["pair"] = {s.i, s.j};
  m["method"] = s.method;
  m["translation_error_m"] = s.error.translation_m;
  m["rotation_error_deg"] = s.error.rotation_deg;
  m["success"] = s.success;
  m["accepted"] = s.assessment.accepted;
  m["false_accept"] = s.falseAccept();
  m["reject_reasons"] = s.assessment.reject_reasons;
  m["assessment"] = assessmentJson(s.assessment);
  m["iterations"] = s.iterations;
  m["time_s"] = s.seconds;
  m["initial_translation_error_m"] = s.start.translation_m;
  m["initial_rotation_error_deg"] = s.start.rotation_deg;
  return m;
}

}  // namespace ambler::eval
