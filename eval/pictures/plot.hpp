#pragma once
// Line and scatter plots drawn by gnuplot (pngcairo), for the run's and the experiments' figures
// and the reports' sweep plots: white background, gridlines at "nice" ticks (1-2-5 steps, decades
// on log axes), a legend, a title and axis labels. renderPlot writes the data and a gnuplot script
// into a private temporary directory, runs `gnuplot` as a child process (no shell) and reads the
// PNG back; the same spec gives the same pixels (docs/report.md, "Plots").
#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace ambler::eval {

struct Series {
  std::string label;                      // empty: left out of the legend
  std::vector<double> x, y;               // same length; a NaN point breaks the line
  cv::Scalar colour{-1, -1, -1, -1};      // BGR; negative: plotColour(index of the series)
  bool markers = false;                   // a dot on every point
  bool lines = true;                      // segments between consecutive finite points
};
// A series with neither lines nor markers draws nothing but still widens the axes to its points
// (callers use it to make room for the legend or to start an axis at zero).

struct PlotSpec {
  std::string title, x_label, y_label;
  bool log_x = false, log_y = false;      // on a log axis, points ≤ 0 are skipped like NaN
  std::vector<Series> series;
};

// Ticks at k · step with step 1, 2 or 5 · 10^n, about `intervals` of them, covering [lo, hi]:
// the first ≤ lo, the last ≥ hi. lo == hi is widened to a unit-sized range around it.
// Throws std::invalid_argument unless lo ≤ hi, both finite, and intervals ≥ 1.
std::vector<double> niceTicks(double lo, double hi, int intervals = 5);

// Powers of ten covering [lo, hi] (0 < lo ≤ hi), at least two; every k-th decade when there would
// be more than `max_ticks`. Throws std::invalid_argument on non-positive or non-finite bounds.
std::vector<double> logTicks(double lo, double hi, int max_ticks = 8);

// The i-th colour (BGR) of a ten-colour palette (matplotlib's "tab10"), cycling.
cv::Scalar plotColour(int i);

// The plot area's margins in pixels: the frame is drawn on columns left and width − 1 − right and
// rows top and height − 1 − bottom.
struct PlotMargins {
  int left, right, top, bottom;
};
PlotMargins plotMargins(const PlotSpec& spec);

// The gnuplot script renderPlot runs: self-contained (the data inline as datablocks), writing a
// width × height PNG to `png_path`. Throws std::invalid_argument as renderPlot does.
std::string gnuplotScript(const PlotSpec& spec, int width, int height, const std::string& png_path);

// The plot as an 8-bit BGR image of width × height. Throws std::invalid_argument when the size is
// below 240 × 180 or a series' x and y differ in length; std::runtime_error with one line when
// gnuplot is not installed ("gnuplot not found: install gnuplot-nox (scripts/setup.sh)") or fails
// (its first line on stderr). Thread-safe. With AMBLER_KEEP_PLOTS=DIR set, every script is also
// kept in DIR as plot-<digest>.gp (re-render it with `gnuplot plot-<digest>.gp`).
cv::Mat renderPlot(const PlotSpec& spec, int width = 900, int height = 560);

}  // namespace ambler::eval
