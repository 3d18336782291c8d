// The footfall stage of `ambler run` (eval/run/stages/footfall.cpp).
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

// The footfall stage on the composite: each method's choice is the lowest score of its written
// raster (a cell centre inside the region; no candidate outside it), its true percentile is a share
// in [0, 1], and the picture is written.
TEST(Run, FootfallStageChoosesTheLowestScoreAndScoresItOnTheTruth) {
  const Scenario sc = parseScenario(twoViews("footfall_test", "[0.5, -5, 3.0], rpy_deg: [0, -30, 8]") +
                                        "merge: {poses: true}\nfootfall: {region: {x_m: [-1, 1], y_m: [1, 3]}}\n",
                                    "inline.yaml");
  test::TempDir run;
  const auto metrics = runScenario(sc, {run.dir, false});
  ASSERT_EQ(metrics["footfall"].size(), 6u);
  EXPECT_TRUE(std::filesystem::exists(run.dir / "footfall" / "choices.png"));
  const perception::MapGrid grid = sc.merge->grid();
  for (const auto& f : metrics["footfall"]) {
    const std::string method = f["method"].get<std::string>();
    const cv::Mat score = cv::imread((run.dir / "footfall" / (method + "_score.tiff")).string(), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(score.rows, grid.rows) << method;
    ASSERT_EQ(score.cols, grid.cols) << method;
    double best = std::numeric_limits<double>::infinity();
    int br = -1, bc = -1;
    for (int r = 0; r < score.rows; ++r)
      for (int c = 0; c < score.cols; ++c) {
        const float v = score.at<float>(r, c);
        if (!std::isfinite(v)) continue;
        const Eigen::Vector2d xy = grid.center(r, c);
        EXPECT_TRUE(xy.x() >= -1 && xy.x() <= 1 && xy.y() >= 1 && xy.y() <= 3) << method << " candidate outside R";
        if (v < best) best = v, br = r, bc = c;  // ties: the first in row-major order
      }
    ASSERT_GE(br, 0) << method;
    const Eigen::Vector2d xy = grid.center(br, bc);
    EXPECT_DOUBLE_EQ(f["x_m"].get<double>(), xy.x()) << method;
    EXPECT_DOUBLE_EQ(f["y_m"].get<double>(), xy.y()) << method;
    EXPECT_FLOAT_EQ(float(f["score"].get<double>()), float(best)) << method;
    const double p = f["truth_percentile"].get<double>();
    EXPECT_GE(p, 0.0) << method;
    EXPECT_LE(p, 1.0) << method;
    // A choice the truth rejects (no true score) is worse than every true candidate.
    if (f["truth_score"].is_null()) {
      EXPECT_EQ(p, 1.0) << method;
    }
  }
}

}  // namespace
}  // namespace ambler::eval
