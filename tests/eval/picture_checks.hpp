#pragma once
// What the pictures of eval/pictures/figures.hpp and eval/pictures/map_outputs.hpp are made of, written out from
// their layout (framePicture: 8 px padding, a 28 px head, the picture centred, a 14 px colour
// scale 8 px under it from x = 88, 160 px narrower than the canvas less padding; the map
// pictures' legend strip of 14 px swatches), so tests can ask what a pixel shows.
#include <gtest/gtest.h>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace ambler::test {

// Where framePicture put things for a picture of pic_rows × pic_cols.
struct FrameLayout {
  int width, x0, y0, bar_x, bar_y, bar_w;
  static FrameLayout of(int pic_rows, int pic_cols) {
    FrameLayout f;
    f.width = std::max(pic_cols + 16, 360);
    f.x0 = (f.width - pic_cols) / 2;
    f.y0 = 28;
    f.bar_x = 88;
    f.bar_y = 28 + pic_rows + 8;
    f.bar_w = f.width - 16 - 160;
    return f;
  }
  int canvasRows(int pic_rows) const { return pic_rows + 28 + 46; }
};

inline int maxChannelDiff(const cv::Vec3b& a, const cv::Vec3d& b) {
  int d = 0;
  for (int k = 0; k < 3; ++k) d = std::max(d, int(std::ceil(std::abs(double(a[k]) - b[k]))));
  return d;
}

// The colour scale: `ramp` (1 × N BGR) stretched over bar_w × 14 px by linear interpolation with
// OpenCV's pixel-centre mapping (source x = (x + ½)·N/bar_w − ½, clamped to the ends). OpenCV
// interpolates 8-bit images with 11-bit fixed-point weights in each direction, so a channel of any
// of the 14 rows may be one off the exact blend.
inline void expectColourScale(const cv::Mat& canvas, const cv::Mat& ramp, int bar_x, int bar_y, int bar_w) {
  ASSERT_LE(bar_x + bar_w, canvas.cols);
  ASSERT_LE(bar_y + 14, canvas.rows);
  const int n = ramp.cols;
  int worst = 0;
  for (int x = 0; x < bar_w; ++x) {
    const double s = std::clamp((x + 0.5) * double(n) / bar_w - 0.5, 0.0, double(n - 1));
    const int i0 = int(std::floor(s)), i1 = std::min(i0 + 1, n - 1);
    const double w = s - i0;
    const cv::Vec3b a = ramp.at<cv::Vec3b>(0, i0), b = ramp.at<cv::Vec3b>(0, i1);
    cv::Vec3d expected;
    for (int k = 0; k < 3; ++k) expected[k] = (1 - w) * a[k] + w * b[k];
    for (int y = 0; y < 14; ++y) worst = std::max(worst, maxChannelDiff(canvas.at<cv::Vec3b>(bar_y + y, bar_x + x), expected));
  }
  EXPECT_LE(worst, 1) << "the colour scale is not the ramp";
  // The ends of the scale are the ramp's ends (within the same rounding).
  EXPECT_LE(maxChannelDiff(canvas.at<cv::Vec3b>(bar_y, bar_x), cv::Vec3d(ramp.at<cv::Vec3b>(0, 0))), 1);
  EXPECT_LE(maxChannelDiff(canvas.at<cv::Vec3b>(bar_y, bar_x + bar_w - 1), cv::Vec3d(ramp.at<cv::Vec3b>(0, n - 1))), 1);
}

// Whether any pixel of `r` in `canvas` is dark (text drawn there).
inline bool hasDarkPixel(const cv::Mat& canvas, const cv::Rect& r) {
  for (int y = r.y; y < r.y + r.height; ++y)
    for (int x = r.x; x < r.x + r.width; ++x) {
      const cv::Vec3b p = canvas.at<cv::Vec3b>(y, x);
      if (p[0] < 128 && p[1] < 128 && p[2] < 128) return true;
    }
  return false;
}

// The map pictures' range-shadow hatching at (x, y) of the enlarged picture or of a swatch.
inline bool stripe(int x, int y) { return (x + y) / 3 % 3 == 0; }
const cv::Vec3b kShadow(110, 25, 100), kStripe(255, 70, 255);
inline cv::Vec3b hatch(int x, int y) { return stripe(x, y) ? kStripe : kShadow; }

// The x of each legend swatch of withLegend (entries left to right: 14 px box, 20 px to the label,
// the label at FONT_HERSHEY_SIMPLEX 0.4, 18 px gap).
inline std::vector<int> legendSwatchX(const std::vector<std::string>& labels) {
  std::vector<int> xs;
  int x = 8;
  for (const auto& l : labels) {
    xs.push_back(x);
    int baseline = 0;
    x += 20 + cv::getTextSize(l, cv::FONT_HERSHEY_SIMPLEX, 0.4, 1, &baseline).width + 18;
  }
  return xs;
}

// A legend swatch at (x, y): a 1 px black border around `colour` (hatched: the stripes over it).
inline void expectSwatch(const cv::Mat& canvas, int x, int y, const cv::Vec3b& colour, bool hatched,
                         const std::string& what) {
  EXPECT_EQ(canvas.at<cv::Vec3b>(y, x), cv::Vec3b(0, 0, 0)) << what << ": border";
  EXPECT_EQ(canvas.at<cv::Vec3b>(y + 13, x + 13), cv::Vec3b(0, 0, 0)) << what << ": border";
  for (int j = 1; j < 13; ++j)
    for (int i = 1; i < 13; ++i) {
      const cv::Vec3b expected = hatched && stripe(i, j) ? kStripe : colour;
      ASSERT_EQ(canvas.at<cv::Vec3b>(y + j, x + i), expected) << what << " at " << i << "," << j;
    }
}

}  // namespace ambler::test
