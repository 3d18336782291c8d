// The merge stage of `ambler run` (eval/run/stages/merge.cpp).
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

// The merge stage with true poses on the map grid maps each scan exactly as the map stage did, so
// the composite knows the union of the views' known cells; where one view alone knows a cell the
// composite has that view's elevation, where both do eq. 9's. With matched poses the composite
// exists and its metrics are filled.
TEST(Run, MergeStageComposesTheViewsMaps) {
  const std::string base = twoViews("merge_test", "[0.5, -5, 3.0], rpy_deg: [0, -30, 8]") + R"(matching:
  methods: [iconic_weighted]
  initial_error: {xyz_m: [0.2, -0.2, 0.0], rpy_deg: [0, 0, 3]}
)";
  {
    const Scenario sc = parseScenario(base + "merge: {poses: true}\n", "inline.yaml");
    test::TempDir run;
    const auto metrics = runScenario(sc, {run.dir, false});
    const auto read = [&](const std::string& name, int flags) {
      const cv::Mat m = cv::imread((run.dir / "maps" / name).string(), flags);
      EXPECT_FALSE(m.empty()) << name;
      return m;
    };
    const cv::Mat s0 = read("view_0_state.png", cv::IMREAD_UNCHANGED), s1 = read("view_1_state.png", cv::IMREAD_UNCHANGED);
    const cv::Mat sc_ = read("composite_state.png", cv::IMREAD_UNCHANGED);
    const cv::Mat z0 = read("view_0_elevation.tiff", cv::IMREAD_UNCHANGED), z1 = read("view_1_elevation.tiff", cv::IMREAD_UNCHANGED);
    const cv::Mat zc = read("composite_elevation.tiff", cv::IMREAD_UNCHANGED);
    ASSERT_EQ(sc_.size(), s0.size());
    long union_known = 0, only_one = 0, both = 0;
    for (int r = 0; r < s0.rows; ++r)
      for (int c = 0; c < s0.cols; ++c) {
        const bool k0 = s0.at<std::uint8_t>(r, c) == 1, k1 = s1.at<std::uint8_t>(r, c) == 1;
        const bool kc = sc_.at<std::uint8_t>(r, c) == 1;
        EXPECT_EQ(kc, k0 || k1) << r << " " << c;
        union_known += k0 || k1;
        if (k0 != k1) {
          ++only_one;
          EXPECT_EQ(zc.at<float>(r, c), k0 ? z0.at<float>(r, c) : z1.at<float>(r, c));
        } else if (k0) {
          ++both;  // eq. 9: between the two
          const float lo = std::min(z0.at<float>(r, c), z1.at<float>(r, c)), hi = std::max(z0.at<float>(r, c), z1.at<float>(r, c));
          EXPECT_GE(zc.at<float>(r, c), lo - 1e-6f);
          EXPECT_LE(zc.at<float>(r, c), hi + 1e-6f);
        }
      }
    EXPECT_GT(only_one, 0);
    EXPECT_GT(both, 0);
    EXPECT_EQ(metrics["composite"]["known"].get<long>(), union_known);
    EXPECT_EQ(metrics["composite"]["poses"], "true");
  }
  {
    const Scenario sc = parseScenario(base + "merge: {poses: matched}\n", "inline.yaml");
    test::TempDir run;
    const auto metrics = runScenario(sc, {run.dir, false});
    EXPECT_EQ(metrics["composite"]["poses"], "matched");
    EXPECT_LT(metrics["composite"]["rms_error_m"].get<double>(), 0.03);
    for (const char* name : {"composite_elevation.tiff", "composite_sigma.tiff", "composite_state.png", "composite_meta.json"})
      EXPECT_TRUE(fs::is_regular_file(run.dir / "maps" / name)) << name;
  }
}

}  // namespace
}  // namespace ambler::eval
