// Map metrics on a hand-made 4 × 5 map whose every figure is worked out by hand, and the map files
// read back bit for bit. AMBLER_TEST_PICTURES=DIR keeps the pictures in DIR to look at.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "eval/pictures/figures.hpp"
#include "eval/scenario/io.hpp"
#include "eval/score/map_metrics.hpp"
#include "eval/pictures/map_outputs.hpp"
#include "eval/picture_checks.hpp"

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

// The map pictures' colours (map_outputs.cpp): unseen cells in shadedRelief's no-data grey,
// unknown ones lighter grey, known cells without truth a middle grey, known ones in the state view
// green; range shadow hatched (test::hatch).
const cv::Vec3b kUnseen(40, 40, 40), kUnknown(150, 150, 150), kNoTruth(95, 95, 95), kKnown(120, 190, 110);

// The error pictures' diverging ramp: level i at t = i/127.5 − 1, white (247, 247, 247) blended
// linearly towards Moreland's cool-warm blue (BGR 192, 76, 59) for t < 0 and red (38, 4, 180) for
// t > 0, each channel rounded.
cv::Mat divergingRamp() {
  const cv::Vec3d blue(192, 76, 59), white(247, 247, 247), red(38, 4, 180);
  cv::Mat ramp(1, 256, CV_8UC3);
  for (int i = 0; i < 256; ++i) {
    const double t = i / 127.5 - 1.0;
    const cv::Vec3d c = t < 0 ? white + (-t) * (blue - white) : white + t * (red - white);
    ramp.at<cv::Vec3b>(0, i) = cv::Vec3b(uchar(std::lround(c[0])), uchar(std::lround(c[1])), uchar(std::lround(c[2])));
  }
  return ramp;
}

// The cells of a map picture: k × k px each (the smallest integer enlargement to ≥ 600 px wide,
// cut while the picture would be taller than 2400 px), the picture at (x0, 28) of the canvas.
struct CellLayout {
  int k, x0;
  explicit CellLayout(const perception::MapGrid& g) {
    k = std::max(1, (600 + g.cols - 1) / g.cols);
    while (k > 1 && g.rows * k > 2400) --k;
    x0 = (std::max(g.cols * k + 16, 360) - g.cols * k) / 2;
  }
  // Every pixel of cell (r, c) has the colour f(x, y) (x, y in the enlarged picture).
  template <class F>
  ::testing::AssertionResult cellIs(const cv::Mat& canvas, int r, int c, F f) const {
    for (int y = k * r; y < k * (r + 1); ++y)
      for (int x = k * c; x < k * (c + 1); ++x)
        if (canvas.at<cv::Vec3b>(28 + y, x0 + x) != f(x, y))
          return ::testing::AssertionFailure() << "cell " << r << "," << c << " pixel " << x << "," << y << ": "
                                               << canvas.at<cv::Vec3b>(28 + y, x0 + x) << " not " << f(x, y);
    return ::testing::AssertionSuccess();
  }
  ::testing::AssertionResult cellIs(const cv::Mat& canvas, int r, int c, const cv::Vec3b& colour) const {
    return cellIs(canvas, r, c, [&](int, int) { return colour; });
  }
  ::testing::AssertionResult cellIsHatched(const cv::Mat& canvas, int r, int c) const {
    return cellIs(canvas, r, c, [](int x, int y) { return test::hatch(x, y); });
  }
};

cv::Mat readPicture(const fs::path& p) {
  cv::Mat img = cv::imread(p.string(), cv::IMREAD_COLOR);
  EXPECT_FALSE(img.empty()) << p;
  return img;
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
  EXPECT_EQ(keys, (std::vector<std::string>{"x_min_m", "y_max_m", "cell_m", "rows", "cols", "frame"}));
  EXPECT_EQ(meta["frame"]["origin_m"], nlohmann::ordered_json({0.0, 0.0, 0.0}));  // the world frame
  EXPECT_EQ(meta["frame"]["yaw_deg"].get<double>(), 0.0);
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
  // The picture is north-up too: the known cell is the top-left block of the state view.
  const cv::Mat view = readPicture(out.dir / "nw_state_view.png");
  const CellLayout at(map.grid());
  EXPECT_TRUE(at.cellIs(view, 0, 0, kKnown));
  EXPECT_TRUE(at.cellIs(view, 3, 0, kUnseen));
  EXPECT_TRUE(at.cellIs(view, 0, 4, kUnseen));
}

// Each picture of the hand-made case, cell by cell (the 4 × 5 grid is enlarged 120×: 600 × 480 px
// at (8, 28) of a 616 px canvas), with its colour scale (framed pictures: 440 px from x = 88, 8 px
// under the picture) and its legend swatches (4 px under the canvas, from x = 8).
TEST(MapFiles, PicturesShowEachCell) {
  const Case k;
  OutDir out;
  const perception::ElevationMap case_truth = truthMap(k.map.grid(), k.truth);
  writeMapFiles(out.dir, "case", k.map, &case_truth, "hand-made case");
  const CellLayout at(k.map.grid());
  ASSERT_EQ(at.k, 120);
  ASSERT_EQ(at.x0, 8);
  const int framed_rows = 480 + 28 + 46, bar_y = 28 + 480 + 8, bar_w = 616 - 16 - 160;
  auto isShadow = [&](int r, int c) { return k.map.stateAt(r, c) == CellState::Shadow; };

  // Elevation: each cell the colour reliefImage gives it (unseen: dark grey), shadow hatched.
  const cv::Mat elevation = readPicture(out.dir / "case_elevation.png");
  ASSERT_EQ(elevation.size(), cv::Size(616, framed_rows + 26));
  const cv::Mat relief = reliefImage(k.map.elevation(), 0.5).image;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 5; ++c) {
      if (isShadow(r, c)) {
        EXPECT_TRUE(at.cellIsHatched(elevation, r, c));
      } else {
        EXPECT_TRUE(at.cellIs(elevation, r, c, relief.at<cv::Vec3b>(r, c)));
        if (k.map.stateAt(r, c) == CellState::Unseen) {
          EXPECT_EQ(relief.at<cv::Vec3b>(r, c), kUnseen);
        }
      }
    }
  test::expectColourScale(elevation, colourRamp(cv::COLORMAP_VIRIDIS), 88, bar_y, bar_w);
  {
    const auto xs = test::legendSwatchX({"unseen", "range shadow"});
    test::expectSwatch(elevation, xs[0], framed_rows + 4, kUnseen, false, "elevation: unseen");
    test::expectSwatch(elevation, xs[1], framed_rows + 4, test::kShadow, true, "elevation: shadow");
  }

  // σ: inferno at 255·(σ − lo)/(hi − lo) rounded over the known cells' σ, lo = 0.0625, hi = 0.5:
  // 0.5 → 255, 0.0625 → 0, 0.25 → 109.29, 0.2f → 80.14, 0.1f → 21.86.
  const cv::Mat sigma = readPicture(out.dir / "case_sigma.png");
  ASSERT_EQ(sigma.size(), cv::Size(616, framed_rows + 26));
  const cv::Mat inferno = colourRamp(cv::COLORMAP_INFERNO);
  const int sigma_level[2][5] = {{255, 255, 0, 22, 109}, {109, 80, 22, -1, -1}};
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 5; ++c) {
      if (isShadow(r, c)) {
        EXPECT_TRUE(at.cellIsHatched(sigma, r, c));
      } else if (k.map.stateAt(r, c) == CellState::Known) {
        EXPECT_TRUE(at.cellIs(sigma, r, c, inferno.at<cv::Vec3b>(0, sigma_level[r][c])));
      } else {
        EXPECT_TRUE(at.cellIs(sigma, r, c, kUnknown));
      }
    }
  test::expectColourScale(sigma, inferno, 88, bar_y, bar_w);
  {
    const auto xs = test::legendSwatchX({"unknown", "range shadow"});
    test::expectSwatch(sigma, xs[0], framed_rows + 4, kUnknown, false, "sigma: unknown");
    test::expectSwatch(sigma, xs[1], framed_rows + 4, test::kShadow, true, "sigma: shadow");
  }

  // Error: the diverging ramp at 127.5 + 127.5·e/s rounded and clamped, s the 99th percentile of
  // |e| (rank ⌊0.99·6⌋ = 5 of 0, 0.125, 0.25, 0.25, 0.5, 0.75, 1: s = 0.75). e = 0.5 → 212.5 → 213,
  // −0.25 → 85, 0.125 → 148.75 → 149, 0 → 127.5 → 128, −1 → −42.5 → 0 (full blue), 0.75 → 255
  // (full red), 0.25 → 170. (1, 2) is known without truth.
  const cv::Mat error = readPicture(out.dir / "case_error.png");
  ASSERT_EQ(error.size(), cv::Size(616, framed_rows + 26));
  const cv::Mat diverging = divergingRamp();
  const int error_level[2][5] = {{213, 85, 149, 128, 0}, {255, 170, -1, -1, -1}};
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 5; ++c) {
      if (isShadow(r, c)) {
        EXPECT_TRUE(at.cellIsHatched(error, r, c));
      } else if (r == 1 && c == 2) {
        EXPECT_TRUE(at.cellIs(error, r, c, kNoTruth));
      } else if (k.map.stateAt(r, c) == CellState::Known) {
        EXPECT_TRUE(at.cellIs(error, r, c, diverging.at<cv::Vec3b>(0, error_level[r][c])));
      } else {
        EXPECT_TRUE(at.cellIs(error, r, c, kUnknown));
      }
    }
  EXPECT_EQ(diverging.at<cv::Vec3b>(0, 0), cv::Vec3b(192, 76, 59));  // (0, 4), 1 m below: blue
  EXPECT_EQ(diverging.at<cv::Vec3b>(0, 255), cv::Vec3b(38, 4, 180));  // (1, 0), 0.75 m above: red
  test::expectColourScale(error, diverging, 88, bar_y, bar_w);
  {
    const auto xs = test::legendSwatchX({"unknown", "range shadow", "known, no truth"});
    test::expectSwatch(error, xs[0], framed_rows + 4, kUnknown, false, "error: unknown");
    test::expectSwatch(error, xs[1], framed_rows + 4, test::kShadow, true, "error: shadow");
    test::expectSwatch(error, xs[2], framed_rows + 4, kNoTruth, false, "error: no truth");
  }

  // State view: known green, unseen dark grey, shadow hatched; no colour scale (the picture sits
  // on a canvas 4 px taller than it and its head); the legend gives each state's share of the
  // 20 cells: 9 unseen, 8 known, 3 shadow.
  const cv::Mat state = readPicture(out.dir / "case_state_view.png");
  ASSERT_EQ(state.size(), cv::Size(616, 480 + 28 + 4 + 26));
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 5; ++c) {
      const CellState s = k.map.stateAt(r, c);
      if (s == CellState::Shadow) {
        EXPECT_TRUE(at.cellIsHatched(state, r, c));
      } else {
        EXPECT_TRUE(at.cellIs(state, r, c, s == CellState::Known ? kKnown : kUnseen));
      }
    }
  {
    const auto xs = test::legendSwatchX({"unseen 45.0%", "known 40.0%", "range shadow 15.0%"});
    test::expectSwatch(state, xs[0], 512 + 4, kUnseen, false, "state: unseen");
    test::expectSwatch(state, xs[1], 512 + 4, kKnown, false, "state: known");
    test::expectSwatch(state, xs[2], 512 + 4, test::kShadow, true, "state: shadow");
  }
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
  // What the pictures show, cell by cell (110 × 100 cells at 6 px). The error scale ends at the
  // 99th percentile s of |map − truth| over the known cells (rank ⌊0.99·(n − 1)⌋); each known cell
  // is the diverging ramp at 127.5 + 127.5·e/s rounded and clamped.
  const CellLayout at(grid);
  ASSERT_EQ(at.k, 6);
  std::vector<double> abs_err;
  for (int r = 0; r < grid.rows; ++r)
    for (int c = 0; c < grid.cols; ++c)
      if (map.stateAt(r, c) == CellState::Known)
        abs_err.push_back(std::abs(double(map.elevation()(r, c)) - double(truth(r, c))));
  ASSERT_GT(abs_err.size(), 2000u);
  std::sort(abs_err.begin(), abs_err.end());
  const double scale = std::max(1e-3, abs_err[std::size_t(0.99 * double(abs_err.size() - 1))]);
  const cv::Mat error = readPicture(out.dir / "synthetic_error.png");
  const cv::Mat cartesian = readPicture(out.dir / "synthetic_cartesian_error.png");
  const cv::Mat state = readPicture(out.dir / "synthetic_state_view.png");
  const cv::Mat diverging = divergingRamp();
  long red = 0, blue = 0;
  for (int r = 0; r < grid.rows; ++r)
    for (int c = 0; c < grid.cols; ++c) {
      const CellState s = map.stateAt(r, c);
      if (s == CellState::Shadow) {
        ASSERT_TRUE(at.cellIsHatched(error, r, c));
        ASSERT_TRUE(at.cellIsHatched(state, r, c));
        continue;
      }
      ASSERT_TRUE(at.cellIs(state, r, c, s == CellState::Known ? kKnown : kUnseen));
      if (s != CellState::Known) {
        ASSERT_TRUE(at.cellIs(error, r, c, kUnknown));
        continue;
      }
      const double e = double(map.elevation()(r, c)) - double(truth(r, c));
      const long level = std::clamp(std::lround(127.5 + 127.5 * e / scale), 0L, 255L);
      ASSERT_TRUE(at.cellIs(error, r, c, diverging.at<cv::Vec3b>(0, int(level))));
      red += level == 255, blue += level == 0;
    }
  // About 1 % of the cells lie beyond the scale's ends, at either end.
  EXPECT_GT(red + blue, 0);
  // The Cartesian error picture of the same map is the same picture below its title.
  ASSERT_EQ(cartesian.size(), error.size());
  EXPECT_EQ(cv::norm(cartesian.rowRange(28, cartesian.rows), error.rowRange(28, error.rows), cv::NORM_INF), 0.0);
}

}  // namespace
}  // namespace ambler::eval
