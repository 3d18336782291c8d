// The plot renderer: 1-2-5 ticks and decades worked out by hand; gnuplot's pictures checked
// pixel by pixel against the layout renderPlot asks for (markers where the axes put their data,
// the legend's swatch, a NaN breaking a line, a log axis), the same bytes every time and on
// threads, and the one-line refusals. AMBLER_TEST_PICTURES=DIR keeps the plots in DIR to look at.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <thread>
#include <unistd.h>
#include <vector>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "eval/scenario/io.hpp"
#include "eval/pictures/plot.hpp"

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

cv::Vec3b bgr(const cv::Scalar& s) { return cv::Vec3b(uchar(s[0]), uchar(s[1]), uchar(s[2])); }

// Within `tol` of `colour` in every channel: gnuplot antialiases, so a line's edge pixels are
// blends with the background, but its middle is the colour itself.
bool near(const cv::Vec3b& p, const cv::Vec3b& colour, int tol = 24) {
  for (int i = 0; i < 3; ++i)
    if (std::abs(int(p[i]) - int(colour[i])) > tol) return false;
  return true;
}

// Whether `img` has a horizontal run of at least `length` pixels near `colour`, within the rows
// [r0, r1) and columns [c0, c1).
bool hasHorizontalRun(const cv::Mat& img, const cv::Vec3b& colour, int length, cv::Rect where = {}) {
  if (where.area() == 0) where = cv::Rect(0, 0, img.cols, img.rows);
  for (int r = where.y; r < where.y + where.height; ++r) {
    int run = 0;
    for (int c = where.x; c < where.x + where.width; ++c) {
      run = near(img.at<cv::Vec3b>(r, c), colour) ? run + 1 : 0;
      if (run >= length) return true;
    }
  }
  return false;
}

long countNear(const cv::Mat& img, const cv::Vec3b& colour, cv::Rect where) {
  long n = 0;
  for (int r = where.y; r < where.y + where.height; ++r)
    for (int c = where.x; c < where.x + where.width; ++c) n += near(img.at<cv::Vec3b>(r, c), colour);
  return n;
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
  // Both series are labelled: each has a legend swatch, a line in the palette's colour of its index.
  for (const cv::Mat* img : {&lin, &log})
    for (int k : {0, 1}) EXPECT_TRUE(hasHorizontalRun(*img, bgr(plotColour(k)), 18)) << "series " << k;
  keep(lin, "plot_linear.png");
  keep(log, "plot_log.png");
}

TEST(RenderPlot, EmptyAndDegenerateInputsStillRender) {
  const cv::Mat empty = renderPlot(PlotSpec{});
  EXPECT_EQ(empty.size(), cv::Size(900, 560));
  // Nothing but the frame, grid and labels: black, greys and white, no colour anywhere.
  long coloured = 0;
  for (int r = 0; r < empty.rows; ++r)
    for (int c = 0; c < empty.cols; ++c) {
      const cv::Vec3b p = empty.at<cv::Vec3b>(r, c);
      coloured += p[0] != p[1] || p[1] != p[2];
    }
  EXPECT_EQ(coloured, 0);
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
  // Runs of consecutive image columns holding a red pixel.
  const auto redRuns = [&](const cv::Mat& img) {
    int runs = 0;
    bool in_run = false;
    for (int c = 0; c < img.cols; ++c) {
      bool hit = false;
      for (int r = 0; r < img.rows && !hit; ++r) hit = near(img.at<cv::Vec3b>(r, c), red);
      runs += hit && !in_run;
      in_run = hit;
    }
    return runs;
  };
  const cv::Mat img = renderPlot(spec, 600, 300);
  keep(img, "plot_nan.png");
  EXPECT_EQ(redRuns(img), 2);
  // Without the NaN the same line is one run.
  spec.series[0].y[2] = 1;
  EXPECT_EQ(redRuns(renderPlot(spec, 600, 300)), 1);
}

// Markers where the axes put their data. renderPlot puts the frame at plotMargins (no title or
// axis labels here) and runs each axis from its first to its last tick (niceTicks, or logTicks on
// a log axis, with max(2, area/130 px) intervals across and max(2, area/80 px) down): a value v is
// at pixel p0 + (v − t0)/(tn − t0)·(p1 − p0) (log10 of each on a log axis). A filled marker covers
// its centre and the pixels next to it in the series' colour. The labelled series has a legend
// swatch in the top-right corner (no point falls there); the unlabelled one none.
TEST(RenderPlot, MarkersSitAtTheirDataPoints) {
  const std::vector<double> ax{1.5, 2.5, 4.0, 6.5}, ay{0.2, 0.9, 0.5, 0.35};
  const std::vector<double> bx{3.0, 6.0}, by{0.6, 0.1};
  const cv::Vec3b green(0, 160, 0);
  for (bool log_x : {false, true}) {
    PlotSpec spec{"", "", "", log_x, false,
                  {Series{"series a", ax, ay, cv::Scalar(-1, -1, -1, -1), true, true},
                   Series{"", bx, by, cv::Scalar(green[0], green[1], green[2]), true, false}}};
    const int width = 700, height = 420;
    const cv::Mat img = renderPlot(spec, width, height);
    keep(img, log_x ? "plot_markers_log.png" : "plot_markers.png");
    const PlotMargins m = plotMargins(spec);
    const int left = m.left, right = width - 1 - m.right, top = m.top, bottom = height - 1 - m.bottom;
    // The frame: dark along its four sides.
    for (int r = top + 2; r < bottom - 2; r += 7) {
      EXPECT_TRUE(near(img.at<cv::Vec3b>(r, left), {0, 0, 0}, 100)) << "left frame at row " << r;
      EXPECT_TRUE(near(img.at<cv::Vec3b>(r, right), {0, 0, 0}, 100)) << "right frame at row " << r;
    }
    const auto xt = log_x ? logTicks(1.5, 6.5) : niceTicks(1.5, 6.5, std::max(2, (right - left) / 130));
    const auto yt = niceTicks(0.1, 0.9, std::max(2, (bottom - top) / 80));
    auto unit = [&](double v) { return log_x ? std::log10(v) : v; };
    auto px = [&](double v) {
      return int(std::lround(left + (unit(v) - unit(xt.front())) / (unit(xt.back()) - unit(xt.front())) * (right - left)));
    };
    auto py = [&](double v) { return int(std::lround(bottom + (v - yt.front()) / (yt.back() - yt.front()) * (top - bottom))); };
    auto expectMarker = [&](double x, double y, const cv::Vec3b& colour) {
      const int c = px(x), r = py(y);
      for (const auto& [dr, dc] : {std::pair{0, 0}, {1, 0}, {-1, 0}, {0, 1}, {0, -1}})
        EXPECT_TRUE(near(img.at<cv::Vec3b>(r + dr, c + dc), colour))
            << "marker (" << x << ", " << y << ") log_x " << log_x << " at pixel (" << c + dc << ", " << r + dr
            << "): " << img.at<cv::Vec3b>(r + dr, c + dc);
    };
    for (std::size_t i = 0; i < ax.size(); ++i) expectMarker(ax[i], ay[i], bgr(plotColour(0)));
    for (std::size_t i = 0; i < bx.size(); ++i) expectMarker(bx[i], by[i], green);
    // The one legend entry: a swatch line in the top-right quarter of the plot area, and none in
    // the top-left (where the points would be hidden; a point is there).
    const cv::Rect top_right((left + right) / 2, top, (right - left) / 2, 60), top_left(left, top, (right - left) / 2, 60);
    EXPECT_TRUE(hasHorizontalRun(img, bgr(plotColour(0)), 18, top_right));
    EXPECT_FALSE(hasHorizontalRun(img, bgr(plotColour(0)), 18, top_left));
    EXPECT_FALSE(hasHorizontalRun(img, green, 10));  // markers only, and no legend entry
  }
}

// The legend moves out of the way: points filling the top strip put it in a bottom corner (its
// box's grey border and the series' line sample there), and none in the top strip.
TEST(RenderPlot, LegendAvoidsThePoints) {
  Series dots{"", {}, {}, cv::Scalar(-1, -1, -1, -1), true, false};
  for (int i = 0; i <= 40; ++i) dots.x.push_back(i), dots.y.push_back(i % 2 ? 10 : 9);
  dots.x.push_back(0), dots.y.push_back(0);
  const Series line{"a line", {0, 40}, {9.5, 9.5}, cv::Scalar(-1, -1, -1, -1), false, true};
  PlotSpec spec{"", "", "", false, false, {dots, line}};
  const cv::Mat img = renderPlot(spec, 600, 400);
  keep(img, "plot_legend.png");
  const PlotMargins m = plotMargins(spec);
  const int bottom = 400 - 1 - m.bottom, width = 600 - m.left - m.right;
  const cv::Rect low(m.left + 2, bottom - 50, width - 4, 48), high(m.left + 2, m.top + 2, width - 4, 60);
  EXPECT_TRUE(hasHorizontalRun(img, bgr(plotColour(1)), 18, low));
  EXPECT_GT(countNear(img, cv::Vec3b(160, 160, 160), low), 40);
  EXPECT_EQ(countNear(img, cv::Vec3b(160, 160, 160), high), 0);
}

// Titles and labels are gnuplot strings, not code: a quote, a backslash and enhanced-text
// markup come out as written and do not break the script.
TEST(RenderPlot, LabelsAreQuoted) {
  PlotSpec spec{"it's \"a\" \\n {x}^2_y @z", "x'", "y\nz", false, false, {Series{"a'b", {0, 1}, {0, 1}}}};
  const std::string script = gnuplotScript(spec, 400, 300, "o'ut.png");
  EXPECT_NE(script.find("set title 'it''s \"a\" \\n {x}^2_y @z'"), std::string::npos) << script;
  EXPECT_NE(script.find("set ylabel 'y z'"), std::string::npos);
  EXPECT_NE(script.find("set output 'o''ut.png'"), std::string::npos);
  EXPECT_NE(script.find("title 'a''b'"), std::string::npos);
  EXPECT_NE(script.find("noenhanced"), std::string::npos);
  EXPECT_EQ(renderPlot(spec, 400, 300).size(), cv::Size(400, 300));
}

// The same spec gives the same pixels, one plot at a time or four on threads at once.
TEST(RenderPlot, DeterministicAndThreadSafe) {
  const PlotSpec spec = sampleSpec(true);
  const cv::Mat first = renderPlot(spec, 500, 300);
  std::vector<cv::Mat> out(4);
  std::vector<std::thread> threads;
  for (auto& m : out) threads.emplace_back([&spec, &m] { m = renderPlot(spec, 500, 300); });
  for (auto& t : threads) t.join();
  for (const cv::Mat& m : out) {
    ASSERT_EQ(m.size(), first.size());
    EXPECT_EQ(cv::norm(m, first, cv::NORM_INF), 0);
  }
}

// What renderPlot throws with PATH set to `path` (restored after); empty when it does not throw.
std::string errorWithPath(const std::string& path) {
  const std::string saved = std::getenv("PATH") ? std::getenv("PATH") : "";
  ::setenv("PATH", path.c_str(), 1);
  std::string what;
  try {
    renderPlot(sampleSpec(false), 400, 300);
  } catch (const std::runtime_error& e) {
    what = e.what();
  }
  ::setenv("PATH", saved.c_str(), 1);
  return what;
}

// Without gnuplot on PATH: one line that says what to install.
TEST(RenderPlot, MissingGnuplotIsOneClearLine) {
  const auto empty = std::filesystem::temp_directory_path() / "ambler-test-no-gnuplot";
  std::filesystem::create_directories(empty);
  EXPECT_EQ(errorWithPath(empty.string()), "gnuplot not found: install gnuplot-nox (scripts/setup.sh)");
}

// AMBLER_KEEP_PLOTS=DIR keeps each plot's script, which re-renders the same picture on its own.
TEST(RenderPlot, KeptScriptReRendersThePlot) {
  const auto dir = std::filesystem::temp_directory_path() / ("ambler-test-kept-plots-" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  ::setenv("AMBLER_KEEP_PLOTS", dir.c_str(), 1);
  const cv::Mat img = renderPlot(sampleSpec(true), 500, 300);
  ::unsetenv("AMBLER_KEEP_PLOTS");
  std::vector<std::filesystem::path> scripts;
  for (const auto& e : std::filesystem::directory_iterator(dir)) scripts.push_back(e.path());
  ASSERT_EQ(scripts.size(), 1u);
  EXPECT_EQ(scripts[0].extension(), ".gp");
  const std::string command = "cd '" + dir.string() + "' && gnuplot -d '" + scripts[0].filename().string() + "'";
  ASSERT_EQ(std::system(command.c_str()), 0) << command;
  auto png = scripts[0];
  const cv::Mat again = cv::imread(png.replace_extension(".png").string(), cv::IMREAD_COLOR);
  ASSERT_EQ(again.size(), img.size());
  EXPECT_EQ(cv::norm(again, img, cv::NORM_INF), 0);
  std::filesystem::remove_all(dir);
}

// gnuplot failing: one line with its exit status and its message (the last line it printed; a
// real gnuplot's is '"plot.gp" line 3: undefined variable: foo', after the command and a caret).
TEST(RenderPlot, FailingGnuplotIsOneLineWithItsMessage) {
  const std::string path = std::getenv("PATH") ? std::getenv("PATH") : "";
  const auto dir = std::filesystem::temp_directory_path() / ("ambler-test-failing-gnuplot-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  {
    std::ofstream fake(dir / "gnuplot");
    fake << "#!/bin/sh\necho >&2\necho 'plot foo' >&2\necho '     ^' >&2\n"
            "echo '\"plot.gp\" line 3: undefined variable: foo' >&2\nexit 1\n";
  }
  std::filesystem::permissions(dir / "gnuplot", std::filesystem::perms::owner_all);
  const std::string what = errorWithPath(dir.string() + ":" + path);
  std::filesystem::remove_all(dir);
  EXPECT_EQ(what, "gnuplot failed (exit 1): \"plot.gp\" line 3: undefined variable: foo");
}

}  // namespace
}  // namespace ambler::eval
