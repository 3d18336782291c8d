// The plot renderer: 1-2-5 ticks and decades worked out by hand, images of the requested size,
// NaN breaking a line. AMBLER_TEST_PICTURES=DIR keeps the plots in DIR to look at.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <limits>

#include "eval/io.hpp"
#include "eval/plot.hpp"

namespace ambler::eval {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

void keep(const cv::Mat& image, const std::string& name) {
  if (const char* dir = std::getenv("AMBLER_TEST_PICTURES")) writePng(std::filesystem::path(dir) / name, image);
}

TEST(NiceTicks, WorkedExamples) {
  EXPECT_EQ(niceTicks(0.013, 0.87), (std::vector<double>{0, 0.2, 0.4, 0.6, 0.8, 1.0}));  // step 0.857/5 → 0.2
  EXPECT_EQ(niceTicks(-3.7, 12.2), (std::vector<double>{-5, 0, 5, 10, 15}));            // 3.18 → 5
  EXPECT_EQ(niceTicks(0, 100), (std::vector<double>{0, 20, 40, 60, 80, 100}));
  EXPECT_EQ(niceTicks(0.6, 1.0, 4), (std::vector<double>{0.6, 0.7, 0.8, 0.9, 1.0}));     // 0.1 steps, exact ends
  EXPECT_EQ(niceTicks(1013, 1027, 7), (std::vector<double>{1012, 1014, 1016, 1018, 1020, 1022, 1024, 1026, 1028}));
  EXPECT_EQ(niceTicks(2.0, 2.0), (std::vector<double>{1.0, 1.5, 2.0, 2.5, 3.0}));  // widened to [1, 3]: 0.4 → 0.5
}

TEST(NiceTicks, OneTwoFiveStepsCoveringTheRange) {
  for (double lo : {-1234.5, -0.7, 0.0, 3e-5, 0.42, 17.0})
    for (double span : {1e-4, 0.03, 0.9, 2.5, 77.0, 6e5}) {
      const double hi = lo + span;
      const auto t = niceTicks(lo, hi);
      ASSERT_GE(t.size(), 3u);
      EXPECT_LE(t.size(), 12u);
      EXPECT_LE(t.front(), lo);
      EXPECT_GE(t.back(), hi);
      EXPECT_GT(t[1], lo);  // no tick wasted before the range
      EXPECT_LT(t[t.size() - 2], hi);
      const double step = t[1] - t[0];
      const double mantissa = step / std::pow(10.0, std::floor(std::log10(step) + 1e-9));
      EXPECT_TRUE(std::abs(mantissa - 1) < 1e-6 || std::abs(mantissa - 2) < 1e-6 || std::abs(mantissa - 5) < 1e-6)
          << "step " << step;
      // Equal steps up to the rounding of ticks of size |t| (a few ulps each).
      const double ulps = 4 * std::numeric_limits<double>::epsilon() * std::max(std::abs(t.front()), std::abs(t.back()));
      for (std::size_t i = 1; i < t.size(); ++i) EXPECT_NEAR(t[i] - t[i - 1], step, 2 * ulps + 1e-12 * step);
    }
}

TEST(NiceTicks, RejectsBadRanges) {
  EXPECT_THROW(niceTicks(1, 0), std::invalid_argument);
  EXPECT_THROW(niceTicks(kNaN, 1), std::invalid_argument);
  EXPECT_THROW(logTicks(0, 1), std::invalid_argument);
  EXPECT_THROW(logTicks(-1, 1), std::invalid_argument);
}

TEST(LogTicks, Decades) {
  EXPECT_EQ(logTicks(0.003, 470), (std::vector<double>{1e-3, 1e-2, 1e-1, 1, 10, 100, 1000}));
  EXPECT_EQ(logTicks(2, 3), (std::vector<double>{1, 10}));
  EXPECT_EQ(logTicks(10, 100), (std::vector<double>{10, 100}));  // exact powers are their own ends
  EXPECT_EQ(logTicks(1e-9, 1e9), (std::vector<double>{1e-9, 1e-6, 1e-3, 1, 1e3, 1e6, 1e9}));  // every 3rd
}

PlotSpec sampleSpec(bool log) {
  PlotSpec spec{"map rms error vs sensor noise", "noise_k", "rms error (m)", log, log, {}};
  Series a{"locus", {}, {}, cv::Scalar(-1, -1, -1, -1), true};
  Series b{"cartesian", {}, {}, cv::Scalar(-1, -1, -1, -1), false};
  for (int i = 0; i <= 12; ++i) {
    const double x = 1e-5 * std::pow(2.0, i);
    a.x.push_back(x), a.y.push_back(0.004 + 30 * x);
    b.x.push_back(x), b.y.push_back(i == 6 ? kNaN : 0.01 + 80 * x);
  }
  spec.series = {a, b};
  return spec;
}

TEST(RenderPlot, LinearAndLogAxesAtTheRequestedSize) {
  const cv::Mat lin = renderPlot(sampleSpec(false));
  EXPECT_EQ(lin.rows, 560);
  EXPECT_EQ(lin.cols, 900);
  EXPECT_EQ(lin.type(), CV_8UC3);
  const cv::Mat log = renderPlot(sampleSpec(true), 700, 420);
  EXPECT_EQ(log.rows, 420);
  EXPECT_EQ(log.cols, 700);
  EXPECT_EQ(log.at<cv::Vec3b>(0, 0), cv::Vec3b(255, 255, 255));  // white background
  keep(lin, "plot_linear.png");
  keep(log, "plot_log.png");
}

TEST(RenderPlot, EmptyAndDegenerateInputsStillRender) {
  EXPECT_EQ(renderPlot(PlotSpec{}).size(), cv::Size(900, 560));
  PlotSpec one{"one point", "x", "y", false, true, {Series{"p", {3}, {3}, cv::Scalar(0, 0, 0), true}}};
  EXPECT_EQ(renderPlot(one, 400, 300).size(), cv::Size(400, 300));
  PlotSpec nan{"all NaN", "x", "y", true, false, {Series{"n", {kNaN, -1}, {1, 2}, cv::Scalar(0, 0, 0), true}}};
  EXPECT_NO_THROW(renderPlot(nan));
  PlotSpec ragged{"", "", "", false, false, {Series{"r", {1, 2}, {1}, cv::Scalar(0, 0, 0), false}}};
  EXPECT_THROW(renderPlot(ragged), std::invalid_argument);
  EXPECT_THROW(renderPlot(one, 100, 100), std::invalid_argument);
}

TEST(RenderPlot, NaNBreaksTheLine) {
  // A horizontal line (no legend entry) with a NaN in the middle: the columns holding its colour
  // form two runs, [x=0, x=1] and [x=3, x=4].
  const cv::Vec3b red(0, 0, 255);
  PlotSpec spec{"", "", "", false, false,
                {Series{"", {0, 1, 2, 3, 4}, {1, 1, kNaN, 1, 1}, cv::Scalar(red[0], red[1], red[2]), false}}};
  const cv::Mat img = renderPlot(spec, 600, 300);
  int runs = 0;
  bool in_run = false;
  for (int c = 0; c < img.cols; ++c) {
    bool hit = false;
    for (int r = 0; r < img.rows && !hit; ++r) hit = img.at<cv::Vec3b>(r, c) == red;
    runs += hit && !in_run;
    in_run = hit;
  }
  EXPECT_EQ(runs, 2);
}

}  // namespace
}  // namespace ambler::eval
