#include "eval/tools/report/report.hpp"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "eval/scenario/io.hpp"
#include "eval/tools/report/report_internal.hpp"

namespace ambler::eval {
namespace {

namespace fs = std::filesystem;
using namespace report_detail;

// The sections of a run report, in the order they appear (docs/report.md).
enum Section { kRun, kWorld, kScans, kMaps, kMatching, kFootfalls, kLeg, kOther, kSectionCount };
constexpr const char* kIds[kSectionCount] = {"run", "world", "scans", "maps", "matching", "footfalls", "leg", "other"};
constexpr const char* kTitles[kSectionCount] = {"Run",      "World",     "Scans", "Maps",
                                                "Matching", "Footfalls", "Leg",   "Other"};

struct Figure {
  std::string rel;  // path under the run directory, '/'-separated
  fs::path path;
};

Section figureSection(const std::string& rel) {
  const size_t slash = rel.find('/');
  if (slash == std::string::npos) return rel == "terrain.png" ? kWorld : kOther;
  const std::string first = rel.substr(0, slash);
  if (first == "world") return kWorld;
  if (first == "scans") return kScans;
  if (first == "maps") return kMaps;
  if (first == "matching") return kMatching;
  if (first.starts_with("footfall")) return kFootfalls;
  if (first == "leg") return kLeg;
  return kOther;
}

// Maps: every view's pictures (view 0, 1, ...), then the composite's.
bool figureLess(const Figure& a, const Figure& b) {
  const auto composite = [](const std::string& rel) {
    const size_t slash = rel.rfind('/');
    return rel.compare(slash == std::string::npos ? 0 : slash + 1, 10, "composite_") == 0;
  };
  const bool ca = composite(a.rel), cb = composite(b.rel);
  if (ca != cb) return cb;
  return naturalLess(a.rel, b.rel);
}

std::string formatScalar(const Json& v) {
  if (v.is_null()) return "\xE2\x80\x94";  // an em dash
  if (v.is_boolean()) return v.get<bool>() ? "true" : "false";
  if (v.is_number_unsigned()) return std::to_string(v.get<std::uint64_t>());
  if (v.is_number_integer()) return std::to_string(v.get<std::int64_t>());
  if (v.is_number_float()) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.4g", v.get<double>());
    return buf;
  }
  if (v.is_string()) return htmlEscape(v.get<std::string>());
  return "";
}

// An entry's column label from the keys that name it: view, pair, method.
std::string entryLabel(const Json& entry, size_t index) {
  std::string label;
  const auto add = [&](const std::string& s) {
    if (!label.empty()) label += ' ';
    label += s;
  };
  if (entry.contains("view") && entry["view"].is_primitive()) add("view " + formatScalar(entry["view"]));
  if (entry.contains("pair") && entry["pair"].is_array()) {
    std::string p;
    for (const Json& k : entry["pair"]) {
      if (!p.empty()) p += "\xE2\x80\x93";  // an en dash
      p += formatScalar(k);
    }
    add("pair " + p);
  }
  if (entry.contains("method") && entry["method"].is_string()) add(formatScalar(entry["method"]));
  if (label.empty()) label = std::string(1, '#').append(std::to_string(index));
  return label;
}

bool isLabelKey(const std::string& key) { return key == "view" || key == "pair" || key == "method"; }

// Scalars of an entry as (metric name, cell), nested objects as "parent.child"; lists are skipped.
void flatten(const Json& v, const std::string& prefix, const std::vector<std::string>& exclude, bool top,
             std::vector<std::pair<std::string, std::string>>& out) {
  for (const auto& [key, value] : v.items()) {
    if (top && (isLabelKey(key) || std::find(exclude.begin(), exclude.end(), key) != exclude.end())) continue;
    const std::string name = prefix.empty() ? key : prefix + "." + key;
    if (value.is_object())
      flatten(value, name, exclude, false, out);
    else if (!value.is_array())
      out.emplace_back(name, formatScalar(value));
  }
}

// One table of a metrics.json section: a list of entries (one column each) or one object (one
// column named after the section). Empty when there is nothing scalar in it.
Table metricsTable(const std::string& caption, const Json& section, const std::vector<std::string>& exclude = {}) {
  Table t;
  t.caption = caption;
  std::vector<std::pair<std::string, const Json*>> entries;
  if (section.is_object()) {
    entries.emplace_back(caption, &section);
  } else if (section.is_array()) {
    for (size_t k = 0; k < section.size(); ++k)
      if (section[k].is_object()) entries.emplace_back(entryLabel(section[k], k), &section[k]);
  }
  for (size_t c = 0; c < entries.size(); ++c) {
    t.columns.push_back(entries[c].first);
    std::vector<std::pair<std::string, std::string>> cells;
    flatten(*entries[c].second, "", exclude, true, cells);
    for (auto& [name, cell] : cells) {
      auto row = std::find_if(t.rows.begin(), t.rows.end(), [&](const auto& r) { return r.first == name; });
      if (row == t.rows.end()) {
        t.rows.emplace_back(name, std::vector<std::string>(entries.size(), "\xE2\x80\x94"));
        row = t.rows.end() - 1;
      }
      row->second[c] = cell;
    }
  }
  return t;
}

// The leg's figures of each footfall choice: one column per method.
Table legTable(const Json& footfall) {
  Json legs = Json::array();
  for (const Json& f : footfall)
    if (f.is_object() && f.contains("leg") && f["leg"].is_object()) {
      Json e = f["leg"];
      if (f.contains("method")) e["method"] = f["method"];
      legs.push_back(e);
    }
  return metricsTable("leg", legs);
}

}  // namespace

std::string base64Encode(std::string_view bytes) {
  static constexpr char kAlphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  size_t i = 0;
  for (; i + 3 <= bytes.size(); i += 3) {
    const unsigned v = (unsigned(static_cast<unsigned char>(bytes[i])) << 16) |
                       (unsigned(static_cast<unsigned char>(bytes[i + 1])) << 8) |
                       unsigned(static_cast<unsigned char>(bytes[i + 2]));
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += kAlphabet[(v >> 6) & 63];
    out += kAlphabet[v & 63];
  }
  const size_t rest = bytes.size() - i;
  if (rest > 0) {
    unsigned v = unsigned(static_cast<unsigned char>(bytes[i])) << 16;
    if (rest == 2) v |= unsigned(static_cast<unsigned char>(bytes[i + 1])) << 8;
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += rest == 2 ? kAlphabet[(v >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

std::string htmlEscape(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (const char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&#39;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string runReportHtml(const fs::path& run_dir) {
  const fs::path metrics_path = run_dir / "metrics.json";
  std::error_code ec;
  if (!fs::is_regular_file(metrics_path, ec))
    throw std::runtime_error(run_dir.string() + ": not a run directory (no metrics.json)");
  Json metrics;
  try {
    metrics = Json::parse(readFile(metrics_path));
  } catch (const Json::exception& e) {
    throw std::runtime_error(metrics_path.string() + ": not JSON (" + e.what() + ")");
  }
  if (!metrics.is_object()) throw std::runtime_error(metrics_path.string() + ": expected a JSON object");

  // The figures: every PNG under the run directory, in its stage's section.
  std::vector<Figure> figures[kSectionCount];
  for (auto it = fs::recursive_directory_iterator(run_dir); it != fs::recursive_directory_iterator(); ++it) {
    if (!it->is_regular_file() || it->path().extension() != ".png") continue;
    Figure f{fs::relative(it->path(), run_dir).generic_string(), it->path()};
    figures[figureSection(f.rel)].push_back(std::move(f));
  }
  for (auto& list : figures) std::sort(list.begin(), list.end(), figureLess);

  // The tables: metrics.json's sections in their stage's section.
  std::vector<Table> tables[kSectionCount];
  Json run_scalars = Json::object();
  for (const auto& [key, value] : metrics.items()) {
    if (value.is_primitive()) {
      run_scalars[key] = value;
      continue;
    }
    Section s = kOther;
    std::vector<std::string> exclude;
    if (key == "timing_s") s = kRun;
    else if (key == "scan") s = kScans;
    else if (key == "map" || key == "map_cartesian" || key == "composite" || key.starts_with("map_")) s = kMaps;
    else if (key == "registration") s = kMatching;
    else if (key == "footfall") {
      s = kFootfalls;
      exclude = {"leg"};
      Table leg = legTable(value);
      if (!leg.rows.empty()) tables[kLeg].push_back(std::move(leg));
    }
    Table t = metricsTable(key, value, exclude);
    if (!t.rows.empty()) tables[s].push_back(std::move(t));
  }
  if (!run_scalars.empty()) tables[kRun].insert(tables[kRun].begin(), metricsTable("run", run_scalars));

  std::string scenario_text;
  const bool has_scenario = fs::is_regular_file(run_dir / "scenario.resolved.yaml", ec);
  if (has_scenario) scenario_text = readFile(run_dir / "scenario.resolved.yaml");

  const std::string name =
      metrics.contains("name") && metrics["name"].is_string() ? metrics["name"].get<std::string>() : "";
  const std::string shown = shownName(run_dir);
  const std::string title = "ambler run report: " + (name.empty() ? shown : name);
  const Table goal_table = runGoalsTable(metrics, scenario_text);

  std::string html = pageHead(title) + "<p>Run directory <code>" + htmlEscape(shown) +
                     "</code>. Every picture of the run is embedded; metrics from <code>metrics.json</code> "
                     "(numbers to 4 significant digits, " "\xE2\x80\x94" " where a figure is not defined).</p>\n";
  html += "<nav>";
  if (has_scenario) html += "<a href=\"#scenario\">Scenario</a>";
  if (!goal_table.rows.empty()) html += "<a href=\"#goals\">Goals</a>";
  for (int s = 0; s < kSectionCount; ++s)
    if (!figures[s].empty() || !tables[s].empty())
      html += std::string("<a href=\"#") + kIds[s] + "\">" + kTitles[s] + "</a>";
  html += "</nav>\n";
  if (has_scenario)
    html += "<h2 id=\"scenario\">Scenario</h2>\n<pre>" + htmlEscape(scenario_text) + "</pre>\n";
  if (!goal_table.rows.empty())
    html += "<h2 id=\"goals\">Goals</h2>\n<p>The metrics the docs state a goal for (docs/report.md, "
            "\"Goals\").</p>\n" + tableHtml(goal_table);
  for (int s = 0; s < kSectionCount; ++s) {
    if (figures[s].empty() && tables[s].empty()) continue;
    html += std::string("<h2 id=\"") + kIds[s] + "\">" + kTitles[s] + "</h2>\n";
    for (const Table& t : tables[s]) html += tableHtml(t);
    for (const Figure& f : figures[s]) html += figureHtml(f.path, f.rel);
  }
  return html + pageTail();
}

ReportKind reportKind(const fs::path& dir) {
  std::error_code ec;
  if (fs::is_regular_file(dir / "metrics.json", ec)) return ReportKind::Run;
  if (fs::is_regular_file(dir / "results.csv", ec)) return ReportKind::Sweep;
  if (fs::is_regular_file(dir / "basin.csv", ec)) return ReportKind::Basin;
  throw std::runtime_error(dir.string() +
                           ": not a run, sweep or basin directory (no metrics.json, results.csv or basin.csv)");
}

fs::path writeReport(const fs::path& dir, const fs::path& out_html) {
  const fs::path html_dir = out_html.has_parent_path() ? out_html.parent_path() : fs::path(".");
  std::string html;  // all of it before anything is written
  switch (reportKind(dir)) {
    case ReportKind::Run: html = runReportHtml(dir); break;
    case ReportKind::Sweep: html = sweepReportHtml(dir, html_dir); break;
    case ReportKind::Basin: html = basinReportHtml(dir); break;
  }
  if (out_html.has_parent_path()) createOutDir(out_html.parent_path());
  writeText(out_html, html);
  return out_html;
}

fs::path writeRunReport(const fs::path& run_dir, const fs::path& out_html) {
  const std::string html = runReportHtml(run_dir);  // before anything is written
  if (out_html.has_parent_path()) createOutDir(out_html.parent_path());
  writeText(out_html, html);
  return out_html;
}

}  // namespace ambler::eval
