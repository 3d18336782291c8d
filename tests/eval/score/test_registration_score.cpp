// eval/score/registration_score: success within the scenario's bounds (inclusive, both needed),
// the verdict scored against it, and the metrics.json entry's keys and values.
#include <gtest/gtest.h>

#include <limits>

#include "eval/score/registration_score.hpp"

namespace ambler::eval {
namespace {

MatchingSpec bounds() {
  MatchingSpec spec;
  spec.success_translation_m = 0.05, spec.success_rotation_deg = 0.5;
  return spec;
}

TEST(RegistrationScore, SuccessNeedsBothErrorsWithinTheirBounds) {
  const MatchingSpec spec = bounds();
  EXPECT_TRUE(isSuccess({0.05, 0.5}, spec));  // at the bounds: within
  EXPECT_TRUE(isSuccess({0.0, 0.0}, spec));
  EXPECT_FALSE(isSuccess({0.0500001, 0.1}, spec));
  EXPECT_FALSE(isSuccess({0.01, 0.5000001}, spec));
  EXPECT_FALSE(isSuccess({std::numeric_limits<double>::quiet_NaN(), 0.1}, spec));  // no estimate
}

TEST(RegistrationScore, AFalseAcceptIsAcceptedButNotASuccess) {
  RegistrationScore s;
  for (const bool accepted : {false, true})
    for (const bool success : {false, true}) {
      s.assessment.accepted = accepted, s.success = success;
      EXPECT_EQ(s.falseAccept(), accepted && !success) << accepted << success;
    }
}

TEST(RegistrationScore, MetricsEntryHoldsTheScoreAndTheVerdict) {
  RegistrationScore s{0, 1, "iconic_lm", {0.2, 3.0}, {0.3, 3.5}, false, {}, 12, 0.25};
  s.assessment.accepted = true;
  s.assessment.step_mahalanobis2 = std::numeric_limits<double>::quiet_NaN();
  const nlohmann::ordered_json j = toJson(s);
  EXPECT_EQ(j["pair"], nlohmann::json::array({0, 1}));
  EXPECT_EQ(j["method"], "iconic_lm");
  EXPECT_EQ(j["translation_error_m"], 0.2);
  EXPECT_EQ(j["initial_rotation_error_deg"], 3.5);
  EXPECT_EQ(j["false_accept"], true);
  EXPECT_EQ(j["iterations"], 12);
  EXPECT_FALSE(j["assessment"].contains("step_mahalanobis2"));  // a method without the statistic
  s.assessment.step_mahalanobis2 = 4.5;
  EXPECT_EQ(toJson(s)["assessment"]["step_mahalanobis2"], 4.5);
  std::vector<std::string> keys;
  for (const auto& [k, v] : j.items()) keys.push_back(k);
  EXPECT_EQ(keys, (std::vector<std::string>{"pair", "method", "translation_error_m", "rotation_error_deg", "success",
                                            "accepted", "false_accept", "reject_reasons", "assessment", "iterations",
                                            "time_s", "initial_translation_error_m", "initial_rotation_error_deg"}));
}

}  // namespace
}  // namespace ambler::eval
