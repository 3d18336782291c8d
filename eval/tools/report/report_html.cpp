// The pieces every report shares (eval/tools/report/report_internal.hpp): the page frame, tables, embedded
// pictures, and the goals the docs state with their checks.
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "eval/tools/report/report.hpp"
#include "base/read_file.hpp"
#include "eval/tools/report/report_internal.hpp"

namespace ambler::eval::report_detail {

namespace fs = std::filesystem;

namespace {

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

constexpr const char* kStyle = R"(body{font-family:sans-serif;margin:2em auto;max-width:72em;padding:0 1em;color:#222}
h1{font-size:1.6em}h2{border-bottom:1px solid #ccc;margin-top:2em}
nav a{margin-right:1em}
pre{background:#f6f6f6;border:1px solid #ddd;padding:0.8em;overflow:auto;max-height:24em;font-size:0.85em}
@media print{pre{max-height:none}}
table{border-collapse:collapse;margin:1em 0;font-size:0.9em}
caption{text-align:left;font-weight:bold;padding:0.3em 0}
th,td{border:1px solid #ccc;padding:0.2em 0.6em}
td{text-align:right;font-variant-numeric:tabular-nums}
td.pass{color:#1a7f37;font-weight:bold}td.fail{color:#c0392b;font-weight:bold}
table.text td{text-align:left;white-space:nowrap}
tr>th:first-child{text-align:left;font-weight:normal;font-family:monospace}
figure{display:inline-block;margin:0.5em;vertical-align:top;max-width:100%}
img{max-width:100%;height:auto;border:1px solid #eee}
figcaption{font-family:monospace;font-size:0.8em;color:#555}
)";

constexpr double kInf = std::numeric_limits<double>::infinity();

// A scalar of `entry` by dotted path ("leg.tilt_deg"); null when absent.
const Json* at(const Json& entry, const std::string& dotted) {
  const Json* v = &entry;
  std::size_t from = 0;
  while (true) {
    const std::size_t dot = dotted.find('.', from);
    const std::string key = dotted.substr(from, dot == std::string::npos ? std::string::npos : dot - from);
    if (!v->is_object() || !v->contains(key)) return nullptr;
    v = &(*v)[key];
    if (dot == std::string::npos) return v;
    from = dot + 1;
  }
}

std::string entryName(const Json& e, std::size_t k) {
  std::string name;
  if (e.contains("view") && e["view"].is_number()) name += "view " + e["view"].dump();
  if (e.contains("pair") && e["pair"].is_array() && e["pair"].size() == 2)
    name += (name.empty() ? "" : " ") + std::string("pair ") + e["pair"][0].dump() + "\xE2\x80\x93" + e["pair"][1].dump();
  if (e.contains("method") && e["method"].is_string())
    name += (name.empty() ? "" : " ") + e["method"].get<std::string>();
  return name.empty() ? "#" + std::to_string(k) : name;
}

std::string verdict(bool pass) { return pass ? "<td class=\"pass\">pass</td>" : "<td class=\"fail\">fail</td>"; }

}  // namespace

std::string readFile(const fs::path& path) {
  try {
    return base::readFile(path);
  } catch (const base::ReadError& e) {
    throw std::runtime_error(path.string() + ": " + e.what());
  }
}

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

std::string g4(double v) {
  if (!std::isfinite(v)) return "\xE2\x80\x94";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.4g", v);
  return buf;
}

std::string tableHtml(const Table& t) {
  std::string h = t.css_class.empty() ? std::string("<table>") : "<table class=\"" + t.css_class + "\">";
  h += "\n<caption>" + htmlEscape(t.caption) + "</caption>\n<tr><th>" + htmlEscape(t.corner) + "</th>";
  for (const std::string& c : t.columns) h += "<th>" + htmlEscape(c) + "</th>";
  h += "</tr>\n";
  for (const auto& [name, cells] : t.rows) {
    h += "<tr><th>" + htmlEscape(name) + "</th>";
    for (const std::string& c : cells) h += c.starts_with("<td") ? c : "<td>" + c + "</td>";
    h += "</tr>\n";
  }
  return h + "</table>\n";
}

std::string figureBytesHtml(const std::string& bytes, const std::string& caption) {
  const auto [w, h] = pngSize(bytes);
  std::string html = "<figure><img alt=\"" + htmlEscape(caption) + "\"";
  if (w > 0 && h > 0) html += " width=\"" + std::to_string(w) + "\" height=\"" + std::to_string(h) + "\"";
  html += " src=\"data:image/png;base64," + base64Encode(bytes) + "\"><figcaption>" + htmlEscape(caption) +
          "</figcaption></figure>\n";
  return html;
}

std::string figureHtml(const fs::path& path, const std::string& caption) {
  return figureBytesHtml(readFile(path), caption);
}

std::string pageHead(const std::string& title) {
  return "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>" + htmlEscape(title) +
         "</title>\n<style>\n" + kStyle + "</style>\n</head>\n<body>\n<h1>" + htmlEscape(title) + "</h1>\n";
}

std::string pageTail() { return "</body>\n</html>\n"; }

std::string shownName(const fs::path& dir) {
  fs::path shown = dir.lexically_normal();
  if (shown.filename().empty()) shown = shown.parent_path();
  return shown.filename().string();
}

// The goals the docs state, one row each; only metrics with a documented goal. The registration
// criterion is the scenario's own (matching.success, docs/matching.md) and is read from the run.
const std::vector<Goal>& goals() {
  static const std::vector<Goal> kGoals{
      {"composite", "rms_error_m", -kInf, 0.03, "\xE2\x89\xA4 0.03 m (3 cm)", "docs/experiments/composite.md"},
      {"composite", "within_1sigma", 0.60, 0.76, "0.60\xE2\x80\x93" "0.76 (60\xE2\x80\x93" "76 % within 1\xCF\x83)",
       "docs/composite.md"},
      {"footfall", "leg.tilt_deg", -kInf, 5.0, "\xE2\x89\xA4 5\xC2\xB0", "docs/experiments/footfall.md"},
      {"footfall", "leg.slip_m", -kInf, 0.01, "\xE2\x89\xA4 0.01 m (1 cm)", "docs/experiments/footfall.md"},
  };
  return kGoals;
}

Table runGoalsTable(const Json& metrics, const std::string& scenario_yaml) {
  Table t;
  t.caption = "goals the docs state";
  t.corner = "metric";
  t.css_class = "text";
  t.columns = {"entry", "value", "goal", "result", "stated in"};
  for (const Goal& g : goals()) {
    if (!metrics.contains(g.section)) continue;
    const Json& section = metrics[g.section];
    std::vector<std::pair<std::string, const Json*>> entries;
    if (section.is_object()) entries.emplace_back(g.section, &section);
    else if (section.is_array())
      for (std::size_t k = 0; k < section.size(); ++k) entries.emplace_back(entryName(section[k], k), &section[k]);
    for (const auto& [name, entry] : entries) {
      const Json* v = at(*entry, g.metric);
      if (!v || !v->is_number()) continue;
      const double x = v->get<double>();
      t.rows.push_back({std::string(g.section) + "." + g.metric,
                        {htmlEscape(name), g4(x), htmlEscape(g.goal), verdict(x >= g.lo && x <= g.hi), g.doc}});
    }
  }
  // Composite coverage above every single view's (docs/experiments/composite.md).
  if (metrics.contains("composite") && metrics["composite"].is_object() && metrics.contains("map") &&
      metrics["map"].is_array()) {
    const Json* c = at(metrics["composite"], "coverage");
    double best = -kInf;
    for (const Json& m : metrics["map"])
      if (const Json* v = at(m, "coverage"); v && v->is_number()) best = std::max(best, v->get<double>());
    if (c && c->is_number() && std::isfinite(best))
      t.rows.push_back({"composite.coverage",
                        {"composite", g4(c->get<double>()), "&gt; every view's (best " + g4(best) + ")",
                         verdict(c->get<double>() > best), "docs/experiments/composite.md"}});
  }
  // Registration: the scenario's success criterion.
  if (metrics.contains("registration") && metrics["registration"].is_array()) {
    double t_max = kInf, r_max = kInf;
    try {
      const YAML::Node s = YAML::Load(scenario_yaml)["matching"]["success"];
      if (s && s["translation_m"]) t_max = s["translation_m"].as<double>();
      if (s && s["rotation_deg"]) r_max = s["rotation_deg"].as<double>();
    } catch (const YAML::Exception&) {
    }
    const Json& reg = metrics["registration"];
    for (std::size_t k = 0; k < reg.size(); ++k) {
      const Json* te = at(reg[k], "translation_error_m");
      const Json* re = at(reg[k], "rotation_error_deg");
      const Json* ok = at(reg[k], "success");
      if (!ok || !ok->is_boolean()) continue;
      const std::string value = (te && te->is_number() ? g4(te->get<double>()) : "\xE2\x80\x94") + " m, " +
                                (re && re->is_number() ? g4(re->get<double>()) : "\xE2\x80\x94") + "\xC2\xB0";
      const std::string goal = std::isfinite(t_max) && std::isfinite(r_max)
                                   ? "\xE2\x89\xA4 " + g4(t_max) + " m and \xE2\x89\xA4 " + g4(r_max) + "\xC2\xB0"
                                   : "within matching.success";
      t.rows.push_back({"registration.success",
                        {htmlEscape(entryName(reg[k], k)), value, goal, verdict(ok->get<bool>()),
                         "docs/matching.md"}});
    }
  }
  return t;
}

}  // namespace ambler::eval::report_detail
