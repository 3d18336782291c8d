#pragma once
// What the run, sweep and basin reports share (eval/tools/report/report.cpp, eval/tools/report/report_sweep.cpp): the page
// frame and its style, tables, embedded pictures and the goals the docs state.
#include <filesystem>
#include <limits>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

namespace ambler::eval::report_detail {

using Json = nlohmann::ordered_json;

std::string readFile(const std::filesystem::path& path);

// Numbers in text order: "view_2" before "view_10".
bool naturalLess(const std::string& a, const std::string& b);

// "%.4g"; an em dash for a non-finite number.
std::string g4(double v);

struct Table {
  std::string caption;
  std::string corner = "metric";                                       // the first column's heading
  std::string css_class;                                               // "text": cells left-aligned
  std::vector<std::string> columns;                                    // entry labels
  std::vector<std::pair<std::string, std::vector<std::string>>> rows;  // name, one cell per column (HTML)
};
std::string tableHtml(const Table& t);

// <figure> with the PNG at `path` embedded as a data URI, captioned `caption`.
std::string figureHtml(const std::filesystem::path& path, const std::string& caption);
// The same for PNG bytes in memory.
std::string figureBytesHtml(const std::string& png, const std::string& caption);

// <!DOCTYPE html> … <body><h1>title</h1>, and the end of the page.
std::string pageHead(const std::string& title);
std::string pageTail();

// A directory's name as the heading shows it (no absolute paths in a report).
std::string shownName(const std::filesystem::path& dir);

// One goal the docs state for a metric (docs/report.md, "Goals"): passes iff lo ≤ value ≤ hi.
struct Goal {
  const char* section;  // the metrics.json key: "composite", "footfall"
  const char* metric;   // the scalar in each of its entries, dotted: "leg.tilt_deg"
  double lo, hi;
  const char* goal;     // as shown: "≤ 0.03 m (3 cm)"
  const char* doc;      // where the docs state it
};
const std::vector<Goal>& goals();

// The goals table of a run: one row per goal metric the run has (and per registration, the
// scenario's matching.success), value, goal, pass or fail. Empty when the run has none.
Table runGoalsTable(const Json& metrics, const std::string& scenario_yaml);

}  // namespace ambler::eval::report_detail
