// Plots by gnuplot (docs/report.md, "Plots: gnuplot"): the layout (axis ranges from niceTicks and
// logTicks, fixed pixel margins, the legend's corner) is decided here, so it is the same for every
// gnuplot version and testable; gnuplot draws. Each plot runs one `gnuplot` child process on a
// script in its own temporary directory, so plots on several threads never share a file.
#include "eval/pictures/plot.hpp"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <stdexcept>
#include <string_view>
#include <system_error>

#include "eval/scenario/io.hpp"
#include "base/digest.hpp"
#include "base/temp_dir.hpp"
#include "base/text.hpp"

extern char** environ;  // the child's environment starts from ours (unistd.h declares it only with _GNU_SOURCE)

namespace ambler::eval {

namespace {

namespace fs = std::filesystem;

// 10^e, correctly rounded for |e| ≤ 22 (powers of ten up to 1e22 are exact doubles).
double pow10(int e) { return e >= 0 ? std::pow(10.0, e) : 1.0 / std::pow(10.0, -e); }

// The shortest text that reads back as the same double: the script's numbers are exact.
std::string num(double v) { return base::shortestText(v); }

// A gnuplot single-quoted string: no escapes but '' for a quote; line breaks become spaces.
std::string quoted(const std::string& s) {
  std::string out = "'";
  for (const char c : s) {
    if (c == '\'') out += "''";
    else if (c == '\n' || c == '\r' || c == '\t') out += ' ';
    else out += c;
  }
  return out + "'";
}

std::string rgb(const cv::Scalar& bgr) {
  char buf[16];
  const auto channel = [](double v) { return int(std::clamp(std::lround(v), 0L, 255L)); };
  std::snprintf(buf, sizeof buf, "#%02x%02x%02x", channel(bgr[2]), channel(bgr[1]), channel(bgr[0]));
  return buf;
}

// One axis: its range from the first to the last tick (niceTicks, or logTicks on a log axis).
struct Axis {
  bool log = false;
  std::vector<double> ticks;

  bool usable(double v) const { return std::isfinite(v) && (!log || v > 0); }
  double unit(double v) const { return log ? std::log10(v) : v; }
  // 0 at the first tick, 1 at the last.
  double frac(double v) const { return (unit(v) - unit(ticks.front())) / (unit(ticks.back()) - unit(ticks.front())); }

  void fit(double data_lo, double data_hi, int intervals) {
    if (data_lo > data_hi) data_lo = log ? 1.0 : 0.0, data_hi = log ? 10.0 : 1.0;  // no data
    ticks = log ? logTicks(data_lo, data_hi) : niceTicks(data_lo, data_hi, intervals);
  }
  // 2·10^e … 9·10^e between consecutive decade ticks, when the decades are few enough to read.
  bool minor() const { return log && ticks.size() <= 7 && ticks[1] / ticks[0] < 10.5; }

  std::string commands(const char* name) const {
    std::string s = std::string("set ") + name + "range [" + num(ticks.front()) + ":" + num(ticks.back()) + "]\n";
    if (log) s += std::string("set logscale ") + name + " 10\n";
    const double step = log ? ticks[1] / ticks[0] : ticks[1] - ticks[0];
    s += std::string("set ") + name + "tics " + num(ticks.front()) + ", " + num(step) + ", " + num(ticks.back()) +
         " out nomirror\n";
    s += std::string("set format ") + name + " '%g'\n";
    s += minor() ? std::string("set m") + name + "tics 10\n" : std::string("unset m") + name + "tics\n";
    return s;
  }
};

struct Layout {
  Axis x, y;
  PlotMargins m{};
};

Layout layout(const PlotSpec& spec, int width, int height) {
  if (width < 240 || height < 180)
    throw std::invalid_argument("renderPlot: the image must be at least 240 x 180 pixels");
  Layout l;
  l.x.log = spec.log_x, l.y.log = spec.log_y;
  double x_lo = HUGE_VAL, x_hi = -HUGE_VAL, y_lo = HUGE_VAL, y_hi = -HUGE_VAL;
  for (const Series& s : spec.series) {
    if (s.x.size() != s.y.size())
      throw std::invalid_argument("renderPlot: series '" + s.label + "' has x and y of different lengths");
    for (std::size_t i = 0; i < s.x.size(); ++i)
      if (l.x.usable(s.x[i]) && l.y.usable(s.y[i])) {
        x_lo = std::min(x_lo, s.x[i]), x_hi = std::max(x_hi, s.x[i]);
        y_lo = std::min(y_lo, s.y[i]), y_hi = std::max(y_hi, s.y[i]);
      }
  }
  l.m = plotMargins(spec);
  l.x.fit(x_lo, x_hi, std::max(2, (width - l.m.left - l.m.right) / 130));
  l.y.fit(y_lo, y_hi, std::max(2, (height - l.m.top - l.m.bottom) / 80));
  return l;
}

// The key's corner inside the plot area: the one whose (estimated) box hides the fewest points,
// in the order top right, top left, bottom right, bottom left.
std::string keyCorner(const PlotSpec& spec, const Layout& l, int width, int height) {
  std::size_t rows = 0, chars = 0;
  for (const Series& s : spec.series)
    if (!s.label.empty() && (s.lines || s.markers)) ++rows, chars = std::max(chars, s.label.size());
  const double area_w = width - l.m.left - l.m.right, area_h = height - l.m.top - l.m.bottom;
  const double box_w = std::min(1.0, (7.0 * double(chars) + 70) / area_w);
  const double box_h = std::min(1.0, (17.0 * double(rows) + 14) / area_h);
  const std::array<std::pair<const char*, std::pair<double, double>>, 4> corners{
      {{"top right", {1 - box_w, 1 - box_h}}, {"top left", {0, 1 - box_h}}, {"bottom right", {1 - box_w, 0}},
       {"bottom left", {0, 0}}}};
  const char* best = corners[0].first;
  long fewest = std::numeric_limits<long>::max();
  for (const auto& [name, corner] : corners) {
    long n = 0;
    for (const Series& s : spec.series)
      if (s.lines || s.markers)
        for (std::size_t i = 0; i < s.x.size(); ++i) {
          if (!l.x.usable(s.x[i]) || !l.y.usable(s.y[i])) continue;
          const double fx = l.x.frac(s.x[i]), fy = l.y.frac(s.y[i]);
          n += fx >= corner.first && fx <= corner.first + box_w && fy >= corner.second && fy <= corner.second + box_h;
        }
    if (n < fewest) fewest = n, best = name;
  }
  return best;
}

std::string lastLine(const fs::path& file) {
  std::ifstream in(file);
  std::string line, last;
  while (std::getline(in, line))
    if (line.find_first_not_of(" \t^\r") != std::string::npos) last = line;
  return last;
}

// Runs `gnuplot -d SCRIPT` (no init files) in the C locale, stdout and stderr to files in `dir`.
void runGnuplot(const fs::path& dir, const fs::path& script) {
  std::vector<std::string> env;
  for (char** e = environ; *e; ++e) {
    const std::string_view v(*e);
    if (v.starts_with("LC_") || v.starts_with("LANG=") || v.starts_with("LANGUAGE=") || v.starts_with("GNUPLOT_"))
      continue;
    env.emplace_back(v);
  }
  env.emplace_back("LC_ALL=C");
  std::vector<char*> envp;
  for (auto& s : env) envp.push_back(s.data());
  envp.push_back(nullptr);
  std::string arg0 = "gnuplot", arg1 = "-d", arg2 = script.string();
  char* argv[] = {arg0.data(), arg1.data(), arg2.data(), nullptr};

  const std::string out = (dir / "stdout").string(), err = (dir / "stderr").string();
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&actions, 1, out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
  posix_spawn_file_actions_addopen(&actions, 2, err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
  pid_t pid = 0;
  const int spawned = ::posix_spawnp(&pid, "gnuplot", &actions, nullptr, argv, envp.data());
  posix_spawn_file_actions_destroy(&actions);
  if (spawned == ENOENT) throw std::runtime_error("gnuplot not found: install gnuplot-nox (scripts/setup.sh)");
  if (spawned != 0)
    throw std::runtime_error("gnuplot: cannot start: " + std::error_code(spawned, std::generic_category()).message());
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0)
    if (errno != EINTR) throw std::runtime_error("gnuplot: waitpid failed");
  if (WIFEXITED(status) && WEXITSTATUS(status) == 127)
    throw std::runtime_error("gnuplot not found: install gnuplot-nox (scripts/setup.sh)");
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    const std::string why = lastLine(err);
    throw std::runtime_error("gnuplot failed" +
                             (WIFEXITED(status) ? " (exit " + std::to_string(WEXITSTATUS(status)) + ")"
                                                : std::string(" (killed by a signal)")) +
                             (why.empty() ? std::string() : ": " + why));
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

PlotMargins plotMargins(const PlotSpec& spec) {
  return {spec.y_label.empty() ? 64 : 84, 24, spec.title.empty() ? 16 : 40, spec.x_label.empty() ? 34 : 56};
}

std::string gnuplotScript(const PlotSpec& spec, int width, int height, const std::string& png_path) {
  const Layout l = layout(spec, width, height);
  std::string g;
  g += "# ambler renderPlot (eval/pictures/plot.cpp); re-render with: gnuplot -d THIS_FILE\n";
  g += "set encoding utf8\n";
  g += "set terminal pngcairo noenhanced size " + std::to_string(width) + "," + std::to_string(height) +
       " font 'DejaVu Sans,10' background '#ffffff' linewidth 1\n";
  g += "set output " + quoted(png_path) + "\n";
  // Margins at fixed pixels, so the plot area does not move with the tick labels: pngcairo puts
  // screen coordinate f at pixel f·(size − 1), so the frame is on columns left and
  // width − 1 − right, rows top and height − 1 − bottom.
  const auto screen = [](int px, int size) { return num(double(px) / double(size - 1)); };
  g += "set lmargin at screen " + screen(l.m.left, width) + "\n";
  g += "set rmargin at screen " + screen(width - 1 - l.m.right, width) + "\n";
  g += "set tmargin at screen " + screen(height - 1 - l.m.top, height) + "\n";
  g += "set bmargin at screen " + screen(l.m.bottom, height) + "\n";
  g += "set border 15 lc rgb '#000000' lw 1\n";
  g += l.x.commands("x") + l.y.commands("y");
  g += "set grid xtics ytics mxtics mytics lt 1 lc rgb '#dedede' lw 1, lt 1 lc rgb '#f2f2f2' lw 1\n";
  if (!spec.title.empty()) g += "set title " + quoted(spec.title) + " font 'DejaVu Sans,12'\n";
  if (!spec.x_label.empty()) g += "set xlabel " + quoted(spec.x_label) + "\n";
  if (!spec.y_label.empty()) g += "set ylabel " + quoted(spec.y_label) + "\n";
  g += "set key inside " + keyCorner(spec, l, width, height) +
       " reverse Left opaque box lc rgb '#a0a0a0' samplen 3 spacing 1.1 width 1\n";

  std::vector<std::string> plots;
  for (std::size_t k = 0; k < spec.series.size(); ++k) {
    const Series& s = spec.series[k];
    if (!s.lines && !s.markers) continue;  // widens the axes only
    // One line per point; a blank line where a point is not drawable breaks the line there.
    std::string block = "$s" + std::to_string(k) + " << EOD\n";
    bool any = false;
    for (std::size_t i = 0; i < s.x.size(); ++i)
      if (l.x.usable(s.x[i]) && l.y.usable(s.y[i])) block += num(s.x[i]) + " " + num(s.y[i]) + "\n", any = true;
      else block += "\n";
    block += "EOD\n";
    const std::string style = s.lines && s.markers ? "linespoints lw 2 pt 7 ps 0.9"
                              : s.lines            ? "lines lw 2"
                                                   : "points pt 7 ps 0.9";
    const std::string what = any ? (g += block, "$s" + std::to_string(k)) : std::string("NaN");
    plots.push_back(what + " with " + style + " lc rgb '" + rgb(s.colour[0] < 0 ? plotColour(int(k)) : s.colour) +
                    "' " + (s.label.empty() ? std::string("notitle") : "title " + quoted(s.label)));
  }
  if (plots.empty()) plots.push_back("NaN notitle");
  g += "plot ";
  for (std::size_t i = 0; i < plots.size(); ++i) g += (i ? ", \\\n     " : "") + plots[i];
  return g + "\n";
}

cv::Mat renderPlot(const PlotSpec& spec, int width, int height) {
  if (const char* keep = std::getenv("AMBLER_KEEP_PLOTS"); keep && *keep) {
    // Named by the script's FNV-1a digest (the journal's identity digest: 16 hex digits).
    const std::string stem = "plot-" + base::digest(gnuplotScript(spec, width, height, "plot.png"));
    createOutDir(keep);
    writeText(fs::path(keep) / (stem + ".gp"), gnuplotScript(spec, width, height, stem + ".png"));
  }
  const base::TempDir dir("plot");
  const fs::path png = dir.path() / "plot.png", script = dir.path() / "plot.gp";
  {
    std::ofstream out(script, std::ios::binary);
    out << gnuplotScript(spec, width, height, png.string());
    if (!out.flush()) throw std::runtime_error(script.string() + ": write failed");
  }
  runGnuplot(dir.path(), script);
  cv::Mat img = cv::imread(png.string(), cv::IMREAD_COLOR);
  if (img.empty() || img.cols != width || img.rows != height)
    throw std::runtime_error("gnuplot wrote no " + std::to_string(width) + " x " + std::to_string(height) + " PNG");
  return img;
}

}  // namespace ambler::eval
