// `ambler run` end to end: every file of the run directory (docs/scenario.md), consistent with
// itself, and the same scenario and seed give byte-identical files.
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
#include "picture_checks.hpp"
#include "sim/ground_truth.hpp"
#include "sim/ray_scene.hpp"
#include "sim/world.hpp"
#include "terrains/terrain.hpp"
#include "test_support.hpp"
#include "two_view_mars.hpp"

namespace ambler::eval {
namespace {

namespace fs = std::filesystem;
using test::slurp;

// The small two-view Mars scene with 0.4 m of relief, more rocks and two craters; no map.
test::TwoViewMars smallScene() {
  test::TwoViewMars scene = test::TwoViewMars::small();
  scene.name = "run_test";
  scene.seed = 11;
  scene.relief_m = "0.4";
  scene.rocks = "{abundance_k: 0.1, min_diameter_m: 0.15, max_diameter_m: 0.8}";
  scene.craters = "{count: 2, min_diameter_m: 1.0, max_diameter_m: 2.0}";
  scene.view1 = "{xyz_m: [0.5, -3.0, 2.0], rpy_deg: [0, -35, 10]}";
  scene.map_region = "";
  return scene;
}
const std::string kScenario = smallScene().yaml();

// A view inside a rock, below the ground or off the terrain is refused before the run writes
// anything, in one line naming the view and both heights (docs/errors.md, "Views").
TEST(Run, ViewsInsideARockOrBelowTheGroundAreRefusedBeforeAnythingIsWritten) {
  const Scenario good = parseScenario(kScenario, "inline.yaml");
  const terrains::Terrain terrain = terrains::makeTerrain(good.terrain, good.seed);
  ASSERT_FALSE(terrain.rocks.empty());
  // The highest point of any rock: the surface there is the rock's top, above the ground.
  Eigen::Vector3d apex(0, 0, -1e9);
  for (const auto& rock : terrain.rocks)
    for (const auto& v : rock.vertices)
      if ((rock.center + v).z() > apex.z()) apex = rock.center + v;
  const double ground = *terrain.ground.height(apex.x(), apex.y());
  ASSERT_GT(apex.z() - 0.02, ground);
  test::TempDir tmp;
  const auto refusal = [&](const Eigen::Vector3d& xyz) {
    Scenario sc = good;
    sc.views[1].xyz_m = xyz;
    try {
      runScenario(sc, {tmp.dir / "out", false});
    } catch (const ScenarioError& e) {
      return std::string(e.what());
    }
    return std::string("(no error)");
  };
  const std::string in_rock = refusal({apex.x(), apex.y(), apex.z() - 0.02});
  EXPECT_EQ(in_rock.rfind("inline.yaml: views[1].xyz_m: expected the sensor above the terrain, whose surface is at z = ", 0), 0u)
      << in_rock;
  char top[32];
  std::snprintf(top, sizeof top, "%.3f", apex.z());
  EXPECT_NE(in_rock.find(std::string("z = ") + top + " there"), std::string::npos) << in_rock;
  const std::string below = refusal({0.5, -3.0, ground - 5});
  EXPECT_NE(below.find("views[1].xyz_m: expected the sensor above the terrain"), std::string::npos) << below;
  // Built in code, past the reader's check: off the heightfield, no ground under the sensor.
  EXPECT_EQ(refusal({40, 0, 2}),
            "inline.yaml: views[1].xyz_m: expected a sensor over the terrain, got [40, 0, 2], where there is no ground");
  EXPECT_FALSE(fs::exists(tmp.dir / "out"));
}

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

cv::Mat readPicture(const fs::path& p) {
  cv::Mat img = cv::imread(p.string(), cv::IMREAD_COLOR);
  EXPECT_FALSE(img.empty()) << p;
  return img;
}

// The largest difference of any channel of any pixel (the sizes must agree).
double maxDifference(const cv::Mat& a, const cv::Mat& b) {
  if (a.size() != b.size() || a.type() != b.type()) return 1e9;
  return cv::norm(a, b, cv::NORM_INF);
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

// Same scenario, same seed: every file byte-identical (metrics.json after dropping timing_s, the
// one figure that measures the machine rather than the run).
TEST(Run, SameSeedGivesByteIdenticalFiles) {
  const Scenario sc = parseScenario(kScenario, "inline.yaml");
  test::TempDir a, b;
  runScenario(sc, {a.dir, false});
  runScenario(sc, {b.dir, false});
  int files = 0;
  for (const auto& e : fs::recursive_directory_iterator(a.dir)) {
    if (!e.is_regular_file()) continue;
    const fs::path rel = fs::relative(e.path(), a.dir);
    ASSERT_TRUE(fs::exists(b.dir / rel)) << rel;
    if (rel == "metrics.json") {
      auto ja = nlohmann::json::parse(slurp(e.path())), jb = nlohmann::json::parse(slurp(b.dir / rel));
      ja.erase("timing_s"), jb.erase("timing_s");
      EXPECT_EQ(ja.dump(), jb.dump());
    } else {
      EXPECT_EQ(slurp(e.path()), slurp(b.dir / rel)) << rel;
    }
    ++files;
  }
  EXPECT_GT(files, 10);
  Scenario other = sc;
  other.seed = 12;
  test::TempDir c;
  runScenario(other, {c.dir, false});
  EXPECT_NE(slurp(a.dir / "world/terrain.bin"), slurp(c.dir / "world/terrain.bin"));
  EXPECT_NE(slurp(a.dir / "scans/view_0_range.tiff"), slurp(c.dir / "scans/view_0_range.tiff"));
}


// The two-view Mars scene on a 16 m square, mapped on 8 × 9 m, view 1 at the pose `view1`
// ("[x, y, z], rpy_deg: [...]").
std::string twoViews(const std::string& name, const std::string& view1) {
  test::TwoViewMars scene;
  scene.name = name;
  scene.size_m = "[16, 16]";
  scene.view1 = "{xyz_m: " + view1 + "}";
  scene.map_region = "{x_m: [-4, 4], y_m: [-3, 6]}";
  return scene.yaml();
}

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

// The leg stage on flat ground: on rock the foot settles level (tilt < 0.1°, slip < 1 mm, sink
// < 1 mm); on sand it sinks by Bekker's law for the load (within 10 %), docs/leg.md.
TEST(Run, LegStageStepsOnEachChoice) {
  for (const char* soil : {"rock", "sand"}) {
    const Scenario sc = parseScenario(std::string(R"(name: leg_test
seed: 1
terrain: {kind: plane, size_m: [8, 8], cell_m: 0.05}
sensor: {noise_k: 0, quantization_m: 0, mixed_pixels: false}
views: [{xyz_m: [0, -3, 2.0], rpy_deg: [0, -35, 0]}]
map: {cell_m: 0.1, region: {x_m: [-2, 2], y_m: [-1, 3]}, baseline: none}
footfall: {region: {x_m: [-0.5, 0.5], y_m: [0.5, 1.5]}, methods: [max_min, equilibrium]}
leg: {soil: )") + soil + ", load_n: 3000}\n",
                                      "inline.yaml");
    test::TempDir run;
    const auto metrics = runScenario(sc, {run.dir, false});
    EXPECT_TRUE(std::filesystem::exists(run.dir / "world" / "leg.xml"));
    ASSERT_EQ(metrics["footfall"].size(), 2u);
    // A rigid disk rests level on flat ground at every candidate of the region: the cells whose
    // centres lie a foot radius inside the 1 × 1 m region, 8 × 8 at 10 cm.
    const cv::Mat predicted = cv::imread((run.dir / "leg" / "predicted_tilt.tiff").string(), cv::IMREAD_UNCHANGED);
    ASSERT_FALSE(predicted.empty());
    int candidates = 0;
    for (int r = 0; r < predicted.rows; ++r)
      for (int c = 0; c < predicted.cols; ++c)
        if (std::isfinite(predicted.at<float>(r, c))) {
          ++candidates;
          EXPECT_LT(std::abs(predicted.at<float>(r, c)), 0.01);
        }
    EXPECT_EQ(candidates, 64);
    // Bekker's law by hand for the scenario's 3 kN on the 30 cm foot in dry sand (the working is in
    // tests/sim/test_leg.cpp): z = (W/(π·b²)/(k_c/b + k_φ))^(1/n) = 38.31 mm.
    const double b = 0.15, n = 1.1, k_c = 0.99e3, k_phi = 1528.43e3;
    const double bekker = std::pow(3000 / (std::numbers::pi * b * b) / (k_c / b + k_phi), 1.0 / n);
    const double expected_sink = std::string(soil) == "sand" ? bekker : 0.0;
    for (const auto& f : metrics["footfall"]) {
      const auto& leg = f["leg"];
      SCOPED_TRACE(std::string(soil) + " " + f["method"].get<std::string>());
      EXPECT_TRUE(leg["settled"].get<bool>());
      EXPECT_LT(leg["tilt_deg"].get<double>(), 0.1);
      EXPECT_LT(leg["slip_m"].get<double>(), 0.001);
      if (expected_sink > 0)
        EXPECT_NEAR(leg["sink_m"].get<double>(), expected_sink, 0.1 * expected_sink);
      else
        EXPECT_LT(leg["sink_m"].get<double>(), 0.001);
      EXPECT_TRUE(std::filesystem::exists(run.dir / "leg" / (f["method"].get<std::string>() + ".json")));
    }
  }
}

}  // namespace
}  // namespace ambler::eval
