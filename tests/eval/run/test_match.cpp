// The match stage of `ambler run` (eval/run/stages/match.cpp).
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <numbers>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "eval/pictures/figures.hpp"
#include "eval/scenario/io.hpp"
#include "eval/run/runner.hpp"
#include "eval/scenario/scenario.hpp"
#include "perception/sensor_geometry.hpp"
#include "eval/picture_checks.hpp"
#include "sim/ground_truth.hpp"
#include "sim/ray_scene.hpp"
#include "sim/world.hpp"
#include "terrains/terrain.hpp"
#include "test_support.hpp"
#include "run_scenes.hpp"

namespace ambler::eval {
namespace {

namespace fs = std::filesystem;
using namespace run_test;
using test::slurp;

// The match stage end to end: two views of Mars-like ground with rocks, the ERIM's noise,
// quantisation and mixed pixels, view 1 believed 0.3 m and 3° off. Each method's file and
// registration entry are written; T_true is the views' relative pose; both iconic methods land
// within the bound for a noisy sensor (5 cm and 0.5°, docs/matching.md), far inside the start.
TEST(Run, MatchStageRegistersTheViewsAgainstTheTruePose) {
  const std::string yaml = twoViews("match_test", "[0, -5, 3.0], rpy_deg: [0, -30, 5]") + R"(matching:
  methods: [iconic_robust, iconic_lm]
  initial_error: {xyz_m: [0.2, -0.2, 0.05], rpy_deg: [0, 0, 3]}
)";
  const Scenario sc = parseScenario(yaml, "inline.yaml");
  test::TempDir run;
  const auto metrics = runScenario(sc, {run.dir, false});
  ASSERT_EQ(metrics["registration"].size(), 2u);
  const Eigen::Isometry3d T0 = perception::sensorPose(sc.views[0].xyz_m, sc.views[0].rpy_rad);
  const Eigen::Isometry3d T1 = perception::sensorPose(sc.views[1].xyz_m, sc.views[1].rpy_rad);
  const Eigen::Matrix4d T_IJ = (T0.inverse() * T1).matrix();
  for (const auto& m : metrics["registration"]) {
    const std::string method = m["method"].get<std::string>();
    SCOPED_TRACE(method);
    EXPECT_EQ(m["pair"], nlohmann::ordered_json({0, 1}));
    EXPECT_GT(m["initial_translation_error_m"].get<double>(), 0.25);
    EXPECT_LT(m["translation_error_m"].get<double>(), 0.05);
    EXPECT_LT(m["rotation_error_deg"].get<double>(), 0.5);
    EXPECT_TRUE(m["success"].get<bool>());
    const auto pair = nlohmann::json::parse(slurp(run.dir / "matching" / ("pair_0_1_" + method + ".json")));
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) EXPECT_NEAR(pair["T_true"][r][c].get<double>(), T_IJ(r, c), 1e-12);
    EXPECT_EQ(pair["translation_error_m"].get<double>(), m["translation_error_m"].get<double>());
    ASSERT_GE(pair["trace"].size(), 2u);  // the start and at least one step
    EXPECT_LT(pair["trace"].back()["rms_m"].get<double>(), pair["trace"][0]["rms_m"].get<double>());
    EXPECT_TRUE(fs::is_regular_file(run.dir / "matching" / ("pair_0_1_difference_" + method + ".png")));
  }
  // The pictures (eval/pictures/match_figures.hpp, tested in test_match_figures.cpp).
  for (const char* name : {"view_0_features.png", "view_1_features.png", "pair_0_1_convergence.png"})
    EXPECT_TRUE(fs::is_regular_file(run.dir / "matching" / name)) << name;
}

}  // namespace
}  // namespace ambler::eval
