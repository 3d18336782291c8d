// The map and Cartesian stages of `ambler run` (eval/run/stages/map.cpp, cartesian.cpp): every map
// file of the contract and the pictures of them.
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

// With a map region the map and Cartesian stages run too: every map file of the contract per view,
// both scored in metrics.json, and pictures that show the maps on disk — the state view's cells in
// the colour of state.png's state, the elevation picture's cells in reliefImage's colour of the
// elevation TIFF (shadow hatched).
TEST(Run, MapStagesWriteEveryMapFileAndPicturesOfThem) {
  test::TwoViewMars scene = smallScene();
  scene.map_region = "{x_m: [-2, 2], y_m: [-1, 3]}";
  scene.map_baseline = "";
  Scenario sc = parseScenario(scene.yaml(), "inline.yaml");
  ASSERT_TRUE(sc.map.has_value());
  ASSERT_EQ(sc.map->baseline, Baseline::Cartesian);
  test::TempDir run;
  const auto metrics = runScenario(sc, {run.dir, false});
  ASSERT_EQ(metrics["map"].size(), 2u);
  ASSERT_EQ(metrics["map_cartesian"].size(), 2u);
  const cv::Vec3b kKnown(120, 190, 110), kUnseen(40, 40, 40);
  for (int k = 0; k < 2; ++k) {
    const std::string stem = (run.dir / "maps" / ("view_" + std::to_string(k))).string();
    for (const char* suffix : {"_elevation.tiff", "_sigma.tiff", "_shadow_ceiling.tiff", "_state.png", "_meta.json",
                               "_elevation.png", "_sigma.png", "_state_view.png", "_error.png",
                               "_cartesian_elevation.tiff", "_cartesian_error.png"})
      EXPECT_TRUE(fs::exists(stem + suffix)) << stem + suffix;
    EXPECT_GT(metrics["map"][k]["coverage"].get<double>(), 0.0);
    const std::string fill = metrics["map_cartesian"][k]["gap_fill"].get<std::string>();
    EXPECT_TRUE(fill == "nearest" || fill == "linear") << fill;

    const auto meta = nlohmann::json::parse(slurp(stem + "_meta.json"));
    const int rows = meta["rows"], cols = meta["cols"];
    ASSERT_EQ(rows, 40);
    ASSERT_EQ(cols, 40);
    const cv::Mat state = cv::imread(stem + "_state.png", cv::IMREAD_UNCHANGED);
    const perception::Raster<float> z = readTiff(stem + "_elevation.tiff");
    const cv::Mat relief = reliefImage(z, meta["cell_m"].get<double>()).image;
    // 40 cells → 15 px each (600 / 40), 600 px at (8, 28).
    const cv::Mat view = readPicture(stem + "_state_view.png");
    const cv::Mat elevation = readPicture(stem + "_elevation.png");
    long known = 0, shadow = 0;
    for (int r = 0; r < rows; ++r)
      for (int c = 0; c < cols; ++c) {
        const int x = 15 * c + 7, y = 15 * r + 7;  // the cell's centre in the enlarged picture
        const auto s = perception::CellState(state.at<std::uint8_t>(r, c));
        const cv::Vec3b shown = view.at<cv::Vec3b>(28 + y, 8 + x), relief_shown = elevation.at<cv::Vec3b>(28 + y, 8 + x);
        if (s == perception::CellState::Shadow) {
          EXPECT_EQ(shown, test::hatch(x, y)) << r << "," << c;
          EXPECT_EQ(relief_shown, test::hatch(x, y)) << r << "," << c;
          ++shadow;
          continue;
        }
        EXPECT_EQ(shown, s == perception::CellState::Known ? kKnown : kUnseen) << r << "," << c;
        EXPECT_EQ(relief_shown, relief.at<cv::Vec3b>(r, c)) << r << "," << c;
        EXPECT_EQ(std::isfinite(z(r, c)), s == perception::CellState::Known) << r << "," << c;
        known += s == perception::CellState::Known;
      }
    EXPECT_GT(known, 100);
    RecordProperty("shadow_cells_view_" + std::to_string(k), int(shadow));
  }
}

}  // namespace
}  // namespace ambler::eval
