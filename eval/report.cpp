#include "eval/report.hpp"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "eval/io.hpp"

namespace ambler::eval {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;

std::string readFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path.string() + ": cannot open file");
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// The sections of a run report, in the order they appear (docs/report.md).
enum Section { kRun, kWorld, kScans, kMaps, kMatching, kFootfalls, kLeg, kOther, kSectionCount };
constexpr const char* kIds[kSectionCount] = {"run", "world", "scans", "maps", "matching", "footfalls", "leg", "other"};
constexpr const char* kTitles[kSectionCount] = {"Run",      "World",     "Scans", "Maps",
                                                "Matching", "Footfalls", "Leg",   "Other"};

struct Table {
  std::string caption;
  std::vector<std::string> columns;                              // entry labels
  std::vector<std::pair<std::string, std::vector<std::string>>> rows;  // metric, one cell per column
};

struct Figure {
  std::string rel;  // path under the run directory, '/'-separated
  fs::path path;
};

// Numbers in text order: "view_2" before "view_10".
bool naturalLess(const std::string& a, const std::string& b) {
  size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    if (std::isdigit(static_cast<unsigned char>(a[i])) && std::isdigit(static_cast<unsigned char>(b[j]))) {
      size_t ie = i, je = j;
      while (ie < a.size() && std::isdigit(static_cast<unsigned char>(a[ie]))) ++ie;
      while (je < b.size() && std::isdigit(static_cast<unsigned char>(b[je]))) ++je;
      std::string da = a.substr(i, ie - i), db = b.substr(j, je - j);
      da.erase(0, std::min(da.find_first_not_of('0'), da.size()));
      db.erase(0, std::min(db.find_first_not_of('0'), db.size()));
      if (da.size() != db.size()) return da.size() < db.size();
      if (da != db) return da < db;
      i = ie, j = je;
    } else {
      if (a[i] != b[j]) return a[i] < b[j];
      ++i, ++j;
    }
  }
  if ((a.size() - i) != (b.size() - j)) return a.size() - i < b.size() - j;
  return a < b;  // equal up to leading zeros: a total order all the same
}

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
  const auto add = [&](const std::string& s) { label += (label.empty() ? "" : " ") + s; };
  if (entry.contains("view") && entry["view"].is_primitive()) add("view " + formatScalar(entry["view"]));
  if (entry.contains("pair") && entry["pair"].is_array()) {
    std::string p;
    for (const Json& k : entry["pair"]) p += (p.empty() ? "" : "\xE2\x80\x93") + formatScalar(k);  // an en dash
    add("pair " + p);
  }
  if (entry.contains("method") && entry["method"].is_string()) add(formatScalar(entry["method"]));
  return label.empty() ? "#" + std::to_string(index) : label;
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

std::string tableHtml(const Table& t) {
  std::string h = "<table>\n<caption>" + htmlEscape(t.caption) + "</caption>\n<tr><th>metric</th>";
  for (const std::string& c : t.columns) h += "<th>" + htmlEscape(c) + "</th>";
  h += "</tr>\n";
  for (const auto& [name, cells] : t.rows) {
    h += "<tr><th>" + htmlEscape(name) + "</th>";
    for (const std::string& c : cells) h += "<td>" + c + "</td>";
    h += "</tr>\n";
  }
  return h + "</table>\n";
}

// Width and height from a PNG's IHDR chunk (bytes 16-23, big-endian), 0 if it is not one.
std::pair<unsigned, unsigned> pngSize(const std::string& bytes) {
  if (bytes.size() < 24 || bytes.compare(0, 8, "\x89PNG\r\n\x1a\n") != 0 || bytes.compare(12, 4, "IHDR") != 0)
    return {0, 0};
  const auto be32 = [&](size_t at) {
    unsigned v = 0;
    for (size_t i = 0; i < 4; ++i) v = (v << 8) | static_cast<unsigned char>(bytes[at + i]);
    return v;
  };
  return {be32(16), be32(20)};
}

std::string figureHtml(const Figure& f) {
  const std::string bytes = readFile(f.path);
  const auto [w, h] = pngSize(bytes);
  std::string html = "<figure><img alt=\"" + htmlEscape(f.rel) + "\"";
  if (w > 0 && h > 0) html += " width=\"" + std::to_string(w) + "\" height=\"" + std::to_string(h) + "\"";
  html += " src=\"data:image/png;base64," + base64Encode(bytes) + "\"><figcaption>" + htmlEscape(f.rel) +
          "</figcaption></figure>\n";
  return html;
}

constexpr const char* kStyle = R"(body{font-family:sans-serif;margin:2em auto;max-width:72em;padding:0 1em;color:#222}
h1{font-size:1.6em}h2{border-bottom:1px solid #ccc;margin-top:2em}
nav a{margin-right:1em}
pre{background:#f6f6f6;border:1px solid #ddd;padding:0.8em;overflow-x:auto;font-size:0.85em}
table{border-collapse:collapse;margin:1em 0;font-size:0.9em}
caption{text-align:left;font-weight:bold;padding:0.3em 0}
th,td{border:1px solid #ccc;padding:0.2em 0.6em}
td{text-align:right;font-variant-numeric:tabular-nums}
tr>th:first-child{text-align:left;font-weight:normal;font-family:monospace}
figure{display:inline-block;margin:0.5em;vertical-align:top;max-width:100%}
img{max-width:100%;height:auto;border:1px solid #eee}
figcaption{font-family:monospace;font-size:0.8em;color:#555}
)";

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
  fs::path shown = run_dir.lexically_normal();
  if (shown.filename().empty()) shown = shown.parent_path();
  const std::string title = "ambler run report: " + (name.empty() ? shown.filename().string() : name);

  std::string html = "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>" +
                     htmlEscape(title) + "</title>\n<style>\n" + kStyle + "</style>\n</head>\n<body>\n<h1>" +
                     htmlEscape(title) + "</h1>\n<p>Run directory <code>" + htmlEscape(shown.filename().string()) +
                     "</code>. Every picture of the run is embedded; metrics from <code>metrics.json</code> "
                     "(numbers to 4 significant digits, " "\xE2\x80\x94" " where a figure is not defined).</p>\n";
  html += "<nav>";
  if (has_scenario) html += "<a href=\"#scenario\">Scenario</a>";
  for (int s = 0; s < kSectionCount; ++s)
    if (!figures[s].empty() || !tables[s].empty())
      html += std::string("<a href=\"#") + kIds[s] + "\">" + kTitles[s] + "</a>";
  html += "</nav>\n";
  if (has_scenario)
    html += "<h2 id=\"scenario\">Scenario</h2>\n<pre>" + htmlEscape(scenario_text) + "</pre>\n";
  for (int s = 0; s < kSectionCount; ++s) {
    if (figures[s].empty() && tables[s].empty()) continue;
    html += std::string("<h2 id=\"") + kIds[s] + "\">" + kTitles[s] + "</h2>\n";
    for (const Table& t : tables[s]) html += tableHtml(t);
    for (const Figure& f : figures[s]) html += figureHtml(f);
  }
  html += "</body>\n</html>\n";
  return html;
}

fs::path writeRunReport(const fs::path& run_dir, const fs::path& out_html) {
  const std::string html = runReportHtml(run_dir);  // before anything is written
  if (out_html.has_parent_path()) createOutDir(out_html.parent_path());
  writeText(out_html, html);
  return out_html;
}

}  // namespace ambler::eval
