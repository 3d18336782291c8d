// Two-view matching on simulated scans of Mars-like ground with rocks: view J 1 m from view I
// and turned 10°, believed 0.3 m and 3° off. Noise-free, every
// iconic method recovers the relative pose to 5 mm and 0.05° and feature matching alone to 10 cm
// and 1° (close enough for iconic matching to take over); with the ERIM's noise, quantisation and
// mixed pixels the iconic methods reach 5 cm and 0.5°. And the paper's case for feature matching:
// believed 2 m and 30° off, where iconic matching alone is lost, features bring it within reach.
#include <gtest/gtest.h>

#include <cstdio>
#include <string>
#include <vector>

#include "eval/run/runner.hpp"
#include "eval/scenario/scenario.hpp"
#include "test_support.hpp"
#include "two_view_mars.hpp"

namespace ambler::eval {
namespace {

// The two-view Mars scene with view J 1 m from view I and turned 10°, on a map of 10 × 11 m.
std::string scenario(bool noisy, const std::string& initial_error = "{xyz_m: [0.2, 0.2, 0.1], rpy_deg: [0, 0, 3]}") {
  test::TwoViewMars scene;
  scene.name = "matching_test";
  scene.seed = 3;
  scene.sensor = noisy ? "{}" : test::kNoiseFreeSensor;
  scene.view1 = "{xyz_m: [0.6, -5.2, 3.0], rpy_deg: [0, -30, 10]}";
  scene.map_region = "{x_m: [-5, 5], y_m: [-3, 8]}";
  return scene.yaml() + R"(matching:
  methods: [features, features+iconic_robust, iconic_robust, iconic_lm, iconic_weighted]
  initial_error: )" + initial_error + "\n";
}

TEST(Matching, EveryMethodRecoversTheRelativePose) {
  for (const bool noisy : {false, true}) {
    const Scenario sc = parseScenario(scenario(noisy), "inline.yaml");
    test::TempDir run;
    const auto metrics = runScenario(sc, {run.dir, false});
    ASSERT_EQ(metrics["registration"].size(), 5u);
    for (const auto& m : metrics["registration"]) {
      const std::string method = m["method"].get<std::string>();
      const double t = m["translation_error_m"].get<double>(), r = m["rotation_error_deg"].get<double>();
      std::printf("%s %s: %d iterations, %.4f m %.3f deg (from %.3f m %.2f deg)\n", noisy ? "noisy" : "noise-free",
                  method.c_str(), m["iterations"].get<int>(), t, r, m["initial_translation_error_m"].get<double>(),
                  m["initial_rotation_error_deg"].get<double>());
      EXPECT_NEAR(m["initial_translation_error_m"].get<double>(), 0.3, 1e-9);
      if (method == "features") {
        EXPECT_LT(t, 0.10) << method;
        EXPECT_LT(r, 1.0) << method;
      } else if (noisy) {
        EXPECT_LT(t, 0.05) << method;
        EXPECT_LT(r, 0.5) << method;
      } else {
        EXPECT_LT(t, 0.005) << method;
        EXPECT_LT(r, 0.05) << method;
      }
    }
  }
}

// The paper's fig. 5 case: 2 m and 30° between the belief and the truth. Feature matching's
// search finds the pairing (to 10 cm and 1°) and the paper's descent from T_F finishes the job
// (5 cm, 0.5°); the iconic methods alone, from T_0, are recorded, not asserted (the start is
// outside their basin). There is one registration per method of the scenario, in its order, so
// the two methods asserted on cannot be missing.
TEST(Matching, FeaturesHandleThePapersCase) {
  const Scenario sc = parseScenario(scenario(true, "{xyz_m: [1.6, -1.2, 0.0], rpy_deg: [0, 0, 30]}"), "inline.yaml");
  test::TempDir run;
  const auto metrics = runScenario(sc, {run.dir, false});
  const std::vector<std::string> methods{"features", "features+iconic_robust", "iconic_robust", "iconic_lm",
                                         "iconic_weighted"};
  ASSERT_EQ(metrics["registration"].size(), methods.size());
  for (std::size_t k = 0; k < methods.size(); ++k) {
    const auto& m = metrics["registration"][k];
    const std::string method = m["method"].get<std::string>();
    ASSERT_EQ(method, methods[k]);
    const double t = m["translation_error_m"].get<double>(), r = m["rotation_error_deg"].get<double>();
    std::printf("%s: %.4f m %.3f deg (from %.3f m %.2f deg)\n", method.c_str(), t, r,
                m["initial_translation_error_m"].get<double>(), m["initial_rotation_error_deg"].get<double>());
    if (method == "features") {
      EXPECT_LT(t, 0.10);
      EXPECT_LT(r, 1.0);
    } else if (method == "features+iconic_robust") {
      EXPECT_LT(t, 0.05);
      EXPECT_LT(r, 0.5);
    }
  }
}

// The Open3D peers (eval/peers/) in the same run, on the same pair, scored the same way: fed the
// two scans' returns, each in its view's believed frame. Noise-free, each recovers the relative
// pose to 1 cm and 0.1° (docs/peers.md); FGR, a global method, does so from the paper's 2 m and
// 30° as well.
TEST(Matching, PeersRecoverTheRelativePose) {
  for (const char* error : {"{xyz_m: [0.2, 0.2, 0.1], rpy_deg: [0, 0, 3]}", "{xyz_m: [1.6, -1.2, 0.0], rpy_deg: [0, 0, 30]}"}) {
    std::string text = scenario(false, error);
    const std::string from = "methods: [features, features+iconic_robust, iconic_robust, iconic_lm, iconic_weighted]";
    text.replace(text.find(from), from.size(), "methods: [icp_point_to_plane, gicp, fgr]");
    const Scenario sc = parseScenario(text, "inline.yaml");
    test::TempDir run;
    const auto metrics = runScenario(sc, {run.dir, false});
    ASSERT_EQ(metrics["registration"].size(), 3u);
    const bool far = metrics["registration"][0]["initial_rotation_error_deg"].get<double>() > 20;
    for (const auto& m : metrics["registration"]) {
      const std::string method = m["method"].get<std::string>();
      const double t = m["translation_error_m"].get<double>(), r = m["rotation_error_deg"].get<double>();
      std::printf("%s: %d iterations, %.4f m %.3f deg (from %.3f m %.2f deg)\n", method.c_str(),
                  m["iterations"].get<int>(), t, r, m["initial_translation_error_m"].get<double>(),
                  m["initial_rotation_error_deg"].get<double>());
      if (far && method != "fgr") continue;  // local methods, outside their basin: recorded only
      EXPECT_LT(t, 0.01) << method;
      EXPECT_LT(r, 0.1) << method;
    }
  }
}

}  // namespace
}  // namespace ambler::eval
