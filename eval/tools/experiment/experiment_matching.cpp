// The matching experiment (§6, fig. 5): the basin sweep run through the sweep API, then a report
// that reads only its results.csv. Runs are laid on a grid of initial translation × initial
// rotation (the sweep's two initial_error axes); a cell holds the seeds. Everything is counts,
// medians and maxima of the rows, so the same results.csv gives the same bytes.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "eval/tools/experiment/experiment.hpp"
#include "eval/tools/experiment/experiment_internal.hpp"
#include "eval/scenario/io.hpp"
#include "eval/pictures/match_figures.hpp"
#include "eval/score/stats.hpp"

namespace ambler::eval {
namespace {

namespace fs = std::filesystem;
using namespace experiment_detail;

constexpr const char* kXyzAxis = "matching.initial_error.xyz_m";
constexpr const char* kRpyAxis = "matching.initial_error.rpy_deg";

std::string reg(std::size_t k, const char* key) { return "registration." + std::to_string(k) + "." + key; }

double maximum(const std::vector<double>& v) { return v.empty() ? kNaN : *std::max_element(v.begin(), v.end()); }

// An iteration count: "22", a median between two "22.5".
std::string count(double v) { return std::isfinite(v) ? format("%g", v) : "—"; }

double toDeg(double rad) { return rad * 180.0 / M_PI; }

// "10°" for a yaw alone, else "(roll, pitch, yaw)°"; `deg` is the degree sign (the plots' font
// has none).
std::string rotationLabel(const ViewSpec& e, const char* deg) {
  const Eigen::Vector3d r = e.rpy_rad.unaryExpr([](double a) { return toDeg(a); });
  if (std::abs(r.x()) < 1e-9 && std::abs(r.y()) < 1e-9) return format("%g", r.z()) + deg;
  return format("(%g, ", r.x()) + format("%g, ", r.y()) + format("%g)", r.z()) + deg;
}
std::string translationLabel(const ViewSpec& e) { return format("%g m", e.xyz_m.norm()); }

// The basin sweep's results on the grid: rows the values of the translation axis, columns those of
// the rotation axis, in the sweep's order; methods by their index in metrics.registration.
class Basin {
 public:
  explicit Basin(const Results& r) : r_(r) {
    const Sweep& s = r.sweep();
    for (std::size_t a = 0; a < s.axes.size(); ++a) {
      if (s.axes[a].key == kXyzAxis) xyz_axis_ = a;
      else if (s.axes[a].key == kRpyAxis) rpy_axis_ = a;
      else if (s.axes[a].key != "seed" && s.axes[a].values.size() > 1)
        throw SweepError(s.file.string() + ": axes." + s.axes[a].key +
                         ": the matching report's grid has the initial error's two axes and the seed only");
    }
    rows_ = s.axes[xyz_axis_].values.size(), cols_ = s.axes[rpy_axis_].values.size();
    // Each value's initial error, from the first run of the sweep that has it.
    row_error_.resize(rows_), col_error_.resize(cols_);
    for (std::size_t k = s.runs.size(); k-- > 0;) {
      const auto c = s.combination(k);
      row_error_[c[xyz_axis_]] = col_error_[c[rpy_axis_]] = s.runs[k].matching->initial_error;
    }
    cells_.assign(rows_ * cols_, {});
    for (const auto& g : r.groups()) {
      const auto c = s.combination(g.front());  // the group's runs differ only in their seed
      cells_[c[xyz_axis_] * cols_ + c[rpy_axis_]] = g;
      all_.insert(all_.end(), g.begin(), g.end());
    }
    std::sort(all_.begin(), all_.end());
    if (all_.empty()) throw SweepError(s.file.string() + ": the results have no runs");
    for (std::size_t k = 0; r.hasColumn(reg(k, "method")); ++k) {
      const std::string name = r.cell(all_.front(), reg(k, "method"));
      for (const std::size_t run : all_)
        if (r.cell(run, reg(k, "method")) != name)
          throw SweepError(s.file.string() + ": run " + std::to_string(run) + " registers with " +
                           r.cell(run, reg(k, "method")) + " where run " + std::to_string(all_.front()) +
                           " has " + name + ": the methods must be the same in every run");
      methods_.push_back(name);
    }
    if (methods_.empty()) throw SweepError(s.file.string() + ": the runs have no registration (matching.methods)");
  }

  std::size_t rows() const { return rows_; }
  std::size_t cols() const { return cols_; }
  const std::vector<std::string>& methods() const { return methods_; }
  const std::vector<std::size_t>& cell(std::size_t row, std::size_t col) const { return cells_[row * cols_ + col]; }
  const std::vector<std::size_t>& all() const { return all_; }
  const Results& results() const { return r_; }

  std::string rowLabel(std::size_t row) const { return translationLabel(row_error_[row]); }
  std::string colLabel(std::size_t col, const char* deg) const { return rotationLabel(col_error_[col], deg); }

  int successes(std::size_t method, const std::vector<std::size_t>& runs) const {
    return int(std::count_if(runs.begin(), runs.end(),
                             [&](std::size_t k) { return r_.cell(k, reg(method, "success")) == "true"; }));
  }
  std::vector<double> values(std::size_t method, const std::vector<std::size_t>& runs, const char* key) const {
    return r_.values(runs, reg(method, key));
  }
  std::vector<std::size_t> successful(std::size_t method, const std::vector<std::size_t>& runs) const {
    std::vector<std::size_t> out;
    for (const std::size_t k : runs)
      if (r_.cell(k, reg(method, "success")) == "true") out.push_back(k);
    return out;
  }

  // The cell of the largest initial error, the paper's fig. 5 case in the basin sweep (2 m, 30°).
  std::pair<std::size_t, std::size_t> worstCase() const {
    std::size_t row = 0, col = 0;
    for (std::size_t i = 0; i < rows_; ++i)
      if (row_error_[i].xyz_m.norm() > row_error_[row].xyz_m.norm()) row = i;
    for (std::size_t j = 0; j < cols_; ++j)
      if (col_error_[j].rpy_rad.norm() > col_error_[col].rpy_rad.norm()) col = j;
    return {row, col};
  }

 private:

  const Results& r_;
  std::size_t xyz_axis_ = 0, rpy_axis_ = 0, rows_ = 0, cols_ = 0;
  std::vector<ViewSpec> row_error_, col_error_;
  std::vector<std::vector<std::size_t>> cells_;
  std::vector<std::size_t> all_;
  std::vector<std::string> methods_;
};

// ---- tables -------------------------------------------------------------------------------------

std::string rule(std::size_t left, std::size_t right) {
  std::string out = "|";
  for (std::size_t i = 0; i < left; ++i) out += "---|";
  for (std::size_t i = 0; i < right; ++i) out += "---:|";
  return out + "\n";
}

// Per method: successes out of the seeds, median translation and rotation error, per cell.
std::string gridTable(const Basin& b, std::size_t m) {
  std::string out = "| initial translation \\ rotation |";
  for (std::size_t j = 0; j < b.cols(); ++j) appendCell(out, b.colLabel(j, "°"));
  out += "\n" + rule(1, b.cols());
  for (std::size_t i = 0; i < b.rows(); ++i) {
    out += "| " + b.rowLabel(i) + " |";
    for (std::size_t j = 0; j < b.cols(); ++j) {
      const auto& runs = b.cell(i, j);
      if (runs.empty()) {
        appendCell(out, "—");
        continue;
      }
      const int ok = b.successes(m, runs);
      const std::string n = std::to_string(ok) + "/" + std::to_string(runs.size());
      appendCell(out, (ok == int(runs.size()) ? "**" + n + "**" : n) + " · " +
                          number(100 * median(b.values(m, runs, "translation_error_m"))) + " cm · " +
                          number(median(b.values(m, runs, "rotation_error_deg"))) + "°");
    }
    out += "\n";
  }
  return out;
}

std::string summaryTable(const Basin& b) {
  std::string out =
      "| method | success | translation error median / max, cm | rotation error median / max, ° | "
      "iterations median / max | iterations median, successful runs |\n" +
      rule(1, 5);
  const auto& all = b.all();
  for (std::size_t m = 0; m < b.methods().size(); ++m) {
    const int ok = b.successes(m, all);
    const auto t = b.values(m, all, "translation_error_m"), r = b.values(m, all, "rotation_error_deg");
    const auto it = b.values(m, all, "iterations");
    const auto it_ok = b.values(m, b.successful(m, all), "iterations");
    std::string row = "| " + b.methods()[m] + " |";
    for (const std::string& c :
         {std::to_string(ok) + "/" + std::to_string(all.size()) + format(" (%.0f %%)", 100.0 * ok / double(all.size())),
          number(100 * median(t)) + " / " + number(100 * maximum(t)), number(median(r)) + " / " + number(maximum(r)),
          count(median(it)) + " / " + count(maximum(it)), count(median(it_ok))})
      appendCell(row, c);
    out += row + "\n";
  }
  return out;
}

std::string caseTable(const Basin& b, std::size_t row, std::size_t col) {
  const Results& r = b.results();
  std::string out = "| method | seed | translation error, cm | rotation error, ° | iterations | success |\n" + rule(2, 4);
  for (std::size_t m = 0; m < b.methods().size(); ++m)
    for (const std::size_t k : b.cell(row, col)) {
      std::string line = "| " + b.methods()[m] + " |";
      const bool ok = r.cell(k, reg(m, "success")) == "true";
      for (const std::string& c : {std::to_string(r.scenario(k).seed),
                                   number(100 * r.value(k, reg(m, "translation_error_m"))),
                                   number(r.value(k, reg(m, "rotation_error_deg"))),
                                   count(r.value(k, reg(m, "iterations"))), std::string(ok ? "yes" : "**no**")})
        appendCell(line, c);
      out += line + "\n";
    }
  return out;
}

std::string report(const Basin& b, bool quick) {
  const Results& r = b.results();
  const MatchingSpec& spec = *r.scenario(b.all().front()).matching;
  const std::string bound = format("%g cm", 100 * spec.success_translation_m) +
                            format(" and %g°", spec.success_rotation_deg);
  std::string md = "<!-- written by `ambler experiment matching" + std::string(quick ? " --quick" : "") +
                   "` from basin/results.csv -->\n\n";
  md += "Every run registers view 1 against view 0 with each method, starting from the rover's belief, off "
        "the true pose by the run's initial error E (in sensor 1's frame: T_0 = T·E). A run succeeds when the "
        "estimate is within " +
        bound +
        " of the truth (the scenario's matching.success). Errors are those of the final estimate; "
        "iterations are the iconic stage's (features alone has none).\n\n";
  for (std::size_t m = 0; m < b.methods().size(); ++m)
    md += "### Success by initial error: " + b.methods()[m] +
          "\n\nSuccesses out of the seeds (bold: all), then the median over the seeds of the translation and "
          "rotation error.\n\n" +
          gridTable(b, m) + "\n";
  md += "### Over all runs\n\n" + summaryTable(b);
  const auto [row, col] = b.worstCase();
  md += "\n### The largest initial error (" + b.rowLabel(row) + ", " + b.colLabel(col, "°") + ") per seed\n\n" +
        caseTable(b, row, col);
  return md;
}

// ---- the plot: one panel per method, a cell per initial error coloured by its success fraction --

cv::Mat basinPanel(const Basin& b, std::size_t m) {
  SuccessGrid g;
  g.title = b.methods()[m];
  g.subtitle = "successes / seeds, median translation error";
  g.row_axis = "initial translation";
  g.col_axis = "initial rotation";
  for (std::size_t i = 0; i < b.rows(); ++i) g.row_labels.push_back(b.rowLabel(i));
  for (std::size_t j = 0; j < b.cols(); ++j) g.col_labels.push_back(b.colLabel(j, " deg"));
  for (std::size_t i = 0; i < b.rows(); ++i)
    for (std::size_t j = 0; j < b.cols(); ++j) {
      const auto& runs = b.cell(i, j);
      g.successes.push_back(runs.empty() ? 0 : b.successes(m, runs));
      g.trials.push_back(int(runs.size()));
      g.notes.push_back(runs.empty() ? "" : number(100 * median(b.values(m, runs, "translation_error_m"))) + " cm");
    }
  return successHeatmap(g);
}

cv::Mat basinPlot(const Basin& b) {
  std::vector<cv::Mat> panels;
  for (std::size_t m = 0; m < b.methods().size(); ++m) panels.push_back(basinPanel(b, m));
  const int cols = panels.size() > 1 ? 2 : 1;
  while (panels.size() % std::size_t(cols)) panels.emplace_back(panels.front().size(), CV_8UC3, cv::Scalar(255, 255, 255));
  return grid2(panels, cols);
}

Sweep basinSweep(const ExperimentOptions& opt) {
  const Sweep s = experimentSweep(opt.sweeps / "matching_basin.yaml", opt.quick);
  requireAxes(s, {kXyzAxis, kRpyAxis, "seed"});
  for (const Scenario& sc : s.runs)
    if (!sc.matching || sc.matching->methods.empty())
      throw SweepError(s.file.string() + ": the experiment needs a matching section with methods in every run");
  return s;
}

std::string writeReport(const Sweep& sweep, const ExperimentOptions& opt) {
  const Results results(sweep, opt.out / "basin" / "results.csv");
  const Basin basin(results);
  const std::string md = report(basin, opt.quick);
  writeText(opt.out / "table.md", md);
  writeFigure(opt.out / "basin.png", basinPlot(basin));
  return md;
}

}  // namespace

std::string runMatching(const ExperimentOptions& opt) {
  const auto start = std::chrono::steady_clock::now();
  const Sweep sweep = basinSweep(opt);
  runExperimentSweep(sweep, opt.out / "basin", opt);
  const std::string md = writeReport(sweep, opt);
  if (opt.progress) {
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::fprintf(stderr, "ambler: experiment matching: %zu runs in %.1f s -> %s\n", sweep.runs.size(), s,
                 opt.out.string().c_str());
  }
  return md;
}

std::string reportMatching(const ExperimentOptions& opt) { return writeReport(basinSweep(opt), opt); }

}  // namespace ambler::eval
