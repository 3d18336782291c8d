#include "eval/plot.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

namespace ambler::eval {

namespace {

constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;
const cv::Scalar kBlack(0, 0, 0), kGrid(222, 222, 222), kMinorGrid(242, 242, 242), kWhite(255, 255, 255);

// 10^e, correctly rounded for |e| ≤ 22 (powers of ten up to 1e22 are exact doubles).
double pow10(int e) { return e >= 0 ? std::pow(10.0, e) : 1.0 / std::pow(10.0, -e); }

std::string printf1(const char* pattern, int decimals, double v) {
  char buf[48];
  std::snprintf(buf, sizeof buf, pattern, decimals, v);
  return buf;
}

// Tick labels with as many decimals as the step needs, so 0.2 steps read 0.0, 0.2, ... 1.0.
std::vector<std::string> linearLabels(const std::vector<double>& ticks) {
  const double step = ticks.size() > 1 ? ticks[1] - ticks[0] : 1.0;
  const double big = std::max(std::abs(ticks.front()), std::abs(ticks.back()));
  const int decimals = std::max(0, -int(std::floor(std::log10(step) + 1e-9)));
  std::vector<std::string> out;
  for (double t : ticks)
    out.push_back(big >= 1e6 || decimals > 6 ? printf1("%.*g", 4, t) : printf1("%.*f", decimals, t));
  return out;
}

cv::Size textSize(const std::string& s, double scale) {
  int baseline = 0;
  return cv::getTextSize(s, kFont, scale, 1, &baseline);
}

void text(cv::Mat& img, const std::string& s, cv::Point at, double scale) {
  cv::putText(img, s, at, kFont, scale, kBlack, 1, cv::LINE_AA);
}

// One axis: data values → pixels, linear or log10.
struct Axis {
  bool log = false;
  std::vector<double> ticks;
  double lo = 0, hi = 1;  // axis units (log10 of the value on a log axis)
  double p0 = 0, p1 = 1;  // pixels of lo and hi

  bool usable(double v) const { return std::isfinite(v) && (!log || v > 0); }
  double unit(double v) const { return log ? std::log10(v) : v; }
  double px(double v) const { return p0 + (unit(v) - lo) / (hi - lo) * (p1 - p0); }

  void fit(double data_lo, double data_hi, int intervals) {
    if (data_lo > data_hi) data_lo = log ? 1.0 : 0.0, data_hi = log ? 10.0 : 1.0;  // no data
    ticks = log ? logTicks(data_lo, data_hi) : niceTicks(data_lo, data_hi, intervals);
    lo = unit(ticks.front()), hi = unit(ticks.back());
  }
  std::vector<std::string> labels() const {
    if (!log) return linearLabels(ticks);
    std::vector<std::string> out;
    for (double t : ticks) out.push_back(printf1("%.*g", 6, t));
    return out;
  }
  // 2·10^e … 9·10^e between consecutive decade ticks, when the decades are few enough to read.
  std::vector<double> minor() const {
    std::vector<double> out;
    if (!log || ticks.size() > 7 || ticks[1] / ticks[0] > 10.5) return out;
    for (std::size_t i = 0; i + 1 < ticks.size(); ++i)
      for (int k = 2; k <= 9; ++k) out.push_back(k * ticks[i]);
    return out;
  }
};

void drawYLabel(cv::Mat& canvas, const std::string& label, int x, int y_mid) {
  if (label.empty()) return;
  const cv::Size s = textSize(label, 0.5);
  cv::Mat strip(s.height + 8, s.width + 4, CV_8UC3, kWhite), turned;
  text(strip, label, cv::Point(2, s.height + 2), 0.5);
  cv::rotate(strip, turned, cv::ROTATE_90_COUNTERCLOCKWISE);
  if (turned.rows > canvas.rows || x + turned.cols > canvas.cols) return;  // no room: leave it out
  const int top = std::clamp(y_mid - turned.rows / 2, 0, canvas.rows - turned.rows);
  turned.copyTo(canvas(cv::Rect(x, top, turned.cols, turned.rows)));
}

void drawLegend(cv::Mat& canvas, const PlotSpec& spec, const std::vector<cv::Scalar>& colours,
                const std::vector<std::vector<cv::Point2d>>& points, const cv::Rect& area) {
  std::vector<int> shown;
  int text_w = 0;
  for (std::size_t i = 0; i < spec.series.size(); ++i)
    if (!spec.series[i].label.empty()) {
      shown.push_back(int(i));
      text_w = std::max(text_w, textSize(spec.series[i].label, 0.45).width);
    }
  if (shown.empty()) return;
  const int row_h = 20, w = std::min(area.width - 12, text_w + 48);
  const int h = std::min(area.height - 12, int(shown.size()) * row_h + 8);
  // The corner of the plot area that hides the fewest points.
  const std::array<cv::Point, 4> corners{cv::Point(area.x + area.width - w - 6, area.y + 6),
                                         cv::Point(area.x + 6, area.y + 6),
                                         cv::Point(area.x + area.width - w - 6, area.y + area.height - h - 6),
                                         cv::Point(area.x + 6, area.y + area.height - h - 6)};
  cv::Rect best;
  long fewest = std::numeric_limits<long>::max();
  for (const auto& corner : corners) {
    const cv::Rect box(corner, cv::Size(w, h));
    long n = 0;
    for (const auto& ps : points)
      for (const auto& p : ps) n += box.contains(cv::Point(int(p.x), int(p.y)));
    if (n < fewest) fewest = n, best = box;
  }
  canvas(best).setTo(kWhite);
  cv::rectangle(canvas, best, cv::Scalar(160, 160, 160), 1);
  for (std::size_t k = 0; k < shown.size(); ++k) {
    const Series& s = spec.series[std::size_t(shown[k])];
    const int y = best.y + 4 + int(k) * row_h + row_h / 2;
    if (y + row_h / 2 > best.y + best.height) break;  // more series than the plot has room for
    const cv::Scalar& colour = colours[std::size_t(shown[k])];
    if (s.lines) cv::line(canvas, {best.x + 6, y}, {best.x + 32, y}, colour, 2, cv::LINE_AA);
    if (s.markers) cv::circle(canvas, {best.x + 19, y}, 3, colour, cv::FILLED, cv::LINE_AA);
    text(canvas, s.label, cv::Point(best.x + 40, y + 5), 0.45);
  }
}

}  // namespace

std::vector<double> niceTicks(double lo, double hi, int intervals) {
  if (!std::isfinite(lo) || !std::isfinite(hi) || lo > hi || intervals < 1)
    throw std::invalid_argument("niceTicks: needs finite lo <= hi and intervals >= 1");
  if (hi - lo <= 1e-12 * std::max(std::abs(lo), std::abs(hi))) {
    const double d = lo == 0 ? 1.0 : 0.5 * std::abs(lo);
    lo -= d, hi += d;
  }
  int e = int(std::floor(std::log10((hi - lo) / intervals)));
  const double f = (hi - lo) / intervals / pow10(e);
  long long m = f < 1.5 ? 1 : f < 3 ? 2 : f < 7 ? 5 : 10;
  if (m == 10) m = 1, ++e;
  // k·m·10^e as the double nearest the decimal number, so 3 · 0.2 is 0.6, not 0.6000000000000001.
  const auto value = [&](long long k) { return e >= 0 ? double(k * m) * pow10(e) : double(k * m) / pow10(-e); };
  const double step = value(1);
  auto k0 = (long long)std::floor(lo / step), k1 = (long long)std::ceil(hi / step);
  while (value(k0) > lo) --k0;
  while (value(k0 + 1) <= lo) ++k0;
  while (value(k1) < hi) ++k1;
  while (value(k1 - 1) >= hi) --k1;
  std::vector<double> out;
  for (long long k = k0; k <= k1; ++k) out.push_back(value(k));
  return out;
}

std::vector<double> logTicks(double lo, double hi, int max_ticks) {
  if (!(lo > 0) || !(hi >= lo) || !std::isfinite(hi) || max_ticks < 2)
    throw std::invalid_argument("logTicks: needs 0 < lo <= hi, finite, and max_ticks >= 2");
  int e0 = int(std::floor(std::log10(lo))), e1 = int(std::ceil(std::log10(hi)));
  while (pow10(e0) > lo) --e0;
  while (pow10(e0 + 1) <= lo) ++e0;
  while (pow10(e1) < hi) ++e1;
  while (pow10(e1 - 1) >= hi) --e1;
  if (e1 == e0) ++e1;
  int d = 1;
  while ((e1 - e0 + d - 1) / d + 1 > max_ticks) ++d;
  std::vector<double> out;
  for (int e = e0;; e += d) {
    out.push_back(pow10(e));
    if (e >= e1) break;
  }
  return out;
}

cv::Scalar plotColour(int i) {
  static const std::array<cv::Scalar, 10> tab10{
      cv::Scalar(180, 119, 31), cv::Scalar(14, 127, 255),  cv::Scalar(44, 160, 44),   cv::Scalar(40, 39, 214),
      cv::Scalar(189, 103, 148), cv::Scalar(75, 86, 140),  cv::Scalar(194, 119, 227), cv::Scalar(127, 127, 127),
      cv::Scalar(34, 189, 188), cv::Scalar(207, 190, 23)};
  return tab10[std::size_t(((i % 10) + 10) % 10)];
}

cv::Mat renderPlot(const PlotSpec& spec, int width, int height) {
  if (width < 240 || height < 180)
    throw std::invalid_argument("renderPlot: the image must be at least 240 x 180 pixels");
  Axis ax, ay;
  ax.log = spec.log_x, ay.log = spec.log_y;
  double x_lo = HUGE_VAL, x_hi = -HUGE_VAL, y_lo = HUGE_VAL, y_hi = -HUGE_VAL;
  for (const Series& s : spec.series) {
    if (s.x.size() != s.y.size())
      throw std::invalid_argument("renderPlot: series '" + s.label + "' has x and y of different lengths");
    for (std::size_t i = 0; i < s.x.size(); ++i)
      if (ax.usable(s.x[i]) && ay.usable(s.y[i])) {
        x_lo = std::min(x_lo, s.x[i]), x_hi = std::max(x_hi, s.x[i]);
        y_lo = std::min(y_lo, s.y[i]), y_hi = std::max(y_hi, s.y[i]);
      }
  }
  const int top = spec.title.empty() ? 16 : 40, bottom = spec.x_label.empty() ? 34 : 56, right = 24;
  ay.fit(y_lo, y_hi, std::max(2, (height - top - bottom) / 80));
  const auto y_labels = ay.labels();
  int label_w = 0;
  for (const auto& l : y_labels) label_w = std::max(label_w, textSize(l, 0.42).width);
  const int left = label_w + 14 + (spec.y_label.empty() ? 4 : 26);
  const cv::Rect area(left, top, width - left - right, height - top - bottom);
  ax.fit(x_lo, x_hi, std::max(2, area.width / 130));
  ax.p0 = area.x, ax.p1 = area.x + area.width - 1;
  ay.p0 = area.y + area.height - 1, ay.p1 = area.y;

  cv::Mat canvas(height, width, CV_8UC3, kWhite);
  const auto xi = [&](double v) { return int(std::lround(ax.px(v))); };
  const auto yi = [&](double v) { return int(std::lround(ay.px(v))); };
  for (double t : ax.minor()) cv::line(canvas, {xi(t), area.y}, {xi(t), area.y + area.height - 1}, kMinorGrid);
  for (double t : ay.minor()) cv::line(canvas, {area.x, yi(t)}, {area.x + area.width - 1, yi(t)}, kMinorGrid);
  const auto x_labels = ax.labels();
  for (std::size_t i = 0; i < ax.ticks.size(); ++i) {
    const int x = xi(ax.ticks[i]);
    cv::line(canvas, {x, area.y}, {x, area.y + area.height - 1}, kGrid);
    cv::line(canvas, {x, area.y + area.height - 1}, {x, area.y + area.height + 3}, kBlack);
    const cv::Size s = textSize(x_labels[i], 0.42);
    text(canvas, x_labels[i], {x - s.width / 2, area.y + area.height + 8 + s.height}, 0.42);
  }
  for (std::size_t i = 0; i < ay.ticks.size(); ++i) {
    const int y = yi(ay.ticks[i]);
    cv::line(canvas, {area.x, y}, {area.x + area.width - 1, y}, kGrid);
    cv::line(canvas, {area.x - 4, y}, {area.x, y}, kBlack);
    const cv::Size s = textSize(y_labels[i], 0.42);
    text(canvas, y_labels[i], {area.x - 7 - s.width, y + s.height / 2}, 0.42);
  }
  cv::rectangle(canvas, area, kBlack, 1);

  std::vector<cv::Scalar> colours;
  std::vector<std::vector<cv::Point2d>> points(spec.series.size());
  for (std::size_t k = 0; k < spec.series.size(); ++k) {
    const Series& s = spec.series[k];
    colours.push_back(s.colour[0] < 0 ? plotColour(int(k)) : s.colour);
    bool joined = false;  // the previous point was drawable: a NaN breaks the line
    for (std::size_t i = 0; i < s.x.size(); ++i) {
      if (!ax.usable(s.x[i]) || !ay.usable(s.y[i])) {
        joined = false;
        continue;
      }
      const cv::Point2d p(ax.px(s.x[i]), ay.px(s.y[i]));
      if (joined && s.lines) {
        const cv::Point2d& q = points[k].back();
        cv::line(canvas, cv::Point(int(std::lround(q.x)), int(std::lround(q.y))),
                 cv::Point(int(std::lround(p.x)), int(std::lround(p.y))), colours[k], 2, cv::LINE_AA);
      }
      points[k].push_back(p);
      joined = true;
    }
    if (s.markers)
      for (const auto& p : points[k])
        cv::circle(canvas, cv::Point(int(std::lround(p.x)), int(std::lround(p.y))), 3, colours[k], cv::FILLED,
                   cv::LINE_AA);
  }
  drawLegend(canvas, spec, colours, points, area);

  if (!spec.title.empty()) {
    const cv::Size s = textSize(spec.title, 0.6);
    text(canvas, spec.title, {std::max(4, (width - s.width) / 2), 12 + s.height}, 0.6);
  }
  if (!spec.x_label.empty()) {
    const cv::Size s = textSize(spec.x_label, 0.5);
    text(canvas, spec.x_label, {area.x + (area.width - s.width) / 2, height - 10}, 0.5);
  }
  drawYLabel(canvas, spec.y_label, 4, area.y + area.height / 2);
  return canvas;
}

}  // namespace ambler::eval
