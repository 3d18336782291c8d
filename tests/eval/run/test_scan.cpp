// The scan stage of `ambler run` (eval/run/stages/scan.cpp): every scan file of the contract, and the
// world and scan pictures against the truth they show.
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

TEST(Run, WritesEveryScanFileOfTheContract) {
  const Scenario sc = parseScenario(kScenario, "inline.yaml");
  test::TempDir run;
  const auto metrics = runScenario(sc, {run.dir, false});
  for (const char* f : {"metrics.json", "scenario.resolved.yaml", "terrain.png", "world/world.xml", "world/terrain.bin"})
    EXPECT_TRUE(fs::exists(run.dir / f)) << f;
  for (int k = 0; k < 2; ++k) {
    const fs::path base = run.dir / "scans" / ("view_" + std::to_string(k));
    for (const char* suffix : {"_range.tiff", "_meta.json", ".ply", ".png"})
      EXPECT_TRUE(fs::exists(base.string() + suffix)) << base.string() + suffix;
    const perception::Raster<float> range = readTiff(base.string() + "_range.tiff");
    ASSERT_EQ(range.rows(), 32);
    ASSERT_EQ(range.cols(), 128);
    long valid = 0;
    for (long i = 0; i < range.size(); ++i) valid += std::isfinite(range.data()[i]);
    const auto& m = metrics["scan"][k];
    EXPECT_EQ(m["rays"].get<long>(), 32 * 128);
    EXPECT_NEAR(m["valid_fraction"].get<double>(), double(valid) / range.size(), 1e-12);
    // The PLY holds exactly the returns.
    const std::string ply = slurp(base.string() + ".ply");
    EXPECT_NE(ply.find("element vertex " + std::to_string(valid) + "\n"), std::string::npos);
    const auto meta = nlohmann::json::parse(slurp(base.string() + "_meta.json"));
    EXPECT_EQ(meta["phi_rad"].size(), 32u);
    EXPECT_EQ(meta["theta_rad"].size(), 128u);
    EXPECT_GT(meta["phi_rad"][0].get<double>(), meta["phi_rad"][31].get<double>());  // row 0 on top
    // σ = kρ² at ≤ 6 m is ≤ 1 cm, quantisation adds q/√12 = 2.2 cm: RMS well under 5 cm.
    EXPECT_LT(m["range_error_rms_m"].get<double>(), 0.05);
  }
  const auto on_disk = nlohmann::json::parse(slurp(run.dir / "metrics.json"));
  EXPECT_EQ(on_disk["name"], "run_test");
  EXPECT_EQ(on_disk["seed"], 11);
  EXPECT_TRUE(on_disk.contains("timing_s"));
}

// The pictures of the world and scan stages show what the run produced. terrain.png is the shaded
// relief of the ground truth on the world stage's grid (the scene's bounds at the terrain's cell,
// at most 1500 cells across), recomputed here from the world the run wrote: the same picture,
// pixel for pixel. Each scan picture is rangePicture of the scan read back (range TIFF, the meta's
// angles and pose); the pose comes back from degrees, which may move a shade's 8-bit truncation by
// one, so within 1 per channel; no-return pixels are black.
TEST(Run, WorldAndScanPicturesShowTheTruthAndTheScans) {
  const Scenario sc = parseScenario(kScenario, "inline.yaml");
  test::TempDir run;
  runScenario(sc, {run.dir, false});
  const sim::World world = sim::World::load(run.dir / "world" / "world.xml");
  const sim::RayScene scene(world);
  const sim::GroundTruth truth(scene);
  const Eigen::AlignedBox3d b = scene.bounds();
  const double extent = std::max(b.max().x() - b.min().x(), b.max().y() - b.min().y());
  const auto grid = perception::MapGrid::covering(b.min().x(), b.max().x(), b.min().y(), b.max().y(),
                                                  std::max(sc.terrain.cell_m, extent / 1500.0));
  const cv::Mat terrain = readPicture(run.dir / "terrain.png");
  const cv::Mat expected_terrain =
      shadedRelief(truth.elevation(grid).elevation(), grid.cell, sc.name + ": terrain (ground truth)");
  EXPECT_EQ(maxDifference(terrain, expected_terrain), 0.0);
  const int pic_rows = terrain.rows - 28 - 46, pic_cols = int(std::lround(grid.cols * 4.0));
  const auto f = test::FrameLayout::of(pic_rows, pic_cols);
  ASSERT_EQ(terrain.cols, f.width);
  test::expectColourScale(terrain, colourRamp(cv::COLORMAP_VIRIDIS), f.bar_x, f.bar_y, f.bar_w);

  for (int k = 0; k < 2; ++k) {
    const fs::path base = run.dir / "scans" / ("view_" + std::to_string(k));
    const auto meta = nlohmann::json::parse(slurp(base.string() + "_meta.json"));
    perception::RangeImage image;
    image.range = readTiff(base.string() + "_range.tiff");
    image.phi = meta["phi_rad"].get<std::vector<double>>();
    image.theta = meta["theta_rad"].get<std::vector<double>>();
    const auto xyz = meta["pose"]["xyz_m"].get<std::vector<double>>();
    const auto rpy = meta["pose"]["rpy_deg"].get<std::vector<double>>();
    const double deg = std::numbers::pi / 180.0;
    image.T_WS = perception::sensorPose({xyz[0], xyz[1], xyz[2]}, {rpy[0] * deg, rpy[1] * deg, rpy[2] * deg});
    const cv::Mat pic = readPicture(base.string() + ".png");
    const cv::Mat expected = rangePicture(image, sc.sensor.max_range_m, sc.name + ": view_" + std::to_string(k) + " range");
    EXPECT_LE(maxDifference(pic, expected), 1.0) << base;
    // 32 × 128 pixels over 30° × 80°: 8× across (1024 / 128) and 8·(30/32)/(80/128) = 12× down.
    const auto fr = test::FrameLayout::of(32 * 12, 128 * 8);
    ASSERT_EQ(pic.size(), cv::Size(fr.width, fr.canvasRows(32 * 12)));
    int none = 0;
    for (int r = 0; r < 32; ++r)
      for (int c = 0; c < 128; ++c)
        if (!image.valid(r, c)) {
          EXPECT_EQ(pic.at<cv::Vec3b>(fr.y0 + 12 * r + 6, fr.x0 + 8 * c + 4), cv::Vec3b(0, 0, 0)) << r << "," << c;
          ++none;
        }
    test::expectColourScale(pic, colourRamp(cv::COLORMAP_TURBO), fr.bar_x, fr.bar_y, fr.bar_w);
    RecordProperty("no_return_pixels_view_" + std::to_string(k), none);
  }
}

}  // namespace
}  // namespace ambler::eval
