// The pictures of eval/pictures/figures.hpp against what they are meant to show: the colour of a cell or a
// pixel is the colour map's colour for its value (shaded as documented), no-data is its documented
// colour, every cell lands where the layout puts it, and the colour scale under the picture is the
// ramp. AMBLER_TEST_PICTURES=DIR keeps the pictures in DIR to look at.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <numbers>

#include "eval/pictures/figures.hpp"
#include "eval/scenario/io.hpp"
#include "perception/sensor_geometry.hpp"
#include "perception/synthetic.hpp"
#include "eval/picture_checks.hpp"

namespace ambler::eval {
namespace {

using test::FrameLayout;
using test::maxChannelDiff;

constexpr float kNaNf = std::numeric_limits<float>::quiet_NaN();
constexpr double kDeg = std::numbers::pi / 180.0;

void keep(const cv::Mat& image, const std::string& name) {
  if (const char* dir = std::getenv("AMBLER_TEST_PICTURES")) writePng(std::filesystem::path(dir) / name, image);
}

cv::Vec3d scaled(const cv::Vec3b& c, double k) { return cv::Vec3d(c[0] * k, c[1] * k, c[2] * k); }

TEST(ColourRamp, IsTheOpenCvColourMapOfEveryLevel) {
  for (int map : {cv::COLORMAP_VIRIDIS, cv::COLORMAP_INFERNO, cv::COLORMAP_TURBO}) {
    const cv::Mat ramp = colourRamp(map);
    ASSERT_EQ(ramp.rows, 1);
    ASSERT_EQ(ramp.cols, 256);
    ASSERT_EQ(ramp.type(), CV_8UC3);
    for (int i = 0; i < 256; ++i) {
      cv::Mat one(1, 1, CV_8UC1, cv::Scalar(i)), colour;
      cv::applyColorMap(one, colour, map);
      ASSERT_EQ(ramp.at<cv::Vec3b>(0, i), colour.at<cv::Vec3b>(0, 0)) << "map " << map << " level " << i;
    }
  }
}

// framePicture: the picture copied unchanged, centred under a 28 px head; white around it; the
// colour scale (the given ramp stretched) 8 px under it, with its end labels beside it.
TEST(FramePicture, PictureCentredAboveTheColourScale) {
  cv::Mat pic(30, 50, CV_8UC3);
  for (int r = 0; r < pic.rows; ++r)
    for (int c = 0; c < pic.cols; ++c) pic.at<cv::Vec3b>(r, c) = cv::Vec3b(uchar(5 * c), uchar(7 * r), 200);
  cv::Mat ramp(1, 3, CV_8UC3);  // blue, green, red
  ramp.at<cv::Vec3b>(0, 0) = {255, 0, 0}, ramp.at<cv::Vec3b>(0, 1) = {0, 255, 0}, ramp.at<cv::Vec3b>(0, 2) = {0, 0, 255};
  for (int cols : {50, 700}) {  // narrower than the 360 px minimum, and wider
    cv::Mat p;
    cv::resize(pic, p, cv::Size(cols, 30), 0, 0, cv::INTER_NEAREST);
    const cv::Mat canvas = framePicture(p, "a title", ramp, -1.5, 2.25, "m");
    const FrameLayout f = FrameLayout::of(p.rows, p.cols);
    ASSERT_EQ(canvas.type(), CV_8UC3);
    ASSERT_EQ(canvas.cols, f.width);
    ASSERT_EQ(canvas.rows, f.canvasRows(p.rows));
    for (int r = 0; r < p.rows; ++r)
      for (int c = 0; c < p.cols; ++c)
        ASSERT_EQ(canvas.at<cv::Vec3b>(f.y0 + r, f.x0 + c), p.at<cv::Vec3b>(r, c)) << r << "," << c;
    // White beside the picture and in the gap between it and the scale.
    for (int r = 0; r < p.rows; ++r) {
      if (f.x0 > 0) {
        EXPECT_EQ(canvas.at<cv::Vec3b>(f.y0 + r, f.x0 - 1), cv::Vec3b(255, 255, 255));
      }
      if (f.x0 + p.cols < canvas.cols) {
        EXPECT_EQ(canvas.at<cv::Vec3b>(f.y0 + r, f.x0 + p.cols), cv::Vec3b(255, 255, 255));
      }
    }
    for (int x = 0; x < canvas.cols; ++x) EXPECT_EQ(canvas.at<cv::Vec3b>(f.y0 + p.rows + 3, x), cv::Vec3b(255, 255, 255));
    test::expectColourScale(canvas, ramp, f.bar_x, f.bar_y, f.bar_w);
    // The labels: text left of the scale (lo) and right of it (hi), and the title in the head.
    EXPECT_TRUE(test::hasDarkPixel(canvas, cv::Rect(8, f.bar_y, 78, 14)));
    EXPECT_TRUE(test::hasDarkPixel(canvas, cv::Rect(f.bar_x + f.bar_w + 2, f.bar_y, canvas.cols - f.bar_x - f.bar_w - 2, 14)));
    EXPECT_TRUE(test::hasDarkPixel(canvas, cv::Rect(8, 4, 60, 20)));
    keep(canvas, "frame_" + std::to_string(cols) + ".png");
  }
}

// A tilted plane z = 1 + gx·x + gy·y on a north-up raster (x = c·cell, y = −r·cell), one cell NaN.
struct PlaneRaster {
  static constexpr double gx = 0.3, gy = -0.2, cell = 0.2;
  perception::Raster<float> z{30, 40};
  float lo = 0, hi = 0;
  PlaneRaster() {
    lo = std::numeric_limits<float>::max(), hi = std::numeric_limits<float>::lowest();
    for (int r = 0; r < z.rows(); ++r)
      for (int c = 0; c < z.cols(); ++c) {
        z(r, c) = float(1.0 + gx * c * cell - gy * r * cell);
        lo = std::min(lo, z(r, c)), hi = std::max(hi, z(r, c));
      }
    z(10, 15) = kNaNf;  // not an extreme: lo and hi stay
  }
  // The viridis level of a value (reliefImage's mapping: 255·(z − lo)/span rounded).
  int level(int r, int c) const {
    const double span = std::max(1e-9, double(hi - lo));
    return int(std::lround(255.0 * (z(r, c) - lo) / span));
  }
  bool nearNaN(int r, int c) const { return std::abs(r - 10) + std::abs(c - 15) <= 1; }
};

// The hill shade of a plane, from the sun's direction: azimuth 315° (north-west), 45° up, so
// L = (−½, ½, √½) in (east, north, up); the plane's normal is (−gx, −gy, 1)/√(1 + gx² + gy²).
double planeShade(double gx, double gy) {
  return std::max(0.0, (-0.5 * -gx + 0.5 * -gy + std::sqrt(0.5)) / std::sqrt(1 + gx * gx + gy * gy));
}

// reliefImage: each cell the viridis colour of its elevation times 0.3 + 0.7·shade (each channel
// truncated to 8 bits: the test's shade, from the normal rather than the code's slope and aspect,
// may differ in the last bits and flip a truncation, so ±1); NaN cells dark grey (40, 40, 40).
TEST(ReliefImage, ViridisOfTheElevationShadedByTheSun) {
  const PlaneRaster p;
  const Relief relief = reliefImage(p.z, p.cell);
  EXPECT_EQ(relief.lo, p.lo);
  EXPECT_EQ(relief.hi, p.hi);
  ASSERT_EQ(relief.image.rows, 30);
  ASSERT_EQ(relief.image.cols, 40);
  const cv::Mat viridis = colourRamp(cv::COLORMAP_VIRIDIS);
  const double k = 0.3 + 0.7 * planeShade(p.gx, p.gy);
  int checked = 0;
  for (int r = 1; r < 29; ++r)
    for (int c = 1; c < 39; ++c) {
      if (p.nearNaN(r, c)) continue;
      const cv::Vec3d expected = scaled(viridis.at<cv::Vec3b>(0, p.level(r, c)), k);
      const cv::Vec3b got = relief.image.at<cv::Vec3b>(r, c);
      for (int ch = 0; ch < 3; ++ch)
        ASSERT_LE(std::abs(double(got[ch]) - std::floor(expected[ch])), 1.0) << r << "," << c << " channel " << ch;
      ++checked;
    }
  EXPECT_GT(checked, 1000);
  EXPECT_EQ(relief.image.at<cv::Vec3b>(10, 15), cv::Vec3b(40, 40, 40));
  // z = 1 + 0.06·c + 0.04·r: the north-west corner is the lowest (the ramp's first colour), the
  // south-east one the highest (its last).
  EXPECT_EQ(p.level(0, 0), 0);
  EXPECT_EQ(p.level(29, 39), 255);
}

// shadedRelief: reliefImage's picture enlarged by an integer factor (900/40 → capped at 4) with
// nearest-neighbour, framed with the viridis scale.
TEST(ShadedRelief, EachCellIsABlockOfItsReliefColourAboveTheViridisScale) {
  const PlaneRaster p;
  const cv::Mat img = shadedRelief(p.z, p.cell, "plane");
  const cv::Mat relief = reliefImage(p.z, p.cell).image;
  const int k = 4;
  const FrameLayout f = FrameLayout::of(30 * k, 40 * k);
  ASSERT_EQ(img.cols, f.width);
  ASSERT_EQ(img.rows, f.canvasRows(30 * k));
  for (int r = 0; r < 30; ++r)
    for (int c = 0; c < 40; ++c)
      for (int dy = 0; dy < k; ++dy)
        for (int dx = 0; dx < k; ++dx)
          ASSERT_EQ(img.at<cv::Vec3b>(f.y0 + k * r + dy, f.x0 + k * c + dx), relief.at<cv::Vec3b>(r, c))
              << "cell " << r << "," << c;
  EXPECT_EQ(img.at<cv::Vec3b>(f.y0 + k * 10 + 1, f.x0 + k * 15 + 2), cv::Vec3b(40, 40, 40));  // the NaN cell
  test::expectColourScale(img, colourRamp(cv::COLORMAP_VIRIDIS), f.bar_x, f.bar_y, f.bar_w);
  keep(img, "shaded_relief.png");
}

// rangePicture on a synthetic plane: a returned pixel is the turbo colour of its range
// (255·(ρ − lo)/span rounded, lo and hi the extreme returns) times 0.45 + 0.55·|n·light| with n
// the plane's normal and light (−1, 1, 2)/√6, when its four neighbours returned (±1 for the
// truncation, as above); without them it is unshaded; no return is black. The 64 × 256 image
// over 30° × 80° is enlarged 4× across and 4·(30/64)/(80/256) = 6× down.
TEST(RangePicture, TurboOfTheRangeShadedByTheSurfaceNoReturnBlack) {
  const test::Plane plane{0.05, 0.1, 0.0};
  auto img = test::planeImage(plane, perception::sensorPose({0, -6, 3}, {0, -30 * kDeg, 0}));
  for (int r = 20; r < 23; ++r)
    for (int c = 100; c < 106; ++c) img.range(r, c) = kNaNf;  // a hole
  float lo = std::numeric_limits<float>::max(), hi = 0;
  int nan = 0;
  for (int r = 0; r < img.rows(); ++r)
    for (int c = 0; c < img.cols(); ++c)
      if (img.valid(r, c)) lo = std::min(lo, img.range(r, c)), hi = std::max(hi, img.range(r, c));
      else ++nan;
  ASSERT_EQ(nan, 18);  // every ray meets the plane within 40 m: only the hole is missing
  const cv::Mat pic = rangePicture(img, 40.0, "plane");
  const int kx = 4, ky = 6;
  const FrameLayout f = FrameLayout::of(64 * ky, 256 * kx);
  ASSERT_EQ(pic.cols, f.width);
  ASSERT_EQ(pic.rows, f.canvasRows(64 * ky));
  const cv::Mat turbo = colourRamp(cv::COLORMAP_TURBO);
  const Eigen::Vector3d light = Eigen::Vector3d(-1, 1, 2).normalized();
  const double shade = 0.45 + 0.55 * std::abs(plane.normal().dot(light));
  const double span = std::max(1e-6, double(hi - lo));
  int shaded = 0, unshaded = 0, black = 0;
  for (int r = 0; r < img.rows(); ++r)
    for (int c = 0; c < img.cols(); ++c) {
      const cv::Vec3b got = pic.at<cv::Vec3b>(f.y0 + ky * r + ky / 2, f.x0 + kx * c + kx / 2);
      if (!img.valid(r, c)) {
        ASSERT_EQ(got, cv::Vec3b(0, 0, 0)) << r << "," << c;
        ++black;
        continue;
      }
      const cv::Vec3b base = turbo.at<cv::Vec3b>(0, int(std::lround(255.0 * (img.range(r, c) - lo) / span)));
      const int r0 = std::max(r - 1, 0), r1 = std::min(r + 1, img.rows() - 1);
      const int c0 = std::max(c - 1, 0), c1 = std::min(c + 1, img.cols() - 1);
      if (img.valid(r0, c) && img.valid(r1, c) && img.valid(r, c0) && img.valid(r, c1)) {
        const cv::Vec3d expected = scaled(base, shade);
        for (int ch = 0; ch < 3; ++ch)
          ASSERT_LE(std::abs(double(got[ch]) - std::floor(expected[ch])), 1.0) << r << "," << c;
        ++shaded;
      } else {
        ASSERT_EQ(got, base) << r << "," << c;
        ++unshaded;
      }
    }
  EXPECT_GT(shaded, 10000);
  EXPECT_EQ(unshaded, 2 * 6 + 2 * 3);  // the hole's rim: a neighbour in the hole
  EXPECT_EQ(black, nan);
  test::expectColourScale(pic, turbo, f.bar_x, f.bar_y, f.bar_w);
  keep(pic, "range_picture.png");
}

}  // namespace
}  // namespace ambler::eval
