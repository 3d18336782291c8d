// The matching pictures of eval/pictures/match_figures.hpp against what they are meant to show: a feature
// colours the pixels where its position, extent and length put it, in its type's colour; the
// difference of two maps is the ramp's colour of each cell's difference on the caller's span (0 its
// white middle), grey where a cell is not known in both, and before and after share one scale; the
// convergence plot has one curve per trace; the writers leave whole files and nothing else.
// AMBLER_TEST_PICTURES=DIR keeps the pictures in DIR to look at.
#include <gtest/gtest.h>
#include <unistd.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <set>

#include "eval/pictures/figures.hpp"
#include "eval/scenario/io.hpp"
#include "eval/pictures/match_figures.hpp"
#include "eval/pictures/plot.hpp"
#include "eval/picture_checks.hpp"

namespace ambler::eval {
namespace {

namespace fs = std::filesystem;
using perception::ElevationMap;
using perception::Feature;
using perception::FeatureType;
using test::FrameLayout;

void keep(const cv::Mat& image, const std::string& name) {
  if (const char* dir = std::getenv("AMBLER_TEST_PICTURES")) writePng(fs::path(dir) / name, image);
}

cv::Vec3b bgr(const cv::Scalar& s) { return cv::Vec3b(uchar(s[0]), uchar(s[1]), uchar(s[2])); }

// A 20 × 30 map of 10 cm cells over x ∈ [−1, 2], y ∈ [0, 2] of its frame: a plane rising 0.1 m/m
// to the east, known except a 2 × 3 block of unseen cells at rows 15–16, columns 2–4.
constexpr int kRows = 20, kCols = 30;
ElevationMap planeMap(const Eigen::Isometry3d& T_WM = Eigen::Isometry3d::Identity()) {
  ElevationMap m(perception::MapGrid::covering(-1.0, 2.0, 0.0, 2.0, 0.1, T_WM));
  for (int r = 0; r < kRows; ++r)
    for (int c = 0; c < kCols; ++c)
      if (!(r >= 15 && r <= 16 && c >= 2 && c <= 4)) m.setKnown(r, c, float(0.1 * m.grid().center(r, c).x()), 0.01f);
  return m;
}

// Where the pictures put a map of kRows × kCols: cells of k px (cellEnlargement: 600 / 30 = 20),
// the enlarged map at (x0, 28) of framePicture's canvas; (x, y) of the map frame is at pixel
// k·(x − x_min)/cell, k·(y_max − y)/cell of the enlarged map.
struct MapLayout {
  int k = cellEnlargement(kRows, kCols);
  FrameLayout f = FrameLayout::of(kRows * k, kCols * k);
  double x_min = -1.0, y_max = 2.0, cell = 0.1;
  cv::Vec3b at(const cv::Mat& canvas, double x, double y) const {
    return canvas.at<cv::Vec3b>(f.y0 + int(std::floor(k * (y_max - y) / cell)),
                                f.x0 + int(std::floor(k * (x - x_min) / cell)));
  }
  // Whether a pixel within `d` px of (x, y) has `colour` (a ring of thickness 2 drawn by a polygon
  // passes within a pixel of its radius).
  bool near(const cv::Mat& canvas, double x, double y, const cv::Vec3b& colour, int d = 1) const {
    const int py = f.y0 + int(std::floor(k * (y_max - y) / cell)), px = f.x0 + int(std::floor(k * (x - x_min) / cell));
    for (int dy = -d; dy <= d; ++dy)
      for (int dx = -d; dx <= d; ++dx)
        if (canvas.at<cv::Vec3b>(py + dy, px + dx) == colour) return true;
    return false;
  }
};

Feature feature(FeatureType type, double x, double y, double extent,
                Eigen::Vector3d direction = Eigen::Vector3d::Zero(), double length = 0) {
  Feature f;
  f.type = type;
  f.position = {x, y, 0.1 * x};
  f.extent_m = extent;
  f.direction = direction;
  f.length_m = length;
  return f;
}

// One of each type, well apart: a point of extent 0.3 m at (−0.45, 1.45), a line of 0.8 m along
// x through (1.05, 0.75), a region of extent 0.25 m at (1.25, 1.45).
std::vector<Feature> threeFeatures() {
  return {feature(FeatureType::Point, -0.45, 1.45, 0.3),
          feature(FeatureType::Line, 1.05, 0.75, 0.4, Eigen::Vector3d(1, 0, 0), 0.8),
          feature(FeatureType::Region, 1.25, 1.45, 0.25)};
}

TEST(FeaturesPicture, EachFeatureInItsTypesColourWhereItsPositionExtentAndLengthPutIt) {
  const ElevationMap map = planeMap();
  const cv::Mat pic = featuresPicture(map, threeFeatures(), "three features");
  const MapLayout L;
  ASSERT_EQ(pic.type(), CV_8UC3);
  ASSERT_EQ(pic.cols, L.f.width);
  ASSERT_EQ(pic.rows, L.f.canvasRows(kRows * L.k) + 26);  // framePicture, then the legend strip
  const cv::Vec3b point = bgr(featureColour(FeatureType::Point)), line = bgr(featureColour(FeatureType::Line)),
                  region = bgr(featureColour(FeatureType::Region));
  EXPECT_NE(point, line);
  EXPECT_NE(line, region);
  EXPECT_NE(point, region);
  // The point: its centre dot, and its ring 0.3 m away in each direction.
  EXPECT_EQ(L.at(pic, -0.45, 1.45), point);
  for (const auto& [dx, dy] : {std::pair{0.3, 0.0}, {-0.3, 0.0}, {0.0, 0.3}, {0.0, -0.3}})
    EXPECT_TRUE(L.near(pic, -0.45 + dx, 1.45 + dy, point)) << dx << "," << dy;
  EXPECT_NE(L.at(pic, -0.45 + 0.15, 1.45), point);  // inside the ring: the relief
  // The line: along x from 0.65 to 1.45 at y = 0.75, nothing of it beyond its ends or beside it.
  for (double x : {0.7, 0.85, 1.05, 1.25, 1.4}) EXPECT_EQ(L.at(pic, x, 0.75), line) << x;
  EXPECT_NE(L.at(pic, 0.55, 0.75), line);
  EXPECT_NE(L.at(pic, 1.55, 0.75), line);
  EXPECT_NE(L.at(pic, 1.05, 0.85), line);
  // The region: centre dot, ring at 0.25 m, and between them the relief tinted 35 % towards white.
  EXPECT_EQ(L.at(pic, 1.25, 1.45), region);
  EXPECT_TRUE(L.near(pic, 1.5, 1.45, region));
  EXPECT_TRUE(L.near(pic, 1.25, 1.2, region));
  const Relief relief = reliefImage(map.elevation(), 0.1);
  const auto cellOf = [&](double x, double y) { return *map.grid().cellOf(x, y); };
  const Eigen::Vector2i inside = cellOf(1.39, 1.45);
  const cv::Vec3b base = relief.image.at<cv::Vec3b>(inside.x(), inside.y()), tinted = L.at(pic, 1.39, 1.45);
  for (int ch = 0; ch < 3; ++ch) EXPECT_NEAR(tinted[ch], 0.65 * base[ch] + 0.35 * region[ch], 1.0) << ch;
  // Far from every feature the relief is untouched; the unseen block is the relief's dark grey.
  const Eigen::Vector2i far = cellOf(0.3, 0.15);
  EXPECT_EQ(L.at(pic, 0.3, 0.15), relief.image.at<cv::Vec3b>(far.x(), far.y()));
  EXPECT_EQ(L.at(pic, -0.65, 0.45), cv::Vec3b(40, 40, 40));
  test::expectColourScale(pic, colourRamp(cv::COLORMAP_VIRIDIS), L.f.bar_x, L.f.bar_y, L.f.bar_w);
  keep(pic, "features.png");
}

// Features are in the map's own frame: the same map and features in a frame moved and turned in
// the world give the same picture, bit for bit.
TEST(FeaturesPicture, TheMapsFrameDoesNotMoveAnything) {
  const cv::Mat world = featuresPicture(planeMap(), threeFeatures(), "t");
  const cv::Mat moved = featuresPicture(planeMap(perception::mapFrame({3, -2, 1}, 0.7)), threeFeatures(), "t");
  ASSERT_EQ(world.size(), moved.size());
  EXPECT_EQ(cv::norm(world, moved, cv::NORM_INF), 0.0);
}

TEST(CorrespondencePicture, MapIsFeaturesMapJsFeaturesAndALineJoiningEachPair) {
  const ElevationMap map = planeMap();
  const std::vector<Feature> fi{feature(FeatureType::Point, -0.45, 1.45, 0.1), feature(FeatureType::Point, 1.55, 0.35, 0.1)};
  const std::vector<Feature> fj{feature(FeatureType::Point, 1.05, 1.45, 0.1),
                                feature(FeatureType::Line, 0.0, 0.45, 0.3, Eigen::Vector3d(0.6, 0.8, 0), 0.6)};
  const cv::Mat pic = correspondencePicture(map, fi, fj, {{0, 0}, {1, 1}}, "pairs");
  const MapLayout L;
  ASSERT_EQ(pic.cols, L.f.width);
  ASSERT_EQ(pic.rows, L.f.canvasRows(kRows * L.k) + 26);
  const cv::Vec3b ci = bgr(kFeaturesIColour), cj = bgr(kFeaturesJColour), pair = bgr(kCorrespondenceColour);
  EXPECT_EQ(L.at(pic, -0.45, 1.45), ci);
  EXPECT_EQ(L.at(pic, 1.55, 0.35), ci);
  EXPECT_EQ(L.at(pic, 1.05, 1.45), cj);  // a centre dot over the line ending there
  EXPECT_EQ(L.at(pic, 1.05 - 0.1, 1.45), pair);  // the line over map J's ring
  EXPECT_TRUE(L.near(pic, 1.05 + 0.1, 1.45, cj));  // map J's point: its ring
  EXPECT_EQ(L.at(pic, 0.0 + 0.2 * 0.6, 0.45 + 0.2 * 0.8), cj);  // map J's line, along (0.6, 0.8)
  EXPECT_EQ(L.at(pic, 0.3, 1.45), pair);   // between the first pair
  EXPECT_EQ(L.at(pic, 0.775, 0.40), pair);  // between the second
  EXPECT_NE(L.at(pic, 0.3, 1.15), pair);
  EXPECT_THROW(correspondencePicture(map, fi, fj, {{0, 2}}, "bad"), std::invalid_argument);
  EXPECT_THROW(correspondencePicture(map, fi, fj, {{-1, 0}}, "bad"), std::invalid_argument);
  keep(pic, "correspondences.png");
}

// The difference pictures' ramp: 255 levels, level 127 (white) for 0, a difference d at
// round(127 + 127·d/span) clamped to [0, 254].
cv::Vec3b differenceColour(double d, double span) {
  const long level = std::clamp(std::lround(127.0 + 127.0 * d / span), 0L, 254L);
  return coolWarmRamp(255).at<cv::Vec3b>(0, int(level));
}

TEST(DifferencePicture, IdenticalMapsAreTheZeroColourWhereKnownAndGreyElsewhere) {
  const ElevationMap a = planeMap();
  const cv::Mat pic = differencePicture(a, a, 0.05, "same");
  const MapLayout L;
  ASSERT_EQ(pic.cols, L.f.width);
  ASSERT_EQ(pic.rows, L.f.canvasRows(kRows * L.k) + 26);
  const cv::Vec3b zero = differenceColour(0, 0.05);
  ASSERT_EQ(zero, cv::Vec3b(247, 247, 247));
  for (int y = 0; y < kRows * L.k; ++y)
    for (int x = 0; x < kCols * L.k; ++x) {
      const bool known = a.stateAt(y / L.k, x / L.k) == perception::CellState::Known;
      ASSERT_EQ(pic.at<cv::Vec3b>(L.f.y0 + y, L.f.x0 + x), known ? zero : cv::Vec3b(150, 150, 150)) << x << "," << y;
    }
  test::expectColourScale(pic, coolWarmRamp(255), L.f.bar_x, L.f.bar_y, L.f.bar_w);
}

TEST(DifferencePicture, EachCellTheRampsColourOfItsDifferenceOnTheCallersSpan) {
  const ElevationMap b = planeMap();
  ElevationMap a = b;
  const double span = 0.04;
  a.elevation()(3, 3) += 0.02f;   // half the span: red half way
  a.elevation()(3, 4) -= 0.02f;   // blue half way
  a.elevation()(3, 5) += 0.10f;   // beyond the span: the red end
  a.setUnknown(3, 6, perception::CellState::Shadow);  // known in b only
  const cv::Mat pic = differencePicture(a, b, span, "d");
  const MapLayout L;
  const auto cell = [&](int r, int c) { return pic.at<cv::Vec3b>(L.f.y0 + L.k * r + L.k / 2, L.f.x0 + L.k * c + L.k / 2); };
  const auto diff = [&](int r, int c) { return double(a.elevation()(r, c)) - double(b.elevation()(r, c)); };
  EXPECT_EQ(cell(3, 3), differenceColour(diff(3, 3), span));
  EXPECT_EQ(cell(3, 4), differenceColour(diff(3, 4), span));
  EXPECT_EQ(cell(3, 5), coolWarmRamp(255).at<cv::Vec3b>(0, 254));
  EXPECT_EQ(cell(3, 6), cv::Vec3b(150, 150, 150));
  // Blue below, red above: the red channel leads where a > b.
  EXPECT_GT(cell(3, 3)[2], cell(3, 3)[0]);
  EXPECT_GT(cell(3, 4)[0], cell(3, 4)[2]);
  EXPECT_THROW(differencePicture(a, planeMap(perception::mapFrame({1, 0, 0}, 0)), span, "x"), std::invalid_argument);
  EXPECT_THROW(differencePicture(a, b, 0.0, "x"), std::invalid_argument);
}

// Before and after side by side (each panel under a 20 px label band, 16 px apart) over one colour
// scale: the same difference is the same colour in both panels.
TEST(BeforeAfterPicture, BothPanelsOnOneScale) {
  const ElevationMap ref = planeMap();
  ElevationMap before = ref, after = ref;
  for (int r = 0; r < kRows; ++r)
    for (int c = 0; c < kCols; ++c) before.elevation()(r, c) += 0.02f, after.elevation()(r, c) += 0.005f;
  after.elevation()(7, 8) += 0.015f;  // 0.02 like the whole of before
  const double span = 0.04;
  const cv::Mat pic = beforeAfterPicture(ref, before, after, span, "before/after", "after lm");
  const int k = cellEnlargement(kRows, kCols), w = kCols * k, h = kRows * k;
  const FrameLayout f = FrameLayout::of(20 + h, 2 * w + 16);
  ASSERT_EQ(pic.cols, f.width);
  ASSERT_EQ(pic.rows, f.canvasRows(20 + h) + 26);
  const auto cell = [&](int panel, int r, int c) {
    return pic.at<cv::Vec3b>(f.y0 + 20 + k * r + k / 2, f.x0 + panel * (w + 16) + k * c + k / 2);
  };
  const auto diff = [&](const ElevationMap& m, int r, int c) { return double(m.elevation()(r, c)) - double(ref.elevation()(r, c)); };
  EXPECT_EQ(cell(0, 7, 8), differenceColour(diff(before, 7, 8), span));
  EXPECT_EQ(cell(1, 0, 0), differenceColour(diff(after, 0, 0), span));
  EXPECT_NE(cell(1, 0, 0), cell(0, 0, 0));
  EXPECT_EQ(cell(1, 7, 8), differenceColour(diff(after, 7, 8), span));
  EXPECT_EQ(cell(1, 7, 8), cell(0, 7, 8));  // the same difference, the same colour
  EXPECT_EQ(cell(0, 15, 3), cv::Vec3b(150, 150, 150));
  EXPECT_EQ(cell(1, 15, 3), cv::Vec3b(150, 150, 150));
  for (int y = 0; y < h; ++y)  // the gap between the panels is white
    ASSERT_EQ(pic.at<cv::Vec3b>(f.y0 + 20 + y, f.x0 + w + 8), cv::Vec3b(255, 255, 255));
  EXPECT_TRUE(test::hasDarkPixel(pic, cv::Rect(f.x0, f.y0, 60, 20)));          // "before"
  EXPECT_TRUE(test::hasDarkPixel(pic, cv::Rect(f.x0 + w + 16, f.y0, 60, 20)));  // "after lm"
  test::expectColourScale(pic, coolWarmRamp(255), f.bar_x, f.bar_y, f.bar_w);
  EXPECT_THROW(beforeAfterPicture(ref, before, planeMap(perception::mapFrame({0, 1, 0}, 0)), span, "x"),
               std::invalid_argument);
  keep(pic, "before_after.png");
}

TEST(DifferenceSpan, NinetyNinthPercentileRoundedUpToOneTwoFive) {
  const ElevationMap ref = planeMap();
  const auto shifted = [&](float d) {
    ElevationMap m = ref;
    for (int r = 0; r < kRows; ++r)
      for (int c = 0; c < kCols; ++c) m.elevation()(r, c) -= d;
    return m;
  };
  EXPECT_DOUBLE_EQ(differenceSpan(shifted(0.013f), ref), 0.02);
  EXPECT_DOUBLE_EQ(differenceSpan(shifted(0.0049f), ref), 0.005);
  EXPECT_DOUBLE_EQ(differenceSpan(shifted(0.3f), ref), 0.5);
  EXPECT_DOUBLE_EQ(differenceSpan(shifted(0.7f), ref), 1.0);
  EXPECT_DOUBLE_EQ(differenceSpan(ref, ref), 0.001);
  // One cell far off among 594 known ones is above the 99th percentile.
  ElevationMap one = ref;
  one.elevation()(0, 0) += 5.0f;
  EXPECT_DOUBLE_EQ(differenceSpan(one, ref), 0.001);
}

// The number of pixels of exactly `colour` in `img`.
long count(const cv::Mat& img, const cv::Vec3b& colour) {
  long n = 0;
  for (int r = 0; r < img.rows; ++r)
    for (int c = 0; c < img.cols; ++c) n += img.at<cv::Vec3b>(r, c) == colour;
  return n;
}

TEST(ConvergencePlot, OneCurveInItsOwnColourPerTrace) {
  std::vector<ConvergenceTrace> traces;
  for (int t = 0; t < 3; ++t) {
    ConvergenceTrace tr{"method " + std::to_string(t), {}};
    for (int k = 0; k < 10 + 5 * t; ++k) tr.values.push_back(0.3 * std::pow(0.5 + 0.1 * t, k) + 1e-3);
    traces.push_back(tr);
  }
  traces[1].values.push_back(0.0);  // not drawable on a log axis: left out
  const cv::Mat plot = convergencePlot(traces, "three methods");
  EXPECT_EQ(plot.size(), cv::Size(900, 560));
  for (int t = 0; t < 3; ++t) EXPECT_GT(count(plot, bgr(plotColour(t))), 150) << "trace " << t;
  EXPECT_EQ(count(plot, bgr(plotColour(3))), 0);
  const cv::Mat two = convergencePlot({traces[0], traces[2]}, "two");
  EXPECT_GT(count(two, bgr(plotColour(1))), 150);  // the second trace takes the second colour
  EXPECT_EQ(count(two, bgr(plotColour(2))), 0);
  keep(plot, "convergence.png");
}

TEST(MatchPictureFiles, WholeFilesUnderTheirNamesAndNothingElse) {
  const fs::path dir = fs::temp_directory_path() / ("ambler-match-figures-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const ElevationMap ref = planeMap();
  ElevationMap before = ref, after = ref;
  before.elevation()(5, 5) += 0.05f;
  writeFeaturesPicture(dir, 3, ref, threeFeatures(), "t");
  writePairPictures(dir, 0, 1, ref, before,
                    {{"features+iconic", &after, {0.1, 0.01, 0.001}}, {"iconic", &after, {}}, {"iconic_lm", nullptr, {0.2, 0.02}}},
                    "t");
  std::set<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.insert(e.path().filename().string());
  EXPECT_EQ(names, (std::set<std::string>{"view_3_features.png", "pair_0_1_difference_features_iconic.png",
                                          "pair_0_1_convergence.png"}));
  const cv::Mat features = cv::imread((dir / "view_3_features.png").string(), cv::IMREAD_COLOR);
  const cv::Mat expected = featuresPicture(ref, threeFeatures(), "t");
  ASSERT_EQ(features.size(), expected.size());
  EXPECT_EQ(cv::norm(features, expected, cv::NORM_INF), 0.0);
  const cv::Mat difference = cv::imread((dir / "pair_0_1_difference_features_iconic.png").string(), cv::IMREAD_COLOR);
  EXPECT_EQ(difference.size(),
            beforeAfterPicture(ref, before, after, differenceSpan(before, ref), "t", "after features+iconic").size());
  EXPECT_EQ(methodFileName("features+iconic"), "features_iconic");
  EXPECT_THROW(writePairPictures(dir, 0, 1, ref, planeMap(perception::mapFrame({0, 1, 0}, 0)), {}, "t"),
               std::invalid_argument);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace ambler::eval
