// eval/score/registration_score: success within the scenario's bounds (inclusive, both needed),
// the verdict scored against it, the metrics.json entry's keys and values, and the pair JSON's
// against a hand-made registration result.
#include <gtest/gtest.h>

#include <limits>
#include <numbers>
#include <string>
#include <vector>

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

std::vector<std::string> keysOf(const nlohmann::ordered_json& j) {
  std::vector<std::string> keys;
  for (const auto& [k, v] : j.items()) keys.push_back(k);
  return keys;
}

Eigen::Isometry3d translation(double x, double y, double z) {
  return Eigen::Isometry3d(Eigen::Translation3d(x, y, z));
}

// A pair (0, 1) of a method that ran no stage beyond the iconic one, at the identity everywhere.
PairRecord iconicRecord(const perception::RegistrationResult& reg) {
  PairRecord r;
  r.score = {0, 1, "iconic_lm", {0.02, 0.1}, {0.4, 2.0}, true, reg.assessment, reg.iterations, 1.5};
  r.reg = &reg;
  return r;
}

TEST(PairRecord, CovarianceOnlyWhereTheIconicStageRanAndConstrainsEveryDirection) {
  perception::RegistrationResult reg;
  reg.iconic.covariance = (perception::PoseVector() << 1e-4, 4e-4, 9e-4, 1e-2, 4e-2, 9e-2).finished().asDiagonal();
  PairRecord r = iconicRecord(reg);
  r.covariance_calibrated = true;

  reg.ran_iconic = false;  // features alone
  nlohmann::ordered_json j = toJson(r);
  EXPECT_TRUE(j["covariance"].is_null());
  EXPECT_TRUE(j["covariance_pose"].is_null());
  EXPECT_EQ(j["degenerate"], false);
  EXPECT_EQ(j["covariance_calibrated"], false);

  reg.ran_iconic = true, reg.iconic.degenerate = true, reg.iconic.free_directions = {"tx"};
  j = toJson(r);
  EXPECT_TRUE(j["covariance"].is_null());
  EXPECT_TRUE(j["covariance_pose"].is_null());
  EXPECT_EQ(j["degenerate"], true);
  EXPECT_EQ(j["free_directions"], nlohmann::json::array({"tx"}));
  EXPECT_EQ(j["covariance_calibrated"], false);

  reg.iconic.degenerate = false, reg.iconic.free_directions.clear();
  j = toJson(r);
  ASSERT_EQ(j["covariance"].size(), 6u);
  EXPECT_EQ(j["covariance"][3], nlohmann::json::array({0.0, 0.0, 0.0, 1e-2, 0.0, 0.0}));
  EXPECT_EQ(j["covariance_calibrated"], true);
  // ν = 0 with sensor J believed at the identity: sensor J's error is −δ, so its covariance is ν's.
  // The Jacobian's central differences (h = 1e-6) err by about ε/h ≈ 2e-10.
  ASSERT_EQ(j["covariance_pose"].size(), 6u);
  for (int a = 0; a < 6; ++a)
    for (int b = 0; b < 6; ++b)
      EXPECT_NEAR(j["covariance_pose"][a][b].get<double>(), reg.iconic.covariance(a, b), 1e-9 * 9e-2) << a << b;
  r.covariance_calibrated = false;
  EXPECT_EQ(toJson(r)["covariance_calibrated"], false);

  reg.iconic.covariance(0, 0) = std::numeric_limits<double>::quiet_NaN();  // a covariance, not a finite one
  j = toJson(r);
  EXPECT_FALSE(j["covariance"].is_null());
  EXPECT_TRUE(j["covariance_pose"].is_null());
}

TEST(PairRecord, AFalseAcceptIsTheVerdictAgainstTheSuccess) {
  perception::RegistrationResult reg;
  PairRecord r = iconicRecord(reg);
  for (const bool accepted : {false, true})
    for (const bool success : {false, true}) {
      r.score.assessment.accepted = accepted, r.score.success = success;
      r.score.assessment.reject_reasons = accepted ? std::vector<std::string>{} : std::vector<std::string>{"overlap"};
      const nlohmann::ordered_json j = toJson(r);
      EXPECT_EQ(j["accepted"], accepted);
      EXPECT_EQ(j["success"], success);
      EXPECT_EQ(j["false_accept"], accepted && !success) << accepted << success;
      EXPECT_EQ(j["reject_reasons"].size(), accepted ? 0u : 1u);
    }
}

TEST(PairRecord, AnIconicMethodsJsonHasNoVerificationNorFeatureStage) {
  perception::RegistrationResult reg;
  reg.ran_iconic = true, reg.iterations = 2, reg.iconic.overlap = 100;
  reg.iconic.rms_m = {0.3, 0.1}, reg.iconic.E_m2 = {9.0, 1.0}, reg.iconic.lines = {100, 98};
  PairRecord r = iconicRecord(reg);
  r.T_true = translation(1, 2, 3), r.T_estimated = translation(1, 2, 3.5);
  const nlohmann::ordered_json j = toJson(r);
  EXPECT_EQ(keysOf(j), (std::vector<std::string>{
                           "pair", "method", "T_true", "T_initial", "T_estimated", "translation_error_m",
                           "rotation_error_deg", "success", "iterations", "time_s", "covariance", "degenerate",
                           "free_directions", "overlap", "covariance_pose", "covariance_calibrated", "accepted",
                           "reject_reasons", "false_accept", "assessment", "trace"}));
  EXPECT_EQ(j["pair"], nlohmann::json::array({0, 1}));
  EXPECT_EQ(j["T_true"], nlohmann::json::parse("[[1,0,0,1],[0,1,0,2],[0,0,1,3],[0,0,0,1]]"));
  EXPECT_EQ(j["T_initial"], nlohmann::json::parse("[[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]"));
  EXPECT_EQ(j["T_estimated"][2][3], 3.5);
  EXPECT_EQ(j["translation_error_m"], 0.02);
  EXPECT_EQ(j["rotation_error_deg"], 0.1);
  EXPECT_EQ(j["iterations"], 2);
  EXPECT_EQ(j["time_s"], 1.5);
  EXPECT_EQ(j["overlap"], 100);
  EXPECT_EQ(j["trace"], nlohmann::ordered_json::parse(R"([{"iteration": 0, "E": 9.0, "rms_m": 0.3, "lines": 100},
                                                  {"iteration": 1, "E": 1.0, "rms_m": 0.1, "lines": 98}])"));
}

// A two-stage method's result: sensor J believed 0.3 m along x of the truth (view I and the truth
// at the identity); two hypotheses, a line and two points of map I, and a point of map J.
struct TwoStage {
  perception::RegistrationResult reg;
  PairRecord record;  // points into reg
  TwoStage(const TwoStage&) = delete;
  TwoStage() {
    reg.ran_iconic = true;
    perception::RegistrationHypothesis h;
    h.start = "T_F", h.stage = "refine", h.D_m = 0.2, h.cost = 0.01, h.iterations = 4;
    h.nu << 0, 0, 0, 0.3, 0, 0;  // exp(ν)⁻¹·believed: the truth
    reg.hypotheses.push_back(h);
    h.start = "T_0", h.D_m = 0.9, h.cost = 0.04, h.iterations = 7;
    h.nu << 0, 0, 2 * std::numbers::pi / 180, 0, 0, 0;  // turned 2° about z, still 0.3 m off
    reg.hypotheses.push_back(h);
    reg.chosen = 0, reg.common_lines = 1234;
    // Map I's features move by (0.3, 0, 0) into map J's frame (its grid at the identity).
    perception::Feature line{perception::FeatureType::Line, {0.5, 0.5, 0}, {1, 0, 0}, 1.0, 0.5, 2.0, 12};
    perception::Feature near{perception::FeatureType::Point, {1.0, 1.0, 0}, {0, 0, 0}, 0, 0.2, 3.0, 5};
    perception::Feature off{perception::FeatureType::Point, {5.0, 5.0, 0}, {0, 0, 0}, 0, 0.2, 3.0, 5};
    reg.features_i = {line, near, off};
    perception::Feature j_point = near;
    j_point.position = {1.4, 1.0, 0};  // 0.1 m from `near` moved
    reg.features_j = {j_point};
    const perception::MapGrid grid = perception::MapGrid::covering(0, 2, 0, 2, 0.1);
    reg.map_j.emplace(grid);
    for (int row = 0; row < grid.rows; ++row)
      for (int col = 0; col < grid.cols; ++col) reg.map_j->setKnown(row, col, 0, 0.01);
    perception::FeatureMatch fm;
    fm.found = true, fm.D = 0.2, fm.D0 = 0.9, fm.pairs = {{1, 0}}, fm.rotation_sigma_deg = 0.4;
    fm.nodes = 17, fm.hypotheses = 5, fm.exhausted = false;
    reg.feature_match = fm;
    record = iconicRecord(reg);
    record.score.method = "features+iconic_lm";
    record.believed_WS = translation(0.3, 0, 0);
    record.T_initial = translation(0.3, 0, 0);
    record.grid_j = grid;
    record.match.d_max_m = 0.5, record.match.inlier_m = 0.3;
  }
};

TEST(PairRecord, VerificationScoresEachHypothesisAgainstTheTruth) {
  const TwoStage t;
  const nlohmann::ordered_json j = toJson(t.record);
  EXPECT_EQ(keysOf(j), (std::vector<std::string>{
                           "pair", "method", "T_true", "T_initial", "T_estimated", "translation_error_m",
                           "rotation_error_deg", "success", "iterations", "time_s", "covariance", "degenerate",
                           "free_directions", "overlap", "covariance_pose", "covariance_calibrated", "accepted",
                           "reject_reasons", "false_accept", "assessment", "verification", "feature_matching",
                           "trace"}));
  const nlohmann::ordered_json& v = j["verification"];
  EXPECT_EQ(keysOf(v), (std::vector<std::string>{"common_lines", "hypotheses"}));
  EXPECT_EQ(v["common_lines"], 1234);
  ASSERT_EQ(v["hypotheses"].size(), 2u);
  const nlohmann::ordered_json& h0 = v["hypotheses"][0];
  EXPECT_EQ(keysOf(h0), (std::vector<std::string>{"start", "stage", "D_m", "iterations", "cost", "chosen",
                                                  "start_translation_error_m", "start_rotation_error_deg",
                                                  "translation_error_m", "rotation_error_deg"}));
  EXPECT_EQ(h0["start"], "T_F");
  EXPECT_EQ(h0["iterations"], 4);
  EXPECT_EQ(h0["chosen"], true);
  EXPECT_NEAR(h0["start_translation_error_m"].get<double>(), 0.3, 1e-12);  // from the belief
  EXPECT_NEAR(h0["start_rotation_error_deg"].get<double>(), 0.0, 1e-12);
  EXPECT_NEAR(h0["translation_error_m"].get<double>(), 0.0, 1e-12);
  EXPECT_NEAR(h0["rotation_error_deg"].get<double>(), 0.0, 1e-12);
  const nlohmann::ordered_json& h1 = v["hypotheses"][1];
  EXPECT_EQ(h1["start"], "T_0");
  EXPECT_EQ(h1["chosen"], false);
  EXPECT_NEAR(h1["translation_error_m"].get<double>(), 0.3, 1e-12);  // a turn about sensor I's origin
  EXPECT_NEAR(h1["rotation_error_deg"].get<double>(), 2.0, 1e-9);
}

TEST(PairRecord, FeatureMatchingScoresEquationThreeAtTheTruth) {
  const TwoStage t;
  const nlohmann::ordered_json f = toJson(t.record)["feature_matching"];
  EXPECT_EQ(keysOf(f), (std::vector<std::string>{"features_i", "features_j", "T_WM_j", "found", "D_m", "D_initial_m",
                                                 "D_true_m", "pairs_true", "pairs", "rotation_sigma_deg", "nodes",
                                                 "hypotheses", "exhausted"}));
  ASSERT_EQ(f["features_i"].size(), 3u);
  EXPECT_EQ(keysOf(f["features_i"][0]), (std::vector<std::string>{"type", "position_m", "direction", "length_m",
                                                                  "extent_m", "strength_per_m", "cells"}));
  EXPECT_EQ(f["features_i"][0]["type"], "line");
  EXPECT_EQ(f["features_i"][0]["direction"], nlohmann::json::array({1.0, 0.0, 0.0}));
  EXPECT_EQ(f["features_i"][0]["cells"], 12);
  EXPECT_EQ(keysOf(f["features_i"][1]),
            (std::vector<std::string>{"type", "position_m", "extent_m", "strength_per_m", "cells"}));
  EXPECT_EQ(f["features_j"][0]["position_m"], nlohmann::json::array({1.4, 1.0, 0.0}));
  EXPECT_EQ(f["found"], true);
  EXPECT_EQ(f["D_m"], 0.2);
  EXPECT_EQ(f["D_initial_m"], 0.9);
  // At the truth the moved point lies 0.1 m from map J's; the line meets no line and the far
  // point falls off map J: d_max_m each.
  EXPECT_NEAR(f["D_true_m"].get<double>(), 0.1 + 2 * 0.5, 1e-12);
  EXPECT_EQ(f["pairs_true"], 1);
  EXPECT_EQ(f["pairs"], nlohmann::json::parse("[[1, 0]]"));
  EXPECT_EQ(f["rotation_sigma_deg"], 0.4);
  EXPECT_EQ(f["nodes"], 17);
  EXPECT_EQ(f["hypotheses"], 5);
  EXPECT_EQ(f["exhausted"], false);
}

}  // namespace
}  // namespace ambler::eval
