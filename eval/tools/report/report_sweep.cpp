// `ambler report` of a sweep directory (results.csv, sweep.resolved.yaml, runs/) and of a basin
// directory (basin.csv, basin.md, the heatmaps, pair/): docs/report.md.
#include <tbb/parallel_for.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <map>
#include <optional>
#include <set>
#include <tuple>
#include <stdexcept>

#include "eval/scenario/io.hpp"
#include "eval/pictures/plot.hpp"
#include "eval/tools/report/report.hpp"
#include "eval/tools/report/report_internal.hpp"
#include "eval/score/stats.hpp"
#include "eval/tools/sweep/sweep.hpp"

namespace ambler::eval {
namespace {

namespace fs = std::filesystem;
using namespace report_detail;
using Rows = std::vector<std::vector<std::string>>;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::optional<double> number(const std::string& cell) {
  if (cell == "true") return 1.0;
  if (cell == "false") return 0.0;
  double v = 0;
  const auto r = std::from_chars(cell.data(), cell.data() + cell.size(), v);
  if (cell.empty() || r.ec != std::errc() || r.ptr != cell.data() + cell.size()) return std::nullopt;
  return v;
}

Rows readCsv(const fs::path& file, const std::string& what, const std::vector<std::string>& head) {
  const auto rows = parseResultsCsv(readFile(file));
  if (!rows || rows->empty() || rows->front().size() < head.size() ||
      !std::equal(head.begin(), head.end(), rows->front().begin()))
    throw std::runtime_error(file.string() + ": not " + what + " (expected a CSV header starting with " +
                             [&] {
                               std::string h;
                               for (const auto& c : head) h += (h.empty() ? "" : ",") + c;
                               return h;
                             }() +
                             ")");
  for (std::size_t r = 1; r < rows->size(); ++r)
    if ((*rows)[r].size() != rows->front().size())
      throw std::runtime_error(file.string() + ": row " + std::to_string(r) + " has " +
                               std::to_string((*rows)[r].size()) + " cells, the header " +
                               std::to_string(rows->front().size()));
  return *rows;
}

// ---- sweeps ---------------------------------------------------------------------------------

// The axis columns of results.csv: those sweep.resolved.yaml names, or, for a sweep directory
// written before it existed, the columns before the first that names a metrics.json section.
std::size_t axisCount(const std::vector<std::string>& header, const std::string& spec_text) {
  if (!spec_text.empty()) {
    try {
      const YAML::Node axes = YAML::Load(spec_text)["axes"];
      if (axes && axes.IsMap()) return std::min(header.size() - 1, std::size_t(axes.size()));
    } catch (const YAML::Exception&) {
    }
  }
  static const std::set<std::string> kSections{"name",         "scan",     "map",      "map_cartesian",
                                               "composite",    "footfall", "timing_s", "registration"};
  std::size_t n = 0;
  for (std::size_t c = 1; c < header.size(); ++c, ++n) {
    const std::string first = header[c].substr(0, header[c].find('.'));
    const std::size_t dot = header[c].find('.');
    const bool indexed = dot != std::string::npos && dot + 1 < header[c].size() &&
                         std::isdigit(static_cast<unsigned char>(header[c][dot + 1]));
    if (first == "name" || first == "timing_s" || first == "composite" || (kSections.count(first) && indexed)) break;
  }
  return n;
}

// The goal a results.csv column is a run's metric of: "composite.rms_error_m",
// "footfall.2.leg.tilt_deg" (any entry index).
const Goal* goalOf(const std::string& column) {
  for (const Goal& g : goals()) {
    const std::string section = std::string(g.section) + ".", metric = std::string(".") + g.metric;
    if (column == section + g.metric) return &g;
    if (column.starts_with(section) && column.ends_with(metric)) {
      const std::string mid = column.substr(section.size(), column.size() - section.size() - metric.size());
      if (!mid.empty() && std::all_of(mid.begin(), mid.end(), [](char c) { return std::isdigit(static_cast<unsigned char>(c)); }))
        return &g;
    }
  }
  return nullptr;
}

struct Plot {
  std::string caption;
  PlotSpec spec;
  std::string png;
};

}  // namespace

namespace {

// A results.csv column of numbers (true/false count as 1/0): its value per run, NaN where empty.
struct Metric {
  std::size_t column;
  std::vector<double> v;
  bool varies = false;
};
// An axis with more than one value, its values in sweep order (first appearance in run order).
struct Axis {
  std::size_t column;
  std::vector<std::string> values;
  bool numeric = true;
  std::vector<std::size_t> of_run;  // the index of each run's value
};

// The metric columns (after the axes): a column is numeric when every non-empty cell is a number;
// one never written is left out; constant ones are tabled but not plotted.
std::vector<Metric> sweepMetrics(const Rows& rows, std::size_t n_axes) {
  const std::vector<std::string>& header = rows.front();
  std::vector<Metric> metrics;
  for (std::size_t c = 1 + n_axes; c < header.size(); ++c) {
    Metric m{c, {}, false};
    bool numeric = true;
    for (std::size_t r = 1; r < rows.size() && numeric; ++r) {
      const auto v = number(rows[r][c]);
      numeric = v || rows[r][c].empty();
      m.v.push_back(v ? *v : kNaN);
    }
    if (!numeric) continue;
    double lo = HUGE_VAL, hi = -HUGE_VAL;
    for (double x : m.v)
      if (std::isfinite(x)) lo = std::min(lo, x), hi = std::max(hi, x);
    if (lo > hi) continue;  // never written
    m.varies = hi > lo;
    metrics.push_back(std::move(m));
  }
  return metrics;
}

// The axis columns with more than one value; a seed axis replicates the others (its runs are the
// spread at each value of the other axes), so it is left out unless it is the only one that varies.
std::vector<Axis> sweepAxes(const Rows& rows, std::size_t n_axes) {
  const std::vector<std::string>& header = rows.front();
  std::vector<Axis> axes;
  for (std::size_t c = 1; c <= n_axes; ++c) {
    Axis a{c, {}, true, {}};
    std::map<std::string, std::size_t> index;
    for (std::size_t r = 1; r < rows.size(); ++r) {
      const auto [it, added] = index.emplace(rows[r][c], a.values.size());
      if (added) a.values.push_back(rows[r][c]);
      a.of_run.push_back(it->second);
    }
    for (const auto& v : a.values) a.numeric = a.numeric && number(v) && std::isfinite(*number(v));
    if (a.values.size() > 1) axes.push_back(std::move(a));
  }
  // A seed axis replicates the others: its runs are the spread at each value of the other axes,
  // not a quantity to plot against, unless it is the only axis that varies.
  if (axes.size() > 1)
    axes.erase(std::remove_if(axes.begin(), axes.end(), [&](const Axis& a) { return header[a.column] == "seed"; }),
               axes.end());
  return axes;
}

// Each varying metric against each axis: at each value of the axis, the median, the least and the
// greatest over the runs with that value.
std::vector<Plot> sweepPlots(const std::vector<std::string>& header, const std::vector<Metric>& metrics,
                             const std::vector<Axis>& axes, std::size_t n_runs) {
  std::vector<Plot> plots;
  for (const Metric& m : metrics) {
    if (!m.varies) continue;
    for (const Axis& a : axes) {
      Plot p;
      PlotSpec& s = p.spec;
      s.title = header[m.column] + " against " + header[a.column];
      s.y_label = header[m.column];
      s.x_label = header[a.column];
      if (!a.numeric) {
        s.x_label += " (value index:";
        for (std::size_t i = 0; i < a.values.size(); ++i) s.x_label += " " + std::to_string(i) + " = " + a.values[i];
        s.x_label += ")";
        if (s.x_label.size() > 110) s.x_label = s.x_label.substr(0, 107) + "...";
      }
      Series med{"median", {}, {}, plotColour(0), true, true}, lo{"least", {}, {}, plotColour(7), false, true},
          hi{"greatest", {}, {}, plotColour(3), false, true};
      double x_min = HUGE_VAL, x_max = -HUGE_VAL, y_min = HUGE_VAL, y_max = -HUGE_VAL;
      std::size_t per_value = 0;
      std::vector<std::vector<double>> at_value(a.values.size());
      for (std::size_t r = 0; r < n_runs; ++r)
        if (std::isfinite(m.v[r])) at_value[a.of_run[r]].push_back(m.v[r]);
      for (std::size_t i = 0; i < a.values.size(); ++i) {
        const std::vector<double>& at = at_value[i];
        per_value = std::max(per_value, at.size());
        const double x = a.numeric ? *number(a.values[i]) : double(i);
        x_min = std::min(x_min, x), x_max = std::max(x_max, x);
        med.x.push_back(x), lo.x.push_back(x), hi.x.push_back(x);
        med.y.push_back(median(at));
        lo.y.push_back(at.empty() ? kNaN : *std::min_element(at.begin(), at.end()));
        hi.y.push_back(at.empty() ? kNaN : *std::max_element(at.begin(), at.end()));
        for (double y : at) y_min = std::min(y_min, y), y_max = std::max(y_max, y);
      }
      s.log_x = a.numeric && x_min > 0 && x_max >= 100 * x_min;
      s.log_y = y_min > 0 && y_max >= 100 * y_min;
      s.series = {med};
      if (per_value > 1) s.series.push_back(lo), s.series.push_back(hi);
      p.caption = header[m.column] + " against " + header[a.column] +
                  (per_value > 1 ? ": median, least and greatest over the runs at each value" : ": one run at each value");
      plots.push_back(std::move(p));
    }
  }
  return plots;
}

// The runs meeting the goals the docs state, per column that has one.
Table goalsTable(const std::vector<std::string>& header, const std::vector<Metric>& metrics) {
  Table goals_table;
  goals_table.caption = "runs meeting the goals the docs state";
  goals_table.corner = "column";
  goals_table.css_class = "text";
  goals_table.columns = {"runs passing", "goal", "stated in"};
  for (const Metric& m : metrics) {
    const std::string& col = header[m.column];
    std::size_t pass = 0, n = 0;
    std::string goal, doc;
    if (const Goal* g = goalOf(col)) {
      for (double v : m.v)
        if (std::isfinite(v)) ++n, pass += v >= g->lo && v <= g->hi;
      goal = g->goal, doc = g->doc;
    } else if (col.starts_with("registration.") && col.ends_with(".success")) {
      for (double v : m.v)
        if (std::isfinite(v)) ++n, pass += v == 1.0;
      goal = "success (the scenario's matching.success)", doc = "docs/matching.md";
    } else {
      continue;
    }
    goals_table.rows.push_back({col, {std::to_string(pass) + " of " + std::to_string(n), htmlEscape(goal), doc}});
  }

  return goals_table;
}

// The ten runs with the largest `worst_by`, linked to their directories and reports where kept.
std::string worstRunsHtml(const fs::path& dir, const fs::path& html_dir, const Rows& rows, std::size_t n_axes,
                          std::size_t worst_by) {
  const std::vector<std::string>& header = rows.front();
  std::error_code ec;
  std::string html;
  std::vector<std::size_t> order;
  for (std::size_t r = 1; r < rows.size(); ++r)
    if (number(rows[r][worst_by])) order.push_back(r);
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return *number(rows[a][worst_by]) > *number(rows[b][worst_by]); });
  if (order.size() > 10) order.resize(10);
  Table t;
  t.caption = "the " + std::to_string(order.size()) + " runs with the largest " + header[worst_by];
  t.corner = "run";
  for (std::size_t c = 1; c <= n_axes; ++c) t.columns.push_back(header[c]);
  t.columns.push_back(header[worst_by]);
  t.columns.push_back("report");
  for (const std::size_t r : order) {
    const std::string& run = rows[r][0];
    std::vector<std::string> cells;
    for (std::size_t c = 1; c <= n_axes; ++c) cells.push_back(htmlEscape(rows[r][c]));
    cells.push_back(g4(*number(rows[r][worst_by])));
    const fs::path run_dir = dir / "runs" / run;
    const auto link = [&](const fs::path& target) {
      return fs::absolute(target).lexically_normal().lexically_relative(fs::absolute(html_dir).lexically_normal())
          .generic_string();
    };
    cells.push_back(fs::is_regular_file(run_dir / "report.html", ec)
                        ? "<a href=\"" + htmlEscape(link(run_dir / "report.html")) + "\">report.html</a>"
                        : "\xE2\x80\x94");
    const std::string shown = fs::is_directory(run_dir, ec)
                                  ? "<a href=\"" + htmlEscape(link(run_dir)) + "/\">" + htmlEscape(run) + "</a>"
                                  : htmlEscape(run);
    t.rows.push_back({run, cells});
    t.rows.back().first = shown;  // the row heading is HTML here (a link), escaped above
  }
  html += "<h2 id=\"worst\">Worst runs</h2>\n<p>By <code>" + htmlEscape(header[worst_by]) +
          "</code> (largest first). A run links to its directory when the sweep kept it (<code>--keep "
          "metrics</code> or <code>all</code>), and to its report when one was written there.</p>\n";
  // tableHtml escapes row headings; the links are built here instead.
  std::string h = "<table>\n<caption>" + htmlEscape(t.caption) + "</caption>\n<tr><th>run</th>";
  for (const auto& c : t.columns) h += "<th>" + htmlEscape(c) + "</th>";
  h += "</tr>\n";
  for (const auto& [head, cells] : t.rows) {
    h += "<tr><th>" + head + "</th>";
    for (const auto& c : cells) h += "<td>" + c + "</td>";
    h += "</tr>\n";
  }
  html += h + "</table>\n";
  return html;
}

// Least, median and greatest of each numeric metric over the runs.
std::string metricsSummaryHtml(const std::vector<std::string>& header, const std::vector<Metric>& metrics) {
  Table t;
  t.caption = "each numeric metric over the runs";
  t.columns = {"least", "median", "greatest", "runs with a value"};
  for (const Metric& m : metrics) {
    std::vector<double> v;
    for (double x : m.v)
      if (std::isfinite(x)) v.push_back(x);
    t.rows.push_back({header[m.column],
                      {g4(*std::min_element(v.begin(), v.end())), g4(median(v)),
                       g4(*std::max_element(v.begin(), v.end())), std::to_string(v.size())}});
  }
  return "<h2 id=\"metrics\">Metrics</h2>\n" + tableHtml(t);
}

}  // namespace

std::string sweepReportHtml(const fs::path& dir, const fs::path& html_dir) {
  const fs::path csv = dir / "results.csv";
  const Rows rows = readCsv(csv, "a sweep's results table", {"run"});
  const std::vector<std::string>& header = rows.front();
  std::error_code ec;
  std::string spec_text;
  if (fs::is_regular_file(dir / "sweep.resolved.yaml", ec)) spec_text = readFile(dir / "sweep.resolved.yaml");
  const std::size_t n_axes = axisCount(header, spec_text);
  const std::size_t n_runs = rows.size() - 1;

  std::string name = shownName(dir);
  try {
    if (!spec_text.empty()) name = YAML::Load(spec_text)["name"].as<std::string>();
  } catch (const YAML::Exception&) {
  }
  const std::string title = "ambler sweep report: " + name;

  const std::vector<Metric> metrics = sweepMetrics(rows, n_axes);
  const std::vector<Axis> axes = sweepAxes(rows, n_axes);
  std::vector<Plot> plots = sweepPlots(header, metrics, axes, n_runs);
  // gnuplot runs in parallel (renderPlot is thread-safe); each plot's bytes depend on its spec alone.
  tbb::parallel_for(std::size_t(0), plots.size(), [&](std::size_t i) { plots[i].png = compactPngBytes(renderPlot(plots[i].spec, 640, 400)); });

  std::string html = pageHead(title) + "<p>Sweep directory <code>" + htmlEscape(shownName(dir)) + "</code>: " +
                     std::to_string(n_runs) + (n_runs == 1 ? " run" : " runs") + ", " + std::to_string(n_axes) +
                     (n_axes == 1 ? " axis" : " axes") + ", " + std::to_string(header.size() - 1 - n_axes) +
                     " metric columns in <code>results.csv</code> (numbers to 4 significant digits).</p>\n<nav>";
  // The worst runs: by the locus map's RMS error of view 0, else the first RMS error column.
  std::optional<std::size_t> worst_by;
  for (const Metric& m : metrics)
    if (header[m.column] == "map.0.rms_error_m") worst_by = m.column;
  for (const Metric& m : metrics)
    if (!worst_by && header[m.column].ends_with("rms_error_m")) worst_by = m.column;

  const Table goals_table = goalsTable(header, metrics);
  if (!spec_text.empty()) html += "<a href=\"#sweep\">Sweep</a>";
  if (!goals_table.rows.empty()) html += "<a href=\"#goals\">Goals</a>";
  if (!plots.empty()) html += "<a href=\"#plots\">Plots</a>";
  if (worst_by) html += "<a href=\"#worst\">Worst runs</a>";
  if (!metrics.empty()) html += "<a href=\"#metrics\">Metrics</a>";
  html += "</nav>\n";
  if (!spec_text.empty()) html += "<h2 id=\"sweep\">Sweep</h2>\n<pre>" + htmlEscape(spec_text) + "</pre>\n";
  if (!goals_table.rows.empty())
    html += "<h2 id=\"goals\">Goals</h2>\n<p>Per results.csv column with a goal the docs state, the runs "
            "that meet it (docs/report.md, \"Goals\").</p>\n" + tableHtml(goals_table);
  if (!plots.empty()) {
    html += "<h2 id=\"plots\">Plots</h2>\n<p>Each metric that varies against each axis with more than one value "
            "(drawn by gnuplot); a seed axis is not plotted against when another axis varies: its runs are the "
            "spread. Where several runs share an axis value (the other axes vary), the line with "
            "dots is their median and the two other lines their least and greatest value.</p>\n";
    for (const Plot& p : plots) html += figureBytesHtml(p.png, p.caption);
  }
  if (worst_by) html += worstRunsHtml(dir, html_dir, rows, n_axes, *worst_by);
  if (!metrics.empty()) html += metricsSummaryHtml(header, metrics);
  return html + pageTail();
}

// ---- basins ---------------------------------------------------------------------------------

namespace {

// basin.md's text as HTML: its tables as tables, other lines as paragraphs (no comments).
std::string markdownHtml(const std::string& md) {
  std::string html, para;
  std::vector<std::vector<std::string>> table;
  const auto flushPara = [&] {
    if (!para.empty()) html += "<p>" + htmlEscape(para) + "</p>\n";
    para.clear();
  };
  const auto flushTable = [&] {
    if (table.empty()) return;
    html += "<table>\n";
    for (std::size_t r = 0; r < table.size(); ++r) {
      html += "<tr>";
      for (const auto& c : table[r]) html += (r ? "<td>" : "<th>") + htmlEscape(c) + (r ? "</td>" : "</th>");
      html += "</tr>\n";
    }
    html += "</table>\n";
    table.clear();
  };
  std::size_t from = 0;
  while (from < md.size()) {
    std::size_t nl = md.find('\n', from);
    if (nl == std::string::npos) nl = md.size();
    std::string line = md.substr(from, nl - from);
    from = nl + 1;
    if (line.starts_with("<!--")) continue;
    if (line.starts_with("|")) {
      flushPara();
      if (line.find_first_not_of("|-: ") == std::string::npos) continue;  // the separator row
      std::vector<std::string> cells;
      std::size_t a = 1;
      for (std::size_t b; (b = line.find('|', a)) != std::string::npos; a = b + 1) {
        std::string c = line.substr(a, b - a);
        c.erase(0, c.find_first_not_of(' '));
        c.erase(c.find_last_not_of(' ') + 1);
        cells.push_back(c);
      }
      table.push_back(cells);
      continue;
    }
    flushTable();
    while (line.starts_with("#")) line.erase(0, 1);
    if (line.find_first_not_of(' ') == std::string::npos) flushPara();
    else para += (para.empty() ? "" : " ") + line.substr(line.find_first_not_of(' '));
  }
  flushPara();
  flushTable();
  return html;
}

}  // namespace

std::string basinReportHtml(const fs::path& dir) {
  const fs::path csv = dir / "basin.csv";
  const Rows rows = readCsv(csv, "a basin table", {"method", "translation_m", "rotation_deg", "trial", "translation_error_m",
                                                   "rotation_error_deg", "success"});
  std::error_code ec;
  // Methods in file order, the grid's translations and rotations in increasing order.
  std::vector<std::string> methods;
  std::set<double> ts, rs;
  std::map<std::tuple<std::string, double, double>, std::pair<int, int>> cells;  // successes, trials
  for (std::size_t r = 1; r < rows.size(); ++r) {
    const auto t = number(rows[r][1]), rot = number(rows[r][2]);
    if (!t || !rot)
      throw std::runtime_error(csv.string() + ": row " + std::to_string(r) + ": translation_m and rotation_deg must be numbers");
    if (std::find(methods.begin(), methods.end(), rows[r][0]) == methods.end()) methods.push_back(rows[r][0]);
    ts.insert(*t), rs.insert(*rot);
    auto& c = cells[{rows[r][0], *t, *rot}];
    c.first += rows[r][6] == "1" || rows[r][6] == "true";
    ++c.second;
  }
  const std::string name = shownName(dir);
  std::string scenario_text;
  if (fs::is_regular_file(dir / "pair" / "scenario.resolved.yaml", ec))
    scenario_text = readFile(dir / "pair" / "scenario.resolved.yaml");
  std::string summary;
  if (fs::is_regular_file(dir / "basin.md", ec)) summary = readFile(dir / "basin.md");

  std::vector<std::string> figures, pair_figures;  // paths under dir
  for (const auto& e : fs::directory_iterator(dir))
    if (e.is_regular_file() && e.path().extension() == ".png") figures.push_back(e.path().filename().string());
  if (fs::is_directory(dir / "pair", ec))
    for (auto it = fs::recursive_directory_iterator(dir / "pair"); it != fs::recursive_directory_iterator(); ++it)
      if (it->is_regular_file() && it->path().extension() == ".png")
        pair_figures.push_back(fs::relative(it->path(), dir).generic_string());
  // The boundary plot first, then the methods' heatmaps.
  std::sort(figures.begin(), figures.end(), [](const std::string& a, const std::string& b) {
    const bool ba = a == "basin_boundary.png", bb = b == "basin_boundary.png";
    return ba != bb ? ba : naturalLess(a, b);
  });
  std::sort(pair_figures.begin(), pair_figures.end(), naturalLess);

  std::string html = pageHead("ambler basin report: " + name) + "<p>Basin directory <code>" + htmlEscape(name) +
                     "</code>: " + std::to_string(methods.size()) + " methods, " + std::to_string(ts.size()) +
                     " initial translations \xC3\x97 " + std::to_string(rs.size()) + " rotations, " +
                     std::to_string(rows.size() - 1) + " rows in <code>basin.csv</code>.</p>\n<nav>";
  if (!scenario_text.empty()) html += "<a href=\"#scenario\">Scenario</a>";
  html += "<a href=\"#success\">Success rates</a>";
  if (!summary.empty()) html += "<a href=\"#summary\">Summary</a>";
  if (!figures.empty()) html += "<a href=\"#figures\">Figures</a>";
  if (!pair_figures.empty()) html += "<a href=\"#pair\">Pair</a>";
  html += "</nav>\n";
  if (!scenario_text.empty())
    html += "<h2 id=\"scenario\">Scenario</h2>\n<p>The pair's scenario (<code>pair/scenario.resolved.yaml</code>); "
            "its <code>matching.success</code> decides a draw's success.</p>\n<pre>" + htmlEscape(scenario_text) + "</pre>\n";

  html += "<h2 id=\"success\">Success rates</h2>\n<p>Successes / trials per cell, from <code>basin.csv</code>. "
          "Goal (docs/experiments/basin.md): the best two-stage method succeeds in \xE2\x89\xA5 95 % of the trials "
          "of every cell out to 3 m and 30\xC2\xB0.</p>\n";
  Table goal;
  goal.caption = "cells with \xE2\x89\xA5 95 % success";
  goal.corner = "method";
  goal.css_class = "text";
  goal.columns = {"cells", "successes", "every cell \xE2\x89\xA5 95 %"};
  for (const std::string& m : methods) {
    Table t;
    t.caption = m;
    t.corner = "translation (m) \\ rotation (\xC2\xB0)";
    for (double r : rs) t.columns.push_back(g4(r));
    int good = 0, all = 0, s_sum = 0, n_sum = 0;
    for (double tr : ts) {
      std::vector<std::string> row;
      for (double r : rs) {
        const auto it = cells.find({m, tr, r});
        if (it == cells.end()) {
          row.push_back("\xE2\x80\x94");
          continue;
        }
        const auto [s, n] = it->second;
        row.push_back(std::to_string(s) + "/" + std::to_string(n));
        ++all, good += 20 * s >= 19 * n, s_sum += s, n_sum += n;
      }
      t.rows.push_back({g4(tr), row});
    }
    goal.rows.push_back({m,
                         {std::to_string(good) + " of " + std::to_string(all),
                          std::to_string(s_sum) + " of " + std::to_string(n_sum),
                          good == all ? "<td class=\"pass\">pass</td>" : "<td class=\"fail\">fail</td>"}});
    html += tableHtml(t);
  }
  html += tableHtml(goal);
  if (!summary.empty()) html += "<h2 id=\"summary\">Summary</h2>\n<p>From <code>basin.md</code>:</p>\n" + markdownHtml(summary);
  if (!figures.empty()) {
    html += "<h2 id=\"figures\">Figures</h2>\n";
    for (const auto& f : figures) html += figureHtml(dir / f, f);
  }
  if (!pair_figures.empty()) {
    html += "<h2 id=\"pair\">Pair</h2>\n<p>The pair the methods register (<code>pair/</code>, a run directory).</p>\n";
    for (const auto& f : pair_figures) html += figureHtml(dir / f, f);
  }
  return html + pageTail();
}

}  // namespace ambler::eval
