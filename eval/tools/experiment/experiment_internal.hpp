#pragma once
// Internal to eval/experiment*.cpp: what the experiments share — reading a sweep (or its --quick
// reduction), a results.csv grouped over seeds, number formatting for the markdown tables, and
// writing the figures. Not part of the eval library's interface. Defined in experiment.cpp.
#include <cstddef>
#include <filesystem>
#include <functional>
#include <initializer_list>
#include <limits>
#include <map>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "eval/pictures/plot.hpp"
#include "eval/tools/experiment/experiment.hpp"
#include "eval/tools/sweep/sweep.hpp"

namespace ambler::eval::experiment_detail {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The whole file; throws SweepError naming it when it cannot be opened.
std::string readFile(const std::filesystem::path& file);

// The sweep file as it is, or for --quick with only the first and last value of every axis and
// the first seed; still read by the sweep reader, so it is checked like any sweep.
Sweep experimentSweep(const std::filesystem::path& file, bool quick);

// Throws SweepError unless the sweep has an axis named by each of `keys`.
void requireAxes(const Sweep& sweep, std::initializer_list<const char*> keys);

// Runs the sweep into `dir` (results.csv and runs/<k>/) with the experiment's jobs, progress and custom methods.
std::filesystem::path runExperimentSweep(const Sweep& sweep, const std::filesystem::path& dir,
                                         const ExperimentOptions& options);

// The sweep files `files` of options.sweeps (each through experimentSweep: --quick reduces them),
// each with a seed axis and every run `usable`; else SweepError naming the file and saying "the
// experiment needs NEED in every run".
std::vector<Sweep> experimentSweeps(const ExperimentOptions& options, const std::vector<std::string>& files,
                                    const std::function<bool(const Scenario&)>& usable, const std::string& need);

// Writes out/table.md and returns `md`.
std::string writeTable(const ExperimentOptions& options, const std::string& md);

// Runs each sweep into out/dirs[i] (runExperimentSweep), then `report`, and returns its markdown;
// with progress on, prints "ambler: experiment NAME: N runs in T s -> OUT" on stderr.
std::string runSweepsAndReport(const std::vector<Sweep>& sweeps, const std::vector<std::string>& dirs,
                               const ExperimentOptions& options, const char* name,
                               const std::function<std::string()>& report);

struct Stat {
  double mean = kNaN, sd = kNaN;  // sd: sample standard deviation, NaN with fewer than two values
  int n = 0;                      // finite values
};

// One sweep's results.csv, its runs grouped by every axis but the seed.
class Results {
 public:
  // Throws SweepError when the file is not a results.csv of `sweep` (a row names no run of it).
  Results(const Sweep& sweep, const std::filesystem::path& csv);

  // Groups in run order; each is the runs of one combination of the axes other than the seed.
  const std::vector<std::vector<std::size_t>>& groups() const { return groups_; }
  const Scenario& scenario(std::size_t run) const { return sweep_.runs[run]; }
  const Scenario& scenario(const std::vector<std::size_t>& group) const { return sweep_.runs[group.front()]; }
  const Sweep& sweep() const { return sweep_; }

  // The cell of `column` in run k's row; "" when the run or the column is missing.
  std::string cell(std::size_t run, const std::string& column) const;
  bool hasColumn(const std::string& column) const { return column_.count(column) != 0; }
  // The cell as a number; NaN when empty or not a number.
  double value(std::size_t run, const std::string& column) const;
  // The finite values of `column` over the runs of a group, in run order.
  std::vector<double> values(const std::vector<std::size_t>& group, const std::string& column) const;

  Stat stat(const std::vector<std::size_t>& group, const std::string& column) const;
  // The run-by-run difference a − b over the runs where both are finite.
  Stat difference(const std::vector<std::size_t>& group, const std::string& a, const std::string& b) const;
  // The largest value over the runs of a group (NaN if none is finite).
  double largest(const std::vector<std::size_t>& group, const std::string& column) const;

 private:
  const Sweep& sweep_;
  std::map<std::string, std::size_t> column_;
  std::vector<std::vector<std::string>> rows_;
  std::vector<std::vector<std::size_t>> groups_;
};

// ---- labels and numbers

std::string format(const char* pattern, double v);
// As many decimals as a figure's size needs: 0.123, 1.23, 12.3, 123.
int decimalsFor(double v);
// `decimals` < 0: decimalsFor(v); "—" for NaN.
std::string number(double v, int decimals = -1);
// " text |": one more cell of a markdown row.
void appendCell(std::string& row, const std::string& text);

// ---- figures

constexpr int kPanelWidth = 800, kPanelHeight = 500;

// PNG at the highest compression, written atomically.
void writeFigure(const std::filesystem::path& path, const cv::Mat& image);
// An invisible point at x = `x_room` that leaves an empty strip on the right for the legend.
void legendRoom(PlotSpec& spec, double x_room);
// Panels of one size in rows of `cols`; the count must be a multiple of `cols`.
cv::Mat grid2(const std::vector<cv::Mat>& panels, int cols);

}  // namespace ambler::eval::experiment_detail
