// Map metrics on a hand-made 4 × 5 map whose every figure is worked out by hand, and the map files
// read back bit for bit. AMBLER_TEST_PICTURES=DIR keeps the pictures in DIR to look at.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <opencv2/imgcodecs.hpp>

#include "eval/io.hpp"
#include "eval/map_metrics.hpp"
#include "eval/map_outputs.hpp"

namespace ambler::eval {
namespace {

// Ground truth as the runner has it (sim::GroundTruth::elevation): a map on `grid`, Known with
// σ_z = 0 where z is finite.
perception::ElevationMap truthMap(const perception::MapGrid& grid, const perception::Raster<float>& z) {
  perception::ElevationMap m(grid);
  for (int r = 0; r < grid.rows; ++r)
    for (int c = 0; c < grid.cols; ++c)
      if (std::isfinite(z(r, c))) m.setKnown(r, c, z(r, c), 0.0f);
  return m;
}

namespace fs = std::filesystem;
using perception::CellState;
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

// The hand-made case. States (K known, S shadow, U unseen) and truth visibility (v visible,
// h hidden, o out of view):
//   K K K K K     v v v v h
//   K K K S S     v v v h h
//   S U U U U     o v v v o
//   U U U U U     h o o o o
// Truth is 1 m everywhere but (1,2), a known cell with no surface below. The seven compared
// cells have errors 0.5, −0.25, 0.125, 0, −1, 0.75, 0.25 m and σ 0.5, 0.5, 0.0625, 0.1, 0.25,
// 0.25, 0.2 m: within 1σ (0,0) (0,1) (0,3) — 3/7, the first on the boundary; within 2σ also (0,2)
// (boundary) and (1,1) — 5/7. (0,4) is hidden, known and 1 m > 3σ off.
struct Case {
  perception::ElevationMap map;
  perception::Raster<float> truth;
  perception::Raster<std::uint8_t> vis;
  Case() : map(perception::MapGrid{-1.0, 2.0, 0.5, 4, 5}), truth(4, 5), vis(4, 5) {
    truth.setConstant(1.0f);
    truth(1, 2) = kNaN;
    const float err[7] = {0.5f, -0.25f, 0.125f, 0.0f, -1.0f, 0.75f, 0.25f};
    const float sig[7] = {0.5f, 0.5f, 0.0625f, 0.1f, 0.25f, 0.25f, 0.2f};
    const int cells[7][2] = {{0, 0}, {0, 1}, {0, 2}, {0, 3}, {0, 4}, {1, 0}, {1, 1}};
    for (int i = 0; i < 7; ++i) map.setKnown(cells[i][0], cells[i][1], 1.0f + err[i], sig[i]);
    map.setKnown(1, 2, 3.0f, 0.1f);
    map.setUnknown(1, 3, CellState::Shadow);
    map.setShadow(1, 4, 0.75f);  // a shadow cell with a ceiling
    map.setUnknown(2, 0, CellState::Shadow);
    const char* v[4] = {"vvvvh", "vvvhh", "ovvvo", "hoooo"};
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 5; ++c)
        vis(r, c) = std::uint8_t(v[r][c] == 'v' ? sim::Visibility::Visible
                                 : v[r][c] == 'h' ? sim::Visibility::Hidden
                                                  : sim::Visibility::OutOfView);
  }
};

TEST(MapMetrics, HandMadeCase) {
  const Case k;
  const MapMetrics m = mapMetrics(k.map, truthMap(k.map.grid(), k.truth), k.vis);
  EXPECT_EQ(m.cells, 20);
  EXPECT_EQ(m.known, 8);
  EXPECT_EQ(m.shadow, 3);
  EXPECT_EQ(m.visible, 10);
  EXPECT_EQ(m.hidden, 4);
  EXPECT_EQ(m.compared, 7);
  EXPECT_DOUBLE_EQ(m.coverage, 7.0 / 10.0);  // the seven visible known cells of rows 0–1
  EXPECT_DOUBLE_EQ(m.rms_error_m, std::sqrt((0.25 + 0.0625 + 0.015625 + 0 + 1 + 0.5625 + 0.0625) / 7));
  EXPECT_DOUBLE_EQ(m.median_abs_error_m, 0.25);  // 0, 0.125, 0.25, [0.25], 0.5, 0.75, 1
  EXPECT_DOUBLE_EQ(m.max_abs_error_m, 1.0);
  EXPECT_NEAR(m.p95_abs_error_m, 0.75 + 0.7 * 0.25, 1e-12);  // rank 0.95 · 6 = 5.7
  EXPECT_DOUBLE_EQ(m.shadow_precision, 2.0 / 3.0);  // (1,3) (1,4) hidden, (2,0) out of view
  EXPECT_DOUBLE_EQ(m.shadow_recall, 2.0 / 4.0);     // (0,4) known and (3,0) unseen are missed
  EXPECT_DOUBLE_EQ(m.within_1sigma, 3.0 / 7.0);
  EXPECT_DOUBLE_EQ(m.within_2sigma, 5.0 / 7.0);
  EXPECT_EQ(m.known_in_shadow_above_3sigma, 1);
}

TEST(MapMetrics, EvenCountMedianAveragesTheMiddlePair) {
  Case k;
  k.map.setUnknown(1, 1, CellState::Unseen);  // drops |e| 0.25: 0, 0.125, [0.25, 0.5], 0.75, 1
  const MapMetrics m = mapMetrics(k.map, truthMap(k.map.grid(), k.truth), k.vis);
  EXPECT_EQ(m.compared, 6);
  EXPECT_DOUBLE_EQ(m.median_abs_error_m, 0.375);
}

TEST(MapMetrics, EmptyPopulationsAreNaNAndJsonNull) {
  perception::ElevationMap map(perception::MapGrid{0.0, 1.0, 0.5, 2, 2});  // all unseen
  const perception::Raster<float> truth = perception::Raster<float>::Constant(2, 2, 0.0f);
  const perception::Raster<std::uint8_t> vis = perception::Raster<std::uint8_t>::Constant(2, 2, std::uint8_t(sim::Visibility::Visible));
  const MapMetrics m = mapMetrics(map, truthMap(map.grid(), truth), vis);
  EXPECT_EQ(m.known, 0);
  EXPECT_DOUBLE_EQ(m.coverage, 0.0);
  EXPECT_TRUE(std::isnan(m.rms_error_m));
  EXPECT_TRUE(std::isnan(m.shadow_precision));  // no cell reported Shadow
  EXPECT_TRUE(std::isnan(m.shadow_recall));     // no cell truly hidden
  const auto j = toJson(m, 3);
  EXPECT_EQ(j["view"], 3);
  EXPECT_EQ(j["coverage"], 0.0);
  for (const char* key : {"rms_error_m", "median_abs_error_m", "shadow_precision", "shadow_recall",
                          "within_1sigma", "within_2sigma", "max_abs_error_m", "p95_abs_error_m"})
    EXPECT_TRUE(j[key].is_null()) << key;
  EXPECT_EQ(j.dump().find("NaN"), std::string::npos);
  EXPECT_TRUE(cartesianJson(m, 3)["rms_error_m"].is_null());
}

TEST(MapMetrics, JsonKeysInContractOrder) {
  const Case k;
  const MapMetrics m = mapMetrics(k.map, truthMap(k.map.grid(), k.truth), k.vis);
  const auto keys = [](const nlohmann::ordered_json& j) {
    std::vector<std::string> out;
    for (const auto& item : j.items()) out.push_back(item.key());
    return out;
  };
  const std::vector<std::string> map_keys{
      "view",    "cells",           "coverage",        "rms_error_m", "median_abs_error_m", "shadow_precision",
      "shadow_recall", "within_1sigma", "within_2sigma", "known", "max_abs_error_m", "p95_abs_error_m",
      "known_in_shadow_above_3sigma", "shadow", "visible", "hidden", "compared"};
  EXPECT_EQ(keys(toJson(m, 0)), map_keys);
  const std::vector<std::string> cart_keys{"view", "coverage", "rms_error_m", "median_abs_error_m", "cells",
                                           "known", "max_abs_error_m", "p95_abs_error_m", "within_1sigma",
                                           "within_2sigma", "compared"};
  EXPECT_EQ(keys(cartesianJson(m, 0)), cart_keys);
  EXPECT_EQ(toJson(m, 0)["within_1sigma"].get<double>(), 3.0 / 7.0);
}

TEST(MapMetrics, RejectsRastersOffTheMapGrid) {
  const Case k;
  EXPECT_THROW(mapMetrics(k.map, truthMap(perception::MapGrid{-1.0, 2.0, 0.5, 5, 4}, perception::Raster<float>::Zero(5, 4)), k.vis), std::invalid_argument);
  EXPECT_THROW(mapMetrics(k.map, truthMap(k.map.grid(), k.truth), perception::Raster<std::uint8_t>(4, 4)), std::invalid_argument);
}

// Range bands on a 1 × 8 row of 1 m cells, the sensor at (0.5, 0.5, 0) above the centre of cell 0,
// so each cell's range is |(c, 0, z_c)|. Per cell: truth z, range, band, state, error, σ,
// visibility:
//   0:  6   6      [6, 9)    K  +0.5   1     v
//   1:  0   1      [0, 6)    K  −0.25  0.1   v
//   2: 10   10.2   [9, 12)   K  +0.375 NaN   v
//   3:  4   5      [0, 6)    U               v
//   4: NaN  —      none      K  (no truth: in no band)
//   5: 12  13      [12, 16)  S               h
//   6:  8  10      [9, 12)   K  −0.5   0.5   v
//   7:  0   7      [6, 9)    K  +0.25  0.25  o
// Cell 0 sits exactly on the 6 m edge: bands are [lo, hi).
TEST(MapMetrics, RangeBandsByDistanceToTheTrueSurface) {
  perception::ElevationMap map(perception::MapGrid{0.0, 1.0, 1.0, 1, 8});
  perception::Raster<float> truth(1, 8);
  perception::Raster<std::uint8_t> vis(1, 8);
  const float z[8] = {6, 0, 10, 4, kNaN, 12, 8, 0};
  const char* v = "vvvvvhvo";
  for (int c = 0; c < 8; ++c) {
    truth(0, c) = z[c];
    vis(0, c) = std::uint8_t(v[c] == 'v' ? sim::Visibility::Visible
                             : v[c] == 'h' ? sim::Visibility::Hidden
                                           : sim::Visibility::OutOfView);
  }
  map.setKnown(0, 0, 6.5f, 1.0f);
  map.setKnown(0, 1, -0.25f, 0.1f);
  map.setKnown(0, 2, 10.375f, kNaN);
  map.setKnown(0, 4, 1.0f, 0.1f);
  map.setUnknown(0, 5, CellState::Shadow);
  map.setKnown(0, 6, 7.5f, 0.5f);
  map.setKnown(0, 7, 0.25f, 0.25f);
  const Eigen::Vector3d sensor(0.5, 0.5, 0.0);
  const MapMetrics m = mapMetrics(map, truthMap(map.grid(), truth), vis, &sensor);
  ASSERT_EQ(m.bands.size(), 5u);
  const double inf = std::numeric_limits<double>::infinity();
  const double lo[5] = {0, 6, 9, 12, 16}, hi[5] = {6, 9, 12, 16, inf};
  const long visible[5] = {2, 1, 2, 0, 0}, known[5] = {1, 2, 2, 0, 0};
  for (int b = 0; b < 5; ++b) {
    EXPECT_EQ(m.bands[b].lo_m, lo[b]);
    EXPECT_EQ(m.bands[b].hi_m, hi[b]);
    EXPECT_EQ(m.bands[b].visible, visible[b]) << b;
    EXPECT_EQ(m.bands[b].known, known[b]) << b;
  }
  EXPECT_DOUBLE_EQ(m.bands[0].coverage, 0.5);  // cell 3 unseen
  EXPECT_DOUBLE_EQ(m.bands[0].rms_error_m, 0.25);
  EXPECT_DOUBLE_EQ(m.bands[0].median_abs_error_m, 0.25);
  EXPECT_DOUBLE_EQ(m.bands[0].within_1sigma, 0.0);
  EXPECT_DOUBLE_EQ(m.bands[1].coverage, 1.0);  // cell 7 is known but out of view
  EXPECT_DOUBLE_EQ(m.bands[1].rms_error_m, std::sqrt((0.25 + 0.0625) / 2));
  EXPECT_DOUBLE_EQ(m.bands[1].median_abs_error_m, 0.375);
  EXPECT_DOUBLE_EQ(m.bands[1].within_1sigma, 1.0);  // 0.25 ≤ 0.25 on the boundary
  EXPECT_DOUBLE_EQ(m.bands[2].coverage, 1.0);
  EXPECT_DOUBLE_EQ(m.bands[2].rms_error_m, std::sqrt((0.140625 + 0.25) / 2));
  EXPECT_DOUBLE_EQ(m.bands[2].median_abs_error_m, 0.4375);
  EXPECT_DOUBLE_EQ(m.bands[2].within_1sigma, 1.0);  // cell 2 has no σ
  for (int b : {3, 4}) {
    EXPECT_TRUE(std::isnan(m.bands[b].coverage)) << b;
    EXPECT_TRUE(std::isnan(m.bands[b].rms_error_m)) << b;
    EXPECT_TRUE(std::isnan(m.bands[b].within_1sigma)) << b;
  }

  // The whole-map figures do not depend on the bands; without a sensor there are none.
  const MapMetrics plain = mapMetrics(map, truthMap(map.grid(), truth), vis);
  EXPECT_TRUE(plain.bands.empty());
  EXPECT_EQ(plain.compared, m.compared);
  EXPECT_EQ(plain.rms_error_m, m.rms_error_m);
  EXPECT_FALSE(toJson(plain, 0).contains("by_range"));
  EXPECT_FALSE(cartesianJson(plain, 0).contains("by_range"));

  // JSON: by_range after the existing keys; an open upper edge and empty figures are null.
  for (const auto& j : {toJson(m, 0), cartesianJson(m, 0)}) {
    EXPECT_EQ(j.items().begin().key(), "view");
    EXPECT_EQ((--j.end()).key(), "by_range");
    const auto& bands = j["by_range"];
    ASSERT_EQ(bands.size(), 5u);
    std::vector<std::string> keys;
    for (const auto& item : bands[0].items()) keys.push_back(item.key());
    EXPECT_EQ(keys, (std::vector<std::string>{"range_m", "visible", "known", "coverage", "rms_error_m",
                                              "median_abs_error_m", "within_1sigma"}));
    EXPECT_EQ(bands[0]["range_m"], nlohmann::json::parse("[0.0, 6.0]"));
    EXPECT_EQ(bands[4]["range_m"][0].get<double>(), 16.0);
    EXPECT_TRUE(bands[4]["range_m"][1].is_null());
    EXPECT_EQ(bands[1]["median_abs_error_m"].get<double>(), 0.375);
    EXPECT_TRUE(bands[3]["rms_error_m"].is_null());
  }
  auto j = toJson(m, 0);
  j.erase("by_range");
  EXPECT_EQ(j.dump(), toJson(plain, 0).dump());
  auto cj = cartesianJson(m, 0);
  cj.erase("by_range");
  EXPECT_EQ(cj.dump(), cartesianJson(plain, 0).dump());
}

// A directory that is removed afterwards, or AMBLER_TEST_PICTURES if set (kept).
struct OutDir {
  fs::path dir;
  bool keep = false;
  OutDir() {
    static int n = 0;
    if (const char* env = std::getenv("AMBLER_TEST_PICTURES")) {
      dir = env, keep = true;
    } else {
      dir = fs::temp_directory_path() / ("ambler-maps-" + std::to_string(::getpid()) + "-" + std::to_string(n++));
    }
    fs::create_directories(dir);
  }
  ~OutDir() {
    std::error_code ec;
    if (!keep) fs::remove_all(dir, ec);
  }
};

bool sameBits(const perception::Raster<float>& a, const perception::Raster<float>& b) {
  return a.rows() == b.rows() && a.cols() == b.cols() &&
         std::memcmp(a.data(), b.data(), sizeof(float) * std::size_t(a.size())) == 0;
}

TEST(MapFiles, RastersReadBackBitForBit) {
  const Case k;
  OutDir out;
  const perception::ElevationMap case_truth = truthMap(k.map.grid(), k.truth);
  writeMapFiles(out.dir, "case", k.map, &case_truth, "hand-made case");
  EXPECT_TRUE(sameBits(readTiff(out.dir / "case_elevation.tiff"), k.map.elevation()));
  EXPECT_TRUE(sameBits(readTiff(out.dir / "case_sigma.tiff"), k.map.sigma()));
  const perception::Raster<float> ceiling = readTiff(out.dir / "case_shadow_ceiling.tiff");
  EXPECT_TRUE(sameBits(ceiling, k.map.shadowCeiling()));
  EXPECT_EQ(ceiling(1, 4), 0.75f);           // the shadow cell's ceiling
  EXPECT_TRUE(std::isnan(ceiling(1, 3)));    // a shadow cell without one
  EXPECT_TRUE(std::isnan(ceiling(0, 0)));    // a known cell
  const cv::Mat state = cv::imread((out.dir / "case_state.png").string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(state.type(), CV_8UC1);
  ASSERT_EQ(state.rows, 4);
  ASSERT_EQ(state.cols, 5);
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 5; ++c) EXPECT_EQ(state.at<std::uint8_t>(r, c), k.map.state()(r, c)) << r << "," << c;
  EXPECT_EQ(state.at<std::uint8_t>(2, 0), 2);  // values are the states themselves
  EXPECT_EQ(state.at<std::uint8_t>(0, 0), 1);

  std::ifstream in(out.dir / "case_meta.json");
  const auto meta = nlohmann::ordered_json::parse(in);
  std::vector<std::string> keys;
  for (const auto& item : meta.items()) keys.push_back(item.key());
  EXPECT_EQ(keys, (std::vector<std::string>{"x_min_m", "y_max_m", "cell_m", "rows", "cols"}));
  EXPECT_EQ(meta["x_min_m"].get<double>(), -1.0);
  EXPECT_EQ(meta["y_max_m"].get<double>(), 2.0);
  EXPECT_EQ(meta["cell_m"].get<double>(), 0.5);
  EXPECT_EQ(meta["rows"].get<int>(), 4);
  EXPECT_EQ(meta["cols"].get<int>(), 5);

  for (const char* name : {"case_elevation.png", "case_error.png", "case_sigma.png", "case_state_view.png"}) {
    const cv::Mat pic = cv::imread((out.dir / name).string(), cv::IMREAD_UNCHANGED);
    ASSERT_FALSE(pic.empty()) << name;
    EXPECT_EQ(pic.type(), CV_8UC3) << name;
    EXPECT_GE(pic.cols, 600) << name;
  }
}

TEST(MapFiles, RowZeroIsNorth) {
  // A single known cell at the north-west point (−0.9, 1.9) lands at raster (0, 0), and the meta
  // formula x = x_min + (c + ½)·cell, y = y_max − (r + ½)·cell gives back its centre.
  perception::ElevationMap map(perception::MapGrid{-1.0, 2.0, 0.5, 4, 5});
  const auto cell = map.grid().cellOf(-0.9, 1.9);
  ASSERT_TRUE(cell);
  map.setKnown((*cell)(0), (*cell)(1), 7.0f, 0.01f);
  OutDir out;
  writeMapFiles(out.dir, "nw", map, nullptr, "north-west");
  const perception::Raster<float> z = readTiff(out.dir / "nw_elevation.tiff");
  EXPECT_EQ(z(0, 0), 7.0f);
  EXPECT_TRUE(std::isnan(z(3, 0)));
  std::ifstream in(out.dir / "nw_meta.json");
  const auto meta = nlohmann::json::parse(in);
  const double cell_m = meta["cell_m"];
  EXPECT_DOUBLE_EQ(meta["x_min_m"].get<double>() + 0.5 * cell_m, -0.75);
  EXPECT_DOUBLE_EQ(meta["y_max_m"].get<double>() - 0.5 * cell_m, 1.75);
  EXPECT_FALSE(fs::exists(out.dir / "nw_error.png"));  // no truth, no error picture
}

TEST(MapFiles, CartesianFilesAndGridMismatch) {
  const Case k;
  OutDir out;
  const perception::ElevationMap case_truth = truthMap(k.map.grid(), k.truth);
  writeCartesianFiles(out.dir, "case", k.map, &case_truth, "hand-made case, Cartesian");
  EXPECT_TRUE(sameBits(readTiff(out.dir / "case_cartesian_elevation.tiff"), k.map.elevation()));
  EXPECT_FALSE(cv::imread((out.dir / "case_cartesian_error.png").string()).empty());
  const perception::ElevationMap wrong(perception::MapGrid{-1.0, 2.0, 0.5, 3, 5});
  EXPECT_THROW(writeMapFiles(out.dir, "bad", k.map, &wrong, "x"), std::invalid_argument);
}

// A larger synthetic map to look at: a smooth surface, a fan-shaped field of view, a shadow
// behind a ridge, σ growing with range and errors of about σ.
TEST(MapFiles, PicturesOfASyntheticMap) {
  const perception::MapGrid grid{-5.0, 8.0, 0.1, 110, 100};
  perception::ElevationMap map(grid);
  perception::Raster<float> truth(grid.rows, grid.cols);
  for (int r = 0; r < grid.rows; ++r)
    for (int c = 0; c < grid.cols; ++c) {
      const auto p = grid.center(r, c);
      const double ridge = 0.4 * std::exp(-std::pow((p.y() - 2.0) / 0.4, 2));
      truth(r, c) = float(0.15 * std::sin(0.9 * p.x()) * std::cos(0.7 * p.y()) + ridge);
      const double range = std::hypot(p.x(), p.y() + 6.0), bearing = std::atan2(p.x(), p.y() + 6.0);
      if (std::abs(bearing) > 0.55 || range < 3.5) continue;
      if (p.y() > 2.5 && p.y() < 2.5 + 0.2 * range) {
        map.setUnknown(r, c, CellState::Shadow);
        continue;
      }
      const double sigma = 0.0003 * range * range + 0.005;
      const double wiggle = std::sin(12.9898 * r + 78.233 * c) * 43758.5453;
      const double e = 2.0 * (wiggle - std::floor(wiggle) - 0.5) * sigma * 1.7;
      map.setKnown(r, c, truth(r, c) + float(e), float(sigma));
    }
  OutDir out;
  const perception::ElevationMap truth_map = truthMap(grid, truth);
  writeMapFiles(out.dir, "synthetic", map, &truth_map, "synthetic view 0");
  writeCartesianFiles(out.dir, "synthetic", map, &truth_map, "synthetic view 0, Cartesian");
  for (const char* name : {"synthetic_elevation.png", "synthetic_error.png", "synthetic_sigma.png",
                           "synthetic_state_view.png", "synthetic_cartesian_error.png"}) {
    const cv::Mat pic = cv::imread((out.dir / name).string(), cv::IMREAD_UNCHANGED);
    ASSERT_FALSE(pic.empty()) << name;
    EXPECT_GE(pic.cols, 600) << name;
  }
}

}  // namespace
}  // namespace ambler::eval
