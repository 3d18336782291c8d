// The locus-vs-Cartesian experiment: two sweeps run through the sweep API, then a separate report
// step that reads only their results.csv (so a sweep run in shards and merged reports the same),
// groups the runs that differ only in their seed, and writes mean ± standard deviation over seeds.
// Also the helpers every experiment shares (experiment_internal.hpp).
#include "base/read_file.hpp"
#include "eval/tools/experiment/experiment.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <initializer_list>
#include <limits>
#include <map>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "eval/tools/experiment/experiment_internal.hpp"
#include "eval/scenario/io.hpp"
#include "eval/score/map_metrics.hpp"
#include "eval/pictures/plot.hpp"
#include "eval/tools/sweep/sweep.hpp"

namespace ambler::eval {

// ---- shared with the other experiments (experiment_internal.hpp) ---------------------------------

namespace experiment_detail {

namespace fs = std::filesystem;

std::string readFile(const fs::path& file) {
  try {
    return base::readFile(file);
  } catch (const base::ReadError& e) {
    throw SweepError(file.string() + ": " + e.what());
  }
}

Sweep experimentSweep(const fs::path& file, bool quick) {
  if (!quick) return loadSweep(file);
  YAML::Node root;
  try {
    root = YAML::Load(readFile(file));
  } catch (const YAML::Exception& e) {
    throw SweepError(file.string() + ": YAML syntax error: " + e.msg);
  }
  if (root.IsMap() && root["axes"].IsMap()) {
    YAML::Node axes = root["axes"];
    std::vector<std::pair<std::string, YAML::Node>> fewer;
    for (auto it = axes.begin(); it != axes.end(); ++it) {
      const YAML::Node values = it->second;
      if (!it->first.IsScalar() || !values.IsSequence() || values.size() < 2) continue;
      YAML::Node kept(YAML::NodeType::Sequence);
      kept.push_back(YAML::Clone(values[0]));
      if (it->first.Scalar() != "seed") kept.push_back(YAML::Clone(values[values.size() - 1]));
      fewer.emplace_back(it->first.Scalar(), kept);
    }
    for (const auto& [key, kept] : fewer) axes[key] = kept;
  }
  return parseSweep(YAML::Dump(root), file);
}

void requireAxes(const Sweep& s, std::initializer_list<const char*> keys) {
  for (const char* key : keys)
    if (std::none_of(s.axes.begin(), s.axes.end(), [&](const SweepAxis& a) { return a.key == key; }))
      throw SweepError(s.file.string() + ": axes: the experiment's report needs an axis " + key);
}

fs::path runExperimentSweep(const Sweep& sweep, const fs::path& dir, const ExperimentOptions& opt) {
  SweepOptions so;
  so.out = dir;
  so.custom = opt.custom;
  so.jobs = opt.jobs;
  so.progress = opt.progress;
  return runSweep(sweep, so);
}

std::vector<Sweep> experimentSweeps(const ExperimentOptions& opt, const std::vector<std::string>& files,
                                    const std::function<bool(const Scenario&)>& usable, const std::string& need) {
  std::vector<Sweep> sweeps;
  for (const std::string& file : files) {
    Sweep s = experimentSweep(opt.sweeps / file, opt.quick);
    requireAxes(s, {"seed"});
    for (const Scenario& sc : s.runs)
      if (!usable(sc)) throw SweepError(s.file.string() + ": the experiment needs " + need + " in every run");
    sweeps.push_back(std::move(s));
  }
  return sweeps;
}

std::string writeTable(const ExperimentOptions& opt, const std::string& md) {
  writeText(opt.out / "table.md", md);
  return md;
}

std::string runSweepsAndReport(const std::vector<Sweep>& sweeps, const std::vector<std::string>& dirs,
                               const ExperimentOptions& opt, const char* name,
                               const std::function<std::string()>& report) {
  const auto start = std::chrono::steady_clock::now();
  std::size_t runs = 0;
  for (std::size_t i = 0; i < sweeps.size(); ++i) {
    runExperimentSweep(sweeps[i], opt.out / dirs.at(i), opt);
    runs += sweeps[i].runs.size();
  }
  const std::string md = report();
  if (opt.progress) {
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::fprintf(stderr, "ambler: experiment %s: %zu runs in %.1f s -> %s\n", name, runs, s, opt.out.string().c_str());
  }
  return md;
}

namespace {

Stat summary(const std::vector<double>& v) {
  Stat s;
  s.n = int(v.size());
  if (v.empty()) return s;
  double sum = 0;
  for (const double x : v) sum += x;
  s.mean = sum / double(v.size());
  if (v.size() < 2) return s;
  double ss = 0;
  for (const double x : v) ss += (x - s.mean) * (x - s.mean);
  s.sd = std::sqrt(ss / double(v.size() - 1));
  return s;
}

}  // namespace

Results::Results(const Sweep& sweep, const fs::path& csv) : sweep_(sweep) {
  const auto records = parseResultsCsv(readFile(csv));
  if (!records || records->empty()) throw SweepError(csv.string() + ": not a results.csv");
  const auto& header = records->front();
  for (std::size_t i = 0; i < header.size(); ++i) column_[header[i]] = i;
  std::size_t seed_axis = sweep.axes.size();
  for (std::size_t a = 0; a < sweep.axes.size(); ++a)
    if (sweep.axes[a].key == "seed") seed_axis = a;
  rows_.assign(sweep.runs.size(), {});
  std::map<std::vector<std::size_t>, std::size_t> group_of;
  for (std::size_t r = 1; r < records->size(); ++r) {
    const auto& row = (*records)[r];
    std::size_t k = 0;
    if (row.empty() || std::from_chars(row[0].data(), row[0].data() + row[0].size(), k).ec != std::errc() ||
        k >= sweep.runs.size())
      throw SweepError(csv.string() + ": row " + std::to_string(r) + ": not a run of " + sweep.file.string());
    rows_[k] = row;
    auto key = sweep.combination(k);
    if (seed_axis < key.size()) key.erase(key.begin() + std::ptrdiff_t(seed_axis));
    const auto [it, added] = group_of.emplace(key, groups_.size());
    if (added) groups_.emplace_back();
    groups_[it->second].push_back(k);
  }
}

std::string Results::cell(std::size_t run, const std::string& column) const {
  const auto it = column_.find(column);
  return run >= rows_.size() || it == column_.end() || it->second >= rows_[run].size() ? "" : rows_[run][it->second];
}

double Results::value(std::size_t run, const std::string& column) const {
  const std::string text = cell(run, column);
  double x = kNaN;
  if (text.empty() || std::from_chars(text.data(), text.data() + text.size(), x).ec != std::errc()) return kNaN;
  return x;
}

std::vector<double> Results::values(const std::vector<std::size_t>& group, const std::string& column) const {
  std::vector<double> v;
  for (const std::size_t k : group)
    if (const double x = value(k, column); std::isfinite(x)) v.push_back(x);
  return v;
}

Stat Results::stat(const std::vector<std::size_t>& group, const std::string& column) const {
  return summary(values(group, column));
}

// Each run of the locus experiment maps the same scan both ways, so the seeds pair the two maps.
Stat Results::difference(const std::vector<std::size_t>& group, const std::string& a, const std::string& b) const {
  std::vector<double> v;
  for (const std::size_t k : group)
    if (const double d = value(k, a) - value(k, b); std::isfinite(d)) v.push_back(d);
  return summary(v);
}

double Results::largest(const std::vector<std::size_t>& group, const std::string& column) const {
  double out = kNaN;
  for (const std::size_t k : group)
    if (const double x = value(k, column); std::isfinite(x) && !(x <= out)) out = x;
  return out;
}

std::string format(const char* pattern, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, pattern, v);
  return buf;
}

int decimalsFor(double v) {
  const double a = std::abs(v);
  return a < 1 ? 3 : a < 10 ? 2 : a < 100 ? 1 : 0;
}

std::string number(double v, int decimals) {
  if (!std::isfinite(v)) return "—";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals < 0 ? decimalsFor(v) : decimals, v);
  return buf;
}

void appendCell(std::string& row, const std::string& text) { row.append(" ").append(text).append(" |"); }

// The default PNG level makes a four-panel plot twice as large.
void writeFigure(const fs::path& path, const cv::Mat& image) {
  std::string bytes;
  try {
    bytes = compactPngBytes(image);
  } catch (const std::runtime_error&) {
    throw std::runtime_error(path.string() + ": could not encode image");
  }
  writeText(path, bytes);
}

// renderPlot puts the legend in the corner of the plot area that hides the fewest points; the
// invisible point sits at the height of a data point.
void legendRoom(PlotSpec& spec, double x_room) {
  for (const Series& s : spec.series)
    for (const double y : s.y)
      if (std::isfinite(y) && (!spec.log_y || y > 0)) {
        spec.series.push_back(Series{"", {x_room}, {y}, cv::Scalar(255, 255, 255), false, false});
        return;
      }
}

cv::Mat grid2(const std::vector<cv::Mat>& panels, int cols) {
  std::vector<cv::Mat> rows;
  for (std::size_t i = 0; i < panels.size(); i += std::size_t(cols)) {
    cv::Mat row;
    cv::hconcat(std::vector<cv::Mat>(panels.begin() + std::ptrdiff_t(i),
                                     panels.begin() + std::ptrdiff_t(std::min(panels.size(), i + std::size_t(cols)))),
                row);
    rows.push_back(row);
  }
  cv::Mat out;
  cv::vconcat(rows, out);
  return out;
}

}  // namespace experiment_detail

namespace {

namespace fs = std::filesystem;
using namespace experiment_detail;
constexpr std::size_t kBands = kRangeBandEdgesM.size() - 1;

// The gap filling the runs of a group chose: "linear", or "linear 2/3, nearest 1/3".
std::string fills(const Results& r, const std::vector<std::size_t>& group) {
  std::map<std::string, int> count;
  for (const std::size_t k : group) ++count[r.cell(k, "map_cartesian.0.gap_fill")];
  if (count.size() == 1) return count.begin()->first.empty() ? "—" : count.begin()->first;
  std::string out;
  for (const auto& [name, n] : count)
    out += (out.empty() ? "" : ", ") + name + " " + std::to_string(n) + "/" + std::to_string(group.size());
  return out;
}

// Column names of metrics.json leaves, for the locus map ("map") or the baseline ("map_cartesian").
std::string whole(const char* map, const char* key) { return std::string(map) + ".0." + key; }
std::string band(const char* map, std::size_t b, const char* key) {
  return std::string(map) + ".0.by_range." + std::to_string(b) + "." + key;
}

// ---- labels and numbers -------------------------------------------------------------------------

std::string tiltLabel(const Scenario& s) {
  const double a = s.terrain.slope_deg.x(), b = s.terrain.slope_deg.y();
  if (a == 0 && b == 0) return "level";
  std::string out;
  if (a != 0) out = format("%g° facing", a);
  if (b != 0) out += (out.empty() ? "" : ", ") + format("%g° sideways", b);
  return out;
}

std::string noiseLabel(const perception::SensorModel& s) {
  if (s.noise_k == 0 && s.quantization_m == 0) return "none, unquantised";
  const std::string q = s.quantization_m == 0 ? ", unquantised" : "";
  return s.noise_k == 0 ? "quantisation only" + q : format("k = %g", s.noise_k) + q;
}

std::string bandLabel(std::size_t b) {
  const double lo = kRangeBandEdgesM[b], hi = kRangeBandEdgesM[b + 1];
  return std::isinf(hi) ? format("≥ %g m", lo) : format("%g", lo) + format("–%g m", hi);
}

// mean ± sd in `scale` units (mm: 1000, %: 100), both to the mean's decimals; the mean alone with
// one seed.
std::string meanSd(const Stat& s, double scale, int decimals = -1) {
  if (s.n == 0) return "—";
  const int d = decimals < 0 ? decimalsFor(s.mean * scale) : decimals;
  return std::isfinite(s.sd) ? number(s.mean * scale, d) + " ± " + number(s.sd * scale, d) : number(s.mean * scale, d);
}

// Which of locus (−1) and Cartesian (+1) is better by the figure `key`, or 0: the mean of the
// paired difference locus − Cartesian must exceed its standard deviation over seeds (with one
// seed, any difference counts).
int better(const Results& r, const std::vector<std::size_t>& group, const std::string& locus,
           const std::string& cart, bool lower_is_better) {
  const Stat d = r.difference(group, locus, cart);
  if (d.n == 0 || d.mean == 0 || std::abs(d.mean) <= (std::isfinite(d.sd) ? d.sd : 0)) return 0;
  return (d.mean < 0) == lower_is_better ? -1 : 1;
}

std::string bold(const std::string& text, bool on) { return on ? "**" + text + "**" : text; }

// "L / C" of the columns `locus` and `cart`, means, with the better one in bold.
std::string pairCell(const Results& r, const std::vector<std::size_t>& g, const std::string& locus_column,
                     const std::string& cart_column, double scale, bool lower_is_better, int decimals) {
  const Stat locus = r.stat(g, locus_column), cart = r.stat(g, cart_column);
  if (locus.n == 0 && cart.n == 0) return "—";
  const int b = better(r, g, locus_column, cart_column, lower_is_better);
  return bold(locus.n ? number(locus.mean * scale, decimals) : "—", b < 0) + " / " +
         bold(cart.n ? number(cart.mean * scale, decimals) : "—", b > 0);
}

std::string ratioCell(const Stat& locus, const Stat& cart) {
  return locus.n && cart.n && cart.mean > 0 ? format("%.2f", locus.mean / cart.mean) : "—";
}

// ---- tables -------------------------------------------------------------------------------------

using Labeller = std::string (*)(const Results&, const std::vector<std::size_t>&);

std::string tiltRow(const Results& r, const std::vector<std::size_t>& g) {
  return tiltLabel(r.scenario(g)) + " | " + noiseLabel(r.scenario(g).sensor);
}
std::string surfaceRow(const Results& r, const std::vector<std::size_t>& g) { return tiltLabel(r.scenario(g)); }
std::string cellRow(const Results& r, const std::vector<std::size_t>& g) {
  return format("%g cm", 100 * r.scenario(g).map->cell_m);
}

std::string wholeMapTable(const Results& r, const std::string& head, Labeller label) {
  std::string out = "| " + head +
                    " | coverage locus % | coverage Cart. % | RMS locus mm | RMS Cart. mm | RMS locus / Cart."
                    " | median locus mm | median Cart. mm | worst cell mm (L / C) | Cart. fill | locus within 1σ % |"
                    " locus shadow cells |\n";
  const int head_cells = int(std::count(head.begin(), head.end(), '|')) + 1;
  out += "|";
  for (int i = 0; i < head_cells; ++i) out += "---|";
  out += "---:|---:|---:|---:|---:|---:|---:|---:|---|---:|---:|\n";
  for (const auto& g : r.groups()) {
    const Stat cl = r.stat(g, whole("map", "coverage")), cc = r.stat(g, whole("map_cartesian", "coverage"));
    const Stat rl = r.stat(g, whole("map", "rms_error_m")), rc = r.stat(g, whole("map_cartesian", "rms_error_m"));
    const Stat ml = r.stat(g, whole("map", "median_abs_error_m"));
    const Stat mc = r.stat(g, whole("map_cartesian", "median_abs_error_m"));
    const int bc = better(r, g, whole("map", "coverage"), whole("map_cartesian", "coverage"), false);
    const int br = better(r, g, whole("map", "rms_error_m"), whole("map_cartesian", "rms_error_m"), true);
    const int bm =
        better(r, g, whole("map", "median_abs_error_m"), whole("map_cartesian", "median_abs_error_m"), true);
    const std::string worst = number(1000 * r.largest(g, whole("map", "max_abs_error_m"))) + " / " +
                              number(1000 * r.largest(g, whole("map_cartesian", "max_abs_error_m")));
    std::string row = "| " + label(r, g) + " |";
    for (const std::string& cell :
         {bold(meanSd(cl, 100, 1), bc < 0), bold(meanSd(cc, 100, 1), bc > 0), bold(meanSd(rl, 1000), br < 0),
          bold(meanSd(rc, 1000), br > 0), ratioCell(rl, rc), bold(meanSd(ml, 1000), bm < 0),
          bold(meanSd(mc, 1000), bm > 0), worst, fills(r, g), meanSd(r.stat(g, whole("map", "within_1sigma")), 100, 1),
          meanSd(r.stat(g, whole("map", "shadow")), 1, 0)})
      appendCell(row, cell);
    out += row + "\n";
  }
  return out;
}

// The header and alignment rows of a table with the `head` columns and one column per range band.
std::string bandHeader(const std::string& head) {
  std::string out = "| " + head + " |", rule = "|";
  const int head_cells = int(std::count(head.begin(), head.end(), '|')) + 1;
  for (int i = 0; i < head_cells; ++i) rule += "---|";
  for (std::size_t b = 0; b < kBands; ++b) {
    appendCell(out, bandLabel(b));
    rule += "---:|";
  }
  return out + "\n" + rule + "\n";
}

// One row per group, one "locus / Cartesian" column per range band.
std::string bandTable(const Results& r, const std::string& head, Labeller label, const char* key, double scale,
                      bool lower_is_better, int decimals) {
  std::string out = bandHeader(head);
  for (const auto& g : r.groups()) {
    out += "| " + label(r, g) + " |";
    for (std::size_t b = 0; b < kBands; ++b)
      appendCell(out, pairCell(r, g, band("map", b, key), band("map_cartesian", b, key), scale, lower_is_better,
                               decimals));
    out += "\n";
  }
  return out;
}

// Visible cells per band (the same for both maps): how much each band weighs. Rows with the same
// label (a surface seen at every noise level) are shown once.
std::string bandSizes(const Results& r, Labeller label, const std::string& head) {
  std::string out = bandHeader(head);
  std::vector<std::string> shown;
  for (const auto& g : r.groups()) {
    const std::string name = label(r, g);
    if (std::find(shown.begin(), shown.end(), name) != shown.end()) continue;
    shown.push_back(name);
    out += "| " + name + " |";
    for (std::size_t b = 0; b < kBands; ++b) {
      const Stat s = r.stat(g, band("map", b, "visible"));
      appendCell(out, s.n ? format("%.0f", s.mean) : std::string("—"));
    }
    out += "\n";
  }
  return out;
}

std::string report(const Results& tilt, const Results& res, bool quick) {
  const std::string tilt_head = "surface | noise", res_head = "map cell";
  std::string md = "<!-- written by `ambler experiment locus-vs-cartesian" + std::string(quick ? " --quick" : "") +
                   "`; the numbers are means over seeds ± their standard deviation -->\n\n";
  md += "Locus map (L) against the Cartesian baseline (C: bins averaged, the better by RMS of nearest and "
        "linear gap filling). A figure is in bold where it beats the other map by more than the "
        "seed-to-seed spread: each run maps the same scan both ways, and the mean of the paired difference exceeds "
        "its standard deviation over seeds. Coverage is known ∩ visible / visible; "
        "errors are over known cells with a true surface; the worst cell is the largest |error| over the "
        "seeds.\n\n";
  md += "### Tilted planes: whole map (0.10 m cells)\n\n" + wholeMapTable(tilt, tilt_head, tiltRow);
  md += "\n### Tilted planes: RMS error by range band, mm (L / C)\n\n" +
        bandTable(tilt, tilt_head, tiltRow, "rms_error_m", 1000, true, -1);
  md += "\n### Tilted planes: median |error| by range band, mm (L / C)\n\n" +
        bandTable(tilt, tilt_head, tiltRow, "median_abs_error_m", 1000, true, -1);
  md += "\n### Tilted planes: coverage by range band, % (L / C)\n\n" +
        bandTable(tilt, tilt_head, tiltRow, "coverage", 100, false, 1);
  md += "\n### Tilted planes: visible cells per range band\n\n" + bandSizes(tilt, surfaceRow, "surface");
  md += "\n### Fractal terrain: whole map by map cell\n\n" + wholeMapTable(res, res_head, cellRow);
  md += "\n### Fractal terrain: RMS error by range band, mm (L / C)\n\n" +
        bandTable(res, res_head, cellRow, "rms_error_m", 1000, true, -1);
  md += "\n### Fractal terrain: coverage by range band, % (L / C)\n\n" +
        bandTable(res, res_head, cellRow, "coverage", 100, false, 1);
  return md;
}

// ---- plots --------------------------------------------------------------------------------------

// Locus (lines and dots) and Cartesian (lines) of one metric, one colour per noise level, against
// the tilt about x (facing: axis 0) or y (sideways: axis 1).
cv::Mat tiltPanel(const Results& r, int axis, const char* key, double scale, const std::string& title,
                  const std::string& y_label, bool log_y) {
  PlotSpec spec{title, axis == 0 ? "tilt about x, rising away from the sensor (deg)" : "tilt about y, sideways (deg)",
                y_label, false, log_y, {}};
  std::vector<std::string> noises;  // in sweep order
  for (const auto& g : r.groups()) {
    const std::string n = noiseLabel(r.scenario(g).sensor);
    if (std::find(noises.begin(), noises.end(), n) == noises.end()) noises.push_back(n);
  }
  for (std::size_t i = 0; i < noises.size(); ++i) {
    Series locus{"locus, " + noises[i], {}, {}, plotColour(int(i)), true, true};
    Series cart{"Cart., " + noises[i], {}, {}, plotColour(int(i)), false, true};
    for (const auto& g : r.groups()) {
      const Scenario& s = r.scenario(g);
      const double other = axis == 0 ? s.terrain.slope_deg.y() : s.terrain.slope_deg.x();
      if (noiseLabel(s.sensor) != noises[i] || other != 0) continue;
      const double x = axis == 0 ? s.terrain.slope_deg.x() : s.terrain.slope_deg.y();
      locus.x.push_back(x), locus.y.push_back(r.stat(g, whole("map", key)).mean * scale);
      cart.x.push_back(x), cart.y.push_back(r.stat(g, whole("map_cartesian", key)).mean * scale);
    }
    spec.series.push_back(locus);
    spec.series.push_back(cart);
  }
  legendRoom(spec, 75);  // the tilts end at 45°
  return renderPlot(spec, kPanelWidth, kPanelHeight);
}

cv::Mat tiltPlot(const Results& r) {
  return grid2({tiltPanel(r, 0, "rms_error_m", 1000, "RMS error, plane facing the sensor", "RMS error (mm)", true),
                tiltPanel(r, 1, "rms_error_m", 1000, "RMS error, plane tilted sideways", "RMS error (mm)", true),
                tiltPanel(r, 0, "coverage", 100, "coverage, plane facing the sensor", "coverage (%)", false),
                tiltPanel(r, 1, "coverage", 100, "coverage, plane tilted sideways", "coverage (%)", false)},
               2);
}

cv::Mat resolutionPlot(const Results& r) {
  const auto panel = [&](const char* key, double scale, const std::string& title, const std::string& y_label,
                         bool from_zero) {
    PlotSpec spec{title, "map cell (cm)", y_label, false, false, {}};
    Series locus{"locus", {}, {}, plotColour(0), true, true}, cart{"Cartesian", {}, {}, plotColour(1), true, true};
    for (const auto& g : r.groups()) {
      const double x = 100 * r.scenario(g).map->cell_m;
      locus.x.push_back(x), locus.y.push_back(r.stat(g, whole("map", key)).mean * scale);
      cart.x.push_back(x), cart.y.push_back(r.stat(g, whole("map_cartesian", key)).mean * scale);
    }
    spec.series = {locus, cart};
    // The y axis from zero, so that a 10 % difference looks like one.
    if (from_zero && !locus.x.empty())
      spec.series.push_back(Series{"", {locus.x.front()}, {0.0}, cv::Scalar(255, 255, 255), false, false});
    return renderPlot(spec, kPanelWidth, kPanelHeight);
  };
  return grid2({panel("rms_error_m", 1000, "RMS error, fractal terrain", "RMS error (mm)", true),
                panel("coverage", 100, "coverage, fractal terrain", "coverage (%)", false)},
               2);
}

// Band centres for the x axis; the open last band is drawn 2 m past its lower edge.
double bandCentre(std::size_t b) {
  const double lo = kRangeBandEdgesM[b], hi = kRangeBandEdgesM[b + 1];
  return std::isinf(hi) ? lo + 2 : 0.5 * (lo + hi);
}

cv::Mat bandsPlot(const Results& tilt, const Results& res) {
  // The level plane at every noise level, and the fractal terrain's 10 cm maps.
  struct Line {
    std::string label;
    const Results* r;
    std::vector<std::size_t> group;
  };
  std::vector<Line> lines;
  for (const auto& g : tilt.groups())
    if (tiltLabel(tilt.scenario(g)) == "level")
      lines.push_back({"level plane, " + noiseLabel(tilt.scenario(g).sensor), &tilt, g});
  for (const auto& g : res.groups())
    if (std::abs(res.scenario(g).map->cell_m - 0.10) < 1e-9) lines.push_back({"fractal, 10 cm", &res, g});
  const auto panel = [&](const char* key, double scale, const std::string& title, const std::string& y_label,
                         bool log_y) {
    PlotSpec spec{title, "range to the true surface (m; band centres, >= 16 m at 18)", y_label, false, log_y, {}};
    for (std::size_t i = 0; i < lines.size(); ++i) {
      Series locus{"locus, " + lines[i].label, {}, {}, plotColour(int(i)), true, true};
      Series cart{"Cart., " + lines[i].label, {}, {}, plotColour(int(i)), false, true};
      for (std::size_t b = 0; b < kBands; ++b) {
        locus.x.push_back(bandCentre(b)), cart.x.push_back(bandCentre(b));
        locus.y.push_back(lines[i].r->stat(lines[i].group, band("map", b, key)).mean * scale);
        cart.y.push_back(lines[i].r->stat(lines[i].group, band("map_cartesian", b, key)).mean * scale);
      }
      spec.series.push_back(locus);
      spec.series.push_back(cart);
    }
    legendRoom(spec, 29);  // the band centres end at 18 m
    return renderPlot(spec, kPanelWidth, kPanelHeight);
  };
  return grid2({panel("rms_error_m", 1000, "RMS error by range band", "RMS error (mm)", true),
                panel("coverage", 100, "coverage by range band", "coverage (%)", false)},
               2);
}

}  // namespace

std::string runLocusVsCartesian(const ExperimentOptions& opt) {
  const auto start = std::chrono::steady_clock::now();
  // Both sweeps are read and validated before either runs.
  const Sweep tilt = experimentSweep(opt.sweeps / "tilt_noise.yaml", opt.quick);
  const Sweep res = experimentSweep(opt.sweeps / "resolution.yaml", opt.quick);
  const auto require = [](const Sweep& s, std::initializer_list<const char*> keys) {
    requireAxes(s, keys);
    for (const Scenario& sc : s.runs)
      if (!sc.map || sc.map->baseline != Baseline::Cartesian)
        throw SweepError(s.file.string() + ": the experiment needs map.baseline: cartesian in every run");
  };
  require(tilt, {"terrain.slope_deg", "sensor", "seed"});
  require(res, {"map.cell_m", "seed"});

  const Results tilt_results(tilt, runExperimentSweep(tilt, opt.out / "tilt_noise", opt));
  const Results res_results(res, runExperimentSweep(res, opt.out / "resolution", opt));

  const std::string md = report(tilt_results, res_results, opt.quick);
  writeText(opt.out / "table.md", md);
  writeFigure(opt.out / "tilt_noise.png", tiltPlot(tilt_results));
  writeFigure(opt.out / "resolution.png", resolutionPlot(res_results));
  writeFigure(opt.out / "range_bands.png", bandsPlot(tilt_results, res_results));
  if (opt.progress) {
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::fprintf(stderr, "ambler: experiment locus-vs-cartesian: %zu + %zu runs in %.1f s -> %s\n", tilt.runs.size(),
                 res.runs.size(), s, opt.out.string().c_str());
  }
  return md;
}

}  // namespace ambler::eval
