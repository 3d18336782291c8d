// Sweeps: axes of values at dotted key paths into a base scenario's YAML; every combination is
// written back as YAML and read by the strict scenario reader before anything runs. Rows are
// assembled in run order whatever the number of jobs, so results.csv is byte-identical however it
// was produced (one process, several jobs, or shards merged). docs/sweeps.md is the schema.
#include "eval/sweep.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <atomic>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <regex>
#include <sstream>
#include <string_view>
#include <thread>
#include <unordered_map>
#include <utility>

#include "eval/io.hpp"
#include "eval/runner.hpp"

namespace ambler::eval {
namespace {

namespace fs = std::filesystem;

// Bounds the product so a typo cannot start validating (and storing, ~3 kB each) millions of
// scenarios; a bigger study is several sweep files.
constexpr std::size_t kMaxRuns = 100'000;

// ---- YAML text -------------------------------------------------------------------------------

bool isQuoted(const YAML::Node& node) { return node.Tag() == "!"; }


// Whether text read as a plain scalar reads back the same written plain on one line of block YAML.
bool plainSafe(std::string_view s) {
  if (s.empty() || s.front() == ' ' || s.back() == ' ' || s.back() == ':') return false;
  if (s.starts_with("---") || s.starts_with("...")) return false;
  if (std::string_view(",[]{}#&*!|>'\"%@`").find(s.front()) != std::string_view::npos) return false;
  if ((s.front() == '-' || s.front() == '?' || s.front() == ':') && (s.size() == 1 || s[1] == ' ')) {
    return false;
  }
  if (s.find(": ") != std::string_view::npos || s.find(" #") != std::string_view::npos) return false;
  return std::none_of(s.begin(), s.end(),
                      [](char c) { return static_cast<unsigned char>(c) < 0x20 || c == 0x7f; });
}

// A scalar as it must be written so that the scenario reader sees what the user wrote: a quoted
// string stays quoted ("40" is a string, not a number), a plain one stays plain.
std::string scalarText(const YAML::Node& node) {
  return isQuoted(node) || !plainSafe(node.Scalar()) ? yamlQuoted(node.Scalar()) : node.Scalar();
}

// A value on one line, as in a YAML flow collection (for messages and nested CSV cells).
std::string flowText(const YAML::Node& node) {
  if (node.IsScalar()) return scalarText(node);
  if (!node.IsSequence() && !node.IsMap()) return "~";
  std::string out = node.IsMap() ? "{" : "[";
  for (auto it = node.begin(); it != node.end(); ++it) {
    if (out.size() > 1) out += ", ";
    out += node.IsMap() ? flowText(it->first) + ": " + flowText(it->second) : flowText(*it);
  }
  return out + (node.IsMap() ? "}" : "]");
}

// A value as one results.csv cell (before CSV quoting): a list as "a;b;c", nothing as "".
std::string cellText(const YAML::Node& node) {
  if (node.IsScalar()) return node.Scalar();
  if (!node.IsSequence()) return node.IsMap() ? flowText(node) : "";
  std::string out;
  for (std::size_t i = 0; i < node.size(); ++i) {
    const YAML::Node element = node[i];
    out += (i ? ";" : "") + (element.IsScalar() ? element.Scalar()
                             : element.IsNull() ? std::string()
                                                : flowText(element));
  }
  return out;
}

// Block YAML. yaml-cpp's emitter drops the quotes of quoted scalars, which would turn the
// string "40" into the number 40; this keeps them, so a sweep is exactly as strict as a scenario.
void emitBlock(const YAML::Node& node, int indent, std::string& out);

void emitValue(const YAML::Node& value, int indent, std::string& out) {
  if ((value.IsMap() || value.IsSequence()) && value.size() > 0) {
    out += '\n';
    emitBlock(value, indent + 2, out);
  } else {
    out += ' ';
    out += value.IsScalar() ? scalarText(value) : value.IsMap() ? "{}" : value.IsSequence() ? "[]" : "~";
    out += '\n';
  }
}

void emitBlock(const YAML::Node& node, int indent, std::string& out) {
  const std::string pad(std::size_t(indent), ' ');
  for (auto it = node.begin(); it != node.end(); ++it) {
    if (node.IsMap()) {
      const YAML::Node& key = it->first;
      out += pad + (key.IsScalar() && plainSafe(key.Scalar()) ? key.Scalar() : yamlQuoted(flowText(key))) +
             ":";
      emitValue(it->second, indent, out);
    } else {
      out += pad + "-";
      emitValue(*it, indent, out);
    }
  }
}

std::string emitYaml(const YAML::Node& root) {
  std::string out;
  emitBlock(root, 0, out);
  return out;
}

// ---- the sweep file ---------------------------------------------------------------------------

std::vector<std::string> split(std::string_view text, char sep) {
  std::vector<std::string> out;
  for (std::size_t start = 0;;) {
    const auto end = text.find(sep, start);
    out.emplace_back(text.substr(start, end - start));
    if (end == std::string_view::npos) return out;
    start = end + 1;
  }
}

bool allDigits(std::string_view s) {
  return !s.empty() && std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; });
}

bool isKeyPath(std::string_view path) {
  const auto segments = split(path, '.');
  return std::all_of(segments.begin(), segments.end(), [](const std::string& s) {
    return !s.empty() && std::all_of(s.begin(), s.end(), [](char c) {
      return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_';
    });
  });
}

// The scenario reader's name for a dotted path: views.0.xyz_m -> views[0].xyz_m.
std::string readerPath(const std::string& key) {
  std::string out;
  for (const auto& segment : split(key, '.')) {
    out += allDigits(segment) && !out.empty() ? "[" + segment + "]" : (out.empty() ? "" : ".") + segment;
  }
  return out;
}

std::string readText(const fs::path& file, const std::string& who) {
  std::error_code ec;
  std::ifstream in(file, std::ios::binary);
  if (!in || fs::is_directory(file, ec)) throw SweepError(who + ": cannot open file");
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw SweepError(who + ": cannot read file");
  return text.str();
}

class SweepReader {
 public:
  explicit SweepReader(const fs::path& file)
      : file_(file), where_(file.empty() ? "<string>" : file.string()) {}

  [[noreturn]] void fail(const std::string& key, const std::string& what) const {
    throw SweepError(where_ + ": " + (key.empty() ? "" : key + ": ") + what);
  }

  Sweep read(const std::string& text) {
    std::vector<YAML::Node> docs;
    try {
      docs = YAML::LoadAll(text);
    } catch (const YAML::Exception& e) {
      fail(e.mark.is_null()
               ? ""
               : "line " + std::to_string(e.mark.line + 1) + ", column " + std::to_string(e.mark.column + 1),
           "YAML syntax error: " + e.msg);
    }
    if (docs.size() != 1 || !docs.front().IsMap()) {
      fail("", docs.size() > 1 ? "expected one YAML document, got " + std::to_string(docs.size())
                               : "expected a mapping of sweep keys (name, base, axes, metrics)");
    }
    const YAML::Node& root = docs.front();
    std::unordered_map<std::string, YAML::Node> keys;
    for (auto it = root.begin(); it != root.end(); ++it) {
      const std::string key = it->first.IsScalar() ? it->first.Scalar() : flowText(it->first);
      static const std::vector<std::string> kAllowed{"name", "description", "base", "axes", "metrics"};
      if (std::find(kAllowed.begin(), kAllowed.end(), key) == kAllowed.end()) {
        fail(key, "unknown key (allowed: name, description, base, axes, metrics)");
      }
      if (!keys.emplace(key, it->second).second) fail(key, "duplicate key");
    }
    const auto required = [&](const std::string& key) {
      if (!keys.count(key)) fail(key, "missing required key");
      return keys.at(key);
    };

    Sweep sweep;
    sweep.file = file_;
    sweep.name = string(required("name"), "name");
    const bool valid_name =
        !sweep.name.empty() && std::all_of(sweep.name.begin(), sweep.name.end(), [](char c) {
          return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' || c == '-';
        });
    if (!valid_name)
      fail("name", "expected lowercase letters, digits, '_' and '-' only, got " + flowText(keys.at("name")));
    if (keys.count("description")) sweep.description = string(keys.at("description"), "description");

    const std::string base = string(required("base"), "base");
    if (base.empty()) fail("base", "expected the path of a scenario file, got ''");
    sweep.base =
        (fs::path(base).is_absolute() ? fs::path(base) : file_.parent_path() / base).lexically_normal();
    readAxes(required("axes"), sweep);
    if (keys.count("metrics")) readMetrics(keys.at("metrics"), sweep);

    std::size_t count = 1;
    for (const auto& axis : sweep.axes) count = std::min(count * axis.values.size(), kMaxRuns + 1);
    if (count > kMaxRuns) {
      std::string sizes;
      for (const auto& axis : sweep.axes)
        sizes += (sizes.empty() ? "" : " x ") + std::to_string(axis.values.size());
      fail("axes", "expected at most " + std::to_string(kMaxRuns) + " runs, got " + sizes);
    }
    std::error_code ec;
    if (!fs::is_regular_file(sweep.base, ec)) {
      fail("base", "cannot find the scenario file " + yamlQuoted(base) + " (looked for " +
                       fs::absolute(sweep.base, ec).lexically_normal().string() + ")");
    }
    base_text_ = readText(sweep.base, where_ + ": base: " + sweep.base.string());
    validateAll(sweep, count);
    return sweep;
  }

 private:
  std::string string(const YAML::Node& node, const std::string& key) const {
    if (!node.IsScalar()) fail(key, "expected a string, got " + (node.IsNull() ? "nothing" : flowText(node)));
    return node.Scalar();
  }

  void readAxes(const YAML::Node& node, Sweep& sweep) {
    if (!node.IsMap() || node.size() == 0) {
      fail("axes", "expected a non-empty mapping of key paths to lists of values, got " +
                       (node.IsNull() ? "nothing" : flowText(node)));
    }
    for (auto it = node.begin(); it != node.end(); ++it) {
      const std::string key = it->first.IsScalar() ? it->first.Scalar() : flowText(it->first);
      const std::string where = "axes." + key;
      if (!it->first.IsScalar() || !isKeyPath(key)) {
        fail(where, "expected a dotted key path into the scenario (sensor.noise_k, views.0.xyz_m)");
      }
      if (key == "name")
        fail(where, "the sweep names each run <sweep name>_<run index>; it cannot be an axis");
      for (const auto& other : sweep.axes) {
        if (other.key == key) fail(where, "duplicate key");
        const auto& [shorter, longer] =
            std::minmax(other.key, key, [](const auto& a, const auto& b) { return a.size() < b.size(); });
        if (longer.starts_with(shorter + "."))
          fail(where, "overlaps axis " + other.key + "; give each key once");
      }
      const YAML::Node& values = it->second;
      if (!values.IsSequence() || values.size() == 0) {
        fail(where,
             "expected a non-empty list of values, got " + (values.IsNull() ? "nothing" : flowText(values)));
      }
      SweepAxis axis{key, {}, {}};
      std::vector<YAML::Node> nodes;
      for (const auto& value : values) {
        axis.values.push_back(flowText(value));
        axis.cells.push_back(cellText(value));
        nodes.push_back(value);
      }
      sweep.axes.push_back(std::move(axis));
      values_.push_back(std::move(nodes));
    }
  }

  void readMetrics(const YAML::Node& node, Sweep& sweep) const {
    if (!node.IsSequence() || node.size() == 0) {
      fail("metrics", "expected a non-empty list of metric names (map.0.rms_error_m), got " +
                          (node.IsNull() ? "nothing" : flowText(node)));
    }
    for (std::size_t i = 0; i < node.size(); ++i) {
      const std::string where = "metrics[" + std::to_string(i) + "]";
      const YAML::Node& value = node[i];
      if (!value.IsScalar() || !isKeyPath(value.Scalar())) {
        fail(where, "expected a dotted path into metrics.json (map.0.rms_error_m), got " + flowText(value));
      }
      const std::string& metric = value.Scalar();
      if (std::find(sweep.metrics.begin(), sweep.metrics.end(), metric) != sweep.metrics.end()) {
        fail(where, "duplicate metric " + metric);
      }
      for (const auto& axis : sweep.axes) {
        if (axis.key == metric) fail(where, metric + " is already a column: it is an axis");
      }
      if (metric == "run") fail(where, "run is already a column: the run index");
      sweep.metrics.push_back(metric);
    }
  }

  // Sets `value` at the axis's key path in `root`, creating absent sections.
  void set(YAML::Node root, const SweepAxis& axis, const YAML::Node& value) const {
    const auto segments = split(axis.key, '.');
    YAML::Node node = root;
    std::string prefix;
    for (std::size_t i = 0; i < segments.size(); ++i) {
      const std::string& segment = segments[i];
      const bool last = i + 1 == segments.size();
      // reset(), never operator=: assigning a yaml-cpp Node writes through into the tree.
      if (node.IsSequence()) {
        if (!allDigits(segment)) {
          fail("axes." + axis.key, prefix + " is a list: expected an index after it, got " + segment);
        }
        std::size_t index = 0;
        std::from_chars(segment.data(), segment.data() + segment.size(), index);  // > 9 digits: refused below
        if (segment.size() > 9 || index >= node.size()) {
          fail("axes." + axis.key, prefix + " has " + std::to_string(node.size()) +
                                       (node.size() == 1 ? " entry" : " entries") + ": no index " + segment);
        }
        if (last) {
          node[index] = YAML::Clone(value);
        } else {
          node.reset(node[index]);
        }
      } else if (node.IsMap()) {
        const YAML::Node& lookup = node;
        const YAML::Node child = lookup[segment];
        if (last) {
          node[segment] = YAML::Clone(value);
        } else if (!child.IsDefined() || child.IsNull()) {
          node[segment] = YAML::Node(YAML::NodeType::Map);
          node.reset(node[segment]);
        } else {
          node.reset(node[segment]);
        }
      } else {
        fail("axes." + axis.key, prefix + " is a value (" + flowText(node) + "), not a section");
      }
      prefix += (prefix.empty() ? "" : ".") + segment;
    }
  }

  // The scenario YAML of run k.
  std::string runYaml(const Sweep& sweep, const YAML::Node& base, std::size_t k) const {
    YAML::Node root = YAML::Clone(base);
    const auto combination = sweep.combination(k);
    for (std::size_t a = 0; a < sweep.axes.size(); ++a) set(root, sweep.axes[a], values_[a][combination[a]]);
    root["name"] = sweep.name + "_" + std::to_string(k);
    return emitYaml(root);
  }

  void validateAll(Sweep& sweep, std::size_t count) {
    const std::string base_where = where_ + ": base";
    YAML::Node base;
    try {
      const auto docs = YAML::LoadAll(base_text_);
      if (docs.size() == 1 && docs.front().IsMap()) base = docs.front();
    } catch (const YAML::Exception&) {
    }
    if (!base.IsMap()) {
      // Not a mapping: the scenario reader words the problem as for `ambler run`.
      try {
        parseScenario(base_text_, sweep.base);
      } catch (const ScenarioError& e) {
        throw SweepError(base_where + ": " + e.what());
      }
      throw SweepError(base_where + ": " + sweep.base.string() + ": expected a mapping of scenario keys");
    }
    const std::string base_prefix = sweep.base.string() + ": ";
    sweep.runs.reserve(count);
    for (std::size_t k = 0; k < count; ++k) {
      try {
        sweep.runs.push_back(parseScenario(runYaml(sweep, base, k), sweep.base));
      } catch (const ScenarioError& e) {
        throw SweepError(blame(sweep, base, k, e.what(), base_prefix));
      }
    }
  }

  // Names the axis whose key the scenario reader's message is about; else the base, when it fails
  // on its own; else the whole combination.
  std::string blame(const Sweep& sweep, const YAML::Node& base, std::size_t k, const std::string& message,
                    const std::string& base_prefix) const {
    const auto combination = sweep.combination(k);
    if (message.starts_with(base_prefix)) {
      const std::string_view rest = std::string_view(message).substr(base_prefix.size());
      for (std::size_t a = 0; a < sweep.axes.size(); ++a) {
        const std::string path = readerPath(sweep.axes[a].key);
        if (rest.starts_with(path) && rest.size() > path.size() &&
            std::string_view(":[.").find(rest[path.size()]) != std::string_view::npos) {
          return where_ + ": axes." + sweep.axes[a].key + " = " + sweep.axes[a].values[combination[a]] +
                 ": " + message;
        }
      }
    }
    try {
      YAML::Node unchanged = YAML::Clone(base);
      unchanged["name"] = sweep.name + "_0";
      parseScenario(emitYaml(unchanged), sweep.base);
    } catch (const ScenarioError& e) {
      if (e.what() == message) return where_ + ": base: " + message;
    }
    std::string values;
    for (std::size_t a = 0; a < sweep.axes.size(); ++a) {
      values += (a ? ", " : "") + sweep.axes[a].key + " = " + sweep.axes[a].values[combination[a]];
    }
    return where_ + ": run " + std::to_string(k) + " (" + values + "): " + message;
  }

  fs::path file_;
  std::string where_;
  std::string base_text_;
  std::vector<std::vector<YAML::Node>> values_;  // per axis, its values as YAML
};

// ---- results ----------------------------------------------------------------------------------

using Row = std::vector<std::pair<std::string, std::string>>;  // column, cell text

std::string numberText(double v) {
  if (!std::isfinite(v)) return "";  // as in metrics.json, where a non-finite number is null
  char buf[32];
  return std::string(buf, std::to_chars(buf, buf + sizeof buf, v).ptr);
}

// The scalar leaves of metrics.json in document order, arrays by index: map.0.rms_error_m.
void flatten(const nlohmann::ordered_json& j, const std::string& path, bool timing, Row& out) {
  if (j.is_object() || j.is_array()) {
    std::size_t i = 0;
    for (auto it = j.begin(); it != j.end(); ++it, ++i) {
      const std::string key = j.is_object() ? it.key() : std::to_string(i);
      if (path.empty() && key == "timing_s" && !timing) continue;
      flatten(*it, path.empty() ? key : path + "." + key, timing, out);
    }
    return;
  }
  std::string text;
  if (j.is_number_float()) {
    text = numberText(j.get<double>());
  } else if (j.is_number_unsigned()) {
    text = std::to_string(j.get<std::uint64_t>());
  } else if (j.is_number_integer()) {
    text = std::to_string(j.get<std::int64_t>());
  } else if (j.is_boolean()) {
    text = j.get<bool>() ? "true" : "false";
  } else if (j.is_string()) {
    text = j.get<std::string>();
  }
  out.emplace_back(path, std::move(text));
}

std::string csvCell(const std::string& text) {
  if (text.find_first_of(",\"\r\n") == std::string::npos) return text;
  std::string out = "\"";
  for (const char c : text) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

std::string csvText(const std::vector<std::string>& cells) {
  std::string out;
  for (std::size_t i = 0; i < cells.size(); ++i) out += (i ? "," : "") + csvCell(cells[i]);
  return out;
}

std::string csvLine(const std::vector<std::string>& cells) { return csvText(cells) + "\n"; }

// RFC 4180 records; nullopt when a quote is left open or stray.
std::optional<std::vector<std::vector<std::string>>> parseCsv(const std::string& text) {
  std::vector<std::vector<std::string>> records;
  std::vector<std::string> record;
  std::string cell;
  bool quoted = false, was_quoted = false;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (quoted) {
      if (c != '"') {
        cell += c;
      } else if (i + 1 < text.size() && text[i + 1] == '"') {
        cell += '"';
        ++i;
      } else {
        quoted = false;
      }
    } else if (c == '"') {
      if (!cell.empty() || was_quoted) return std::nullopt;
      quoted = was_quoted = true;
    } else if (c == ',') {
      record.push_back(std::move(cell));
      cell.clear();
      was_quoted = false;
    } else if (c == '\n' || c == '\r') {
      if (c == '\r' && i + 1 < text.size() && text[i + 1] == '\n') ++i;
      record.push_back(std::move(cell));
      records.push_back(std::move(record));
      record.clear();
      cell.clear();
      was_quoted = false;
    } else {
      if (was_quoted) return std::nullopt;
      cell += c;
    }
  }
  if (quoted) return std::nullopt;
  if (!cell.empty() || !record.empty() || was_quoted) {
    record.push_back(std::move(cell));
    records.push_back(std::move(record));
  }
  return records;
}

// Metric columns in the order they first appear in run order, a column new in a later run placed
// after its predecessor in that run, so the columns read as metrics.json does.
std::vector<std::string> metricColumns(const Sweep& sweep, const std::vector<Row>& rows) {
  if (!sweep.metrics.empty()) return sweep.metrics;
  std::vector<std::string> columns;
  for (const auto& row : rows) {
    std::size_t at = 0;
    for (const auto& [name, cell] : row) {
      const auto it = std::find(columns.begin(), columns.end(), name);
      if (it == columns.end()) {
        columns.insert(columns.begin() + std::ptrdiff_t(at), name);
        ++at;
      } else {
        at = std::size_t(it - columns.begin()) + 1;
      }
    }
  }
  // An axis that is also a metric (seed) is already a column.
  std::erase_if(columns, [&](const std::string& c) {
    return c == "run" ||
           std::any_of(sweep.axes.begin(), sweep.axes.end(), [&](const SweepAxis& a) { return a.key == c; });
  });
  return columns;
}

std::vector<std::string> axisCells(const Sweep& sweep, std::size_t k) {
  std::vector<std::string> cells{std::to_string(k)};
  const auto combination = sweep.combination(k);
  for (std::size_t a = 0; a < sweep.axes.size(); ++a) cells.push_back(sweep.axes[a].cells[combination[a]]);
  return cells;
}

std::string shardName(const Shard& s) {
  return "results.shard-" + std::to_string(s.index) + "-of-" + std::to_string(s.count) + ".csv";
}

// Keeps what `keep` asks for of a finished run directory.
void prune(const fs::path& dir, Keep keep) {
  if (keep == Keep::All) return;
  if (keep == Keep::None) {
    fs::remove_all(dir);
    return;
  }
  std::vector<fs::path> bulky;
  for (const auto& entry : fs::directory_iterator(dir)) {
    const auto name = entry.path().filename();
    if (name != "metrics.json" && name != "scenario.resolved.yaml") bulky.push_back(entry.path());
  }
  for (const auto& path : bulky) fs::remove_all(path);
}

std::string progressLine(const Sweep& sweep, std::size_t k, const nlohmann::ordered_json& metrics) {
  std::string line = "run " + std::to_string(k) + ":";
  const auto combination = sweep.combination(k);
  for (std::size_t a = 0; a < sweep.axes.size(); ++a) {
    line += " " + sweep.axes[a].key + "=" + sweep.axes[a].cells[combination[a]];
  }
  const auto first = [&](const char* section, const char* key) -> std::optional<double> {
    if (!metrics.contains(section) || metrics[section].empty()) return std::nullopt;
    const auto& v = metrics[section][0];
    if (!v.contains(key) || !v[key].is_number()) return std::nullopt;
    return v[key].get<double>();
  };
  char buf[64];
  if (const auto rms = first("map", "rms_error_m")) {
    std::snprintf(buf, sizeof buf, " rms=%.4g m", *rms);
    line += buf;
  } else if (const auto range = first("scan", "range_error_rms_m")) {
    std::snprintf(buf, sizeof buf, " range_rms=%.4g m", *range);
    line += buf;
  }
  if (const auto cartesian = first("map_cartesian", "rms_error_m")) {
    std::snprintf(buf, sizeof buf, " cartesian_rms=%.4g m", *cartesian);
    line += buf;
  }
  return line;
}

}  // namespace

std::vector<std::size_t> Sweep::combination(std::size_t k) const {
  std::vector<std::size_t> index(axes.size());
  for (std::size_t a = axes.size(); a-- > 0;) {
    index[a] = k % axes[a].values.size();
    k /= axes[a].values.size();
  }
  return index;
}

Sweep parseSweep(const std::string& yaml_text, const fs::path& file) {
  return SweepReader(file).read(yaml_text);
}

Sweep loadSweep(const fs::path& file) { return parseSweep(readText(file, file.string()), file); }

std::optional<std::vector<std::vector<std::string>>> parseResultsCsv(const std::string& text) {
  return parseCsv(text);
}

Shard parseShard(const std::string& text) {
  const auto parts = split(text, '/');
  Shard s;
  const auto parse = [](const std::string& p, int& v) {
    return allDigits(p) && p.size() <= 9 &&
           std::from_chars(p.data(), p.data() + p.size(), v).ec == std::errc();
  };
  if (parts.size() != 2 || !parse(parts[0], s.index) || !parse(parts[1], s.count) || s.index < 1 ||
      s.index > s.count) {
    throw SweepError("--shard: expected K/N with 1 <= K <= N (shard K of N, 1-based), got " +
                     yamlQuoted(text));
  }
  return s;
}

Keep parseKeep(const std::string& text) {
  if (text == "none") return Keep::None;
  if (text == "metrics") return Keep::Metrics;
  if (text == "all") return Keep::All;
  throw SweepError("--keep: expected one of none, metrics, all, got " + yamlQuoted(text));
}

fs::path runSweep(const Sweep& sweep, const SweepOptions& opt) {
  if (opt.jobs < 1) throw SweepError("--jobs: expected an integer >= 1, got " + std::to_string(opt.jobs));
  const std::size_t total = sweep.runs.size();
  if (opt.shard && std::size_t(opt.shard->count) > total) {
    throw SweepError("--shard: " + std::to_string(opt.shard->index) + "/" + std::to_string(opt.shard->count) +
                     ": the sweep has " + std::to_string(total) + " runs, so at most " +
                     std::to_string(total) + " shards");
  }
  std::vector<std::size_t> todo;
  for (std::size_t k = 0; k < total; ++k) {
    if (!opt.shard || k % std::size_t(opt.shard->count) == std::size_t(opt.shard->index - 1))
      todo.push_back(k);
  }
  const fs::path csv = opt.out / (opt.shard ? shardName(*opt.shard) : "results.csv");
  const std::size_t jobs = std::min<std::size_t>(std::size_t(opt.jobs), todo.size());

  std::mutex mutex;  // guards stderr, `done` and the first error
  const auto say = [&](const std::string& line) {
    if (opt.progress) std::fprintf(stderr, "ambler: %s\n", line.c_str());
  };
  say("sweep " + sweep.name + ": " + std::to_string(todo.size()) + " of " + std::to_string(total) + " runs" +
      (opt.shard
           ? " (shard " + std::to_string(opt.shard->index) + " of " + std::to_string(opt.shard->count) + ")"
           : "") +
      ", " + std::to_string(jobs) + (jobs == 1 ? " job" : " jobs") + " -> " + opt.out.string());
  fs::create_directories(opt.out / "runs");

  std::vector<Row> rows(todo.size());
  std::atomic<std::size_t> next{0};
  std::atomic<bool> stop{false};
  std::size_t done = 0;
  std::optional<std::pair<std::size_t, std::string>> error;  // the failed run of lowest index
  const auto work = [&] {
    for (std::size_t i; !stop && (i = next++) < todo.size();) {
      const std::size_t k = todo[i];
      try {
        const fs::path dir = opt.out / "runs" / std::to_string(k);
        fs::remove_all(dir);  // no files of an earlier sweep left beside this run's
        const auto metrics = runScenario(sweep.runs[k], RunOptions{dir, false});
        flatten(metrics, "", opt.timing, rows[i]);
        prune(dir, opt.keep);
        const std::lock_guard lock(mutex);
        ++done;
        say("[" + std::to_string(done) + "/" + std::to_string(todo.size()) + "] " +
            progressLine(sweep, k, metrics));
      } catch (const std::exception& e) {
        stop = true;
        const std::lock_guard lock(mutex);
        if (!error || k < error->first) error.emplace(k, e.what());
      }
    }
  };
  if (jobs <= 1) {
    work();
  } else {
    std::vector<std::jthread> threads;
    for (std::size_t j = 0; j < jobs; ++j) threads.emplace_back(work);
  }
  if (error) {
    std::string values;
    const auto combination = sweep.combination(error->first);
    for (std::size_t a = 0; a < sweep.axes.size(); ++a) {
      values += (a ? ", " : "") + sweep.axes[a].key + " = " + sweep.axes[a].values[combination[a]];
    }
    throw SweepError(sweep.file.string() + ": run " + std::to_string(error->first) + " (" + values +
                     "): " + error->second);
  }
  if (opt.keep == Keep::None) {
    std::error_code ec;
    fs::remove(opt.out / "runs", ec);  // only if empty
  }

  const auto columns = metricColumns(sweep, rows);
  std::vector<std::string> header{"run"};
  for (const auto& axis : sweep.axes) header.push_back(axis.key);
  header.insert(header.end(), columns.begin(), columns.end());
  std::string text = csvLine(header);
  for (std::size_t i = 0; i < todo.size(); ++i) {
    std::unordered_map<std::string, std::string> cells(rows[i].begin(), rows[i].end());
    auto line = axisCells(sweep, todo[i]);
    for (const auto& column : columns) line.push_back(cells.count(column) ? cells[column] : "");
    text += csvLine(line);
  }
  writeText(csv, text);
  say("wrote " + csv.string() + " (" + std::to_string(todo.size()) + " rows, " +
      std::to_string(header.size()) + " columns)");
  return csv;
}

fs::path mergeSweep(const Sweep& sweep, const fs::path& out, bool progress) {
  const std::string where = out.string();
  std::error_code ec;
  if (!fs::is_directory(out, ec)) throw SweepError(where + ": no such directory");
  const std::regex pattern(R"(results\.shard-([0-9]{1,9})-of-([0-9]{1,9})\.csv)");
  std::vector<std::pair<Shard, fs::path>> files;
  for (const auto& entry : fs::directory_iterator(out)) {
    std::smatch m;
    const std::string name = entry.path().filename().string();
    if (!std::regex_match(name, m, pattern)) continue;
    files.emplace_back(Shard{std::stoi(m[1]), std::stoi(m[2])}, entry.path());
  }
  if (files.empty()) throw SweepError(where + ": no results.shard-K-of-N.csv files to merge");
  std::sort(files.begin(), files.end(), [](const auto& a, const auto& b) {
    return std::pair(a.first.count, a.first.index) < std::pair(b.first.count, b.first.index);
  });
  const int n = files.front().first.count;
  if (files.back().first.count != n) {
    throw SweepError(where + ": shards of different splits (" + files.front().second.filename().string() +
                     ", " + files.back().second.filename().string() + "): remove the stale ones");
  }
  for (const auto& [shard, path] : files) {
    if (shard.index < 1 || shard.index > n)
      throw SweepError(path.string() + ": no shard " + std::to_string(shard.index) + " of " +
                       std::to_string(n));
  }
  for (int k = 1; k <= n; ++k) {
    if (std::none_of(files.begin(), files.end(), [&](const auto& f) { return f.first.index == k; })) {
      throw SweepError((out / shardName(Shard{k, n})).string() + ": missing (shard " + std::to_string(k) +
                       " of " + std::to_string(n) + ")");
    }
  }

  const std::size_t total = sweep.runs.size();
  std::vector<std::string> axes_header{"run"};
  for (const auto& axis : sweep.axes) axes_header.push_back(axis.key);
  std::vector<std::string> header;
  fs::path header_file;
  std::vector<std::optional<std::vector<std::string>>> rows(total);
  std::vector<fs::path> row_file(total);
  for (const auto& [shard, path] : files) {
    const std::string name = path.string();
    const auto records = parseCsv(readText(path, name));
    if (!records) throw SweepError(name + ": not a CSV file (an open or stray quote)");
    if (records->empty()) throw SweepError(name + ": empty, expected a header row");
    const auto& head = records->front();
    if (header_file.empty()) {
      if (head.size() < axes_header.size() ||
          !std::equal(axes_header.begin(), axes_header.end(), head.begin())) {
        throw SweepError(name + ": header does not start with run and the sweep's axes (" +
                         csvText(axes_header) + ")");
      }
      header = head;
      header_file = path;
    } else if (head != header) {
      throw SweepError(name + ": header differs from " + header_file.string() + "'s");
    }
    for (std::size_t r = 1; r < records->size(); ++r) {
      const auto& row = (*records)[r];
      const std::string at = name + ": row " + std::to_string(r + 1) + ": ";
      if (row.size() != header.size()) {
        throw SweepError(at + "expected " + std::to_string(header.size()) + " cells, got " +
                         std::to_string(row.size()));
      }
      std::size_t k = 0;
      if (!allDigits(row[0]) || row[0].size() > 9 || (k = std::stoul(row[0])) >= total) {
        throw SweepError(at + "expected a run index in [0, " + std::to_string(total - 1) + "], got " +
                         yamlQuoted(row[0]));
      }
      if (k % std::size_t(n) != std::size_t(shard.index - 1)) {
        throw SweepError(at + "run " + std::to_string(k) + " belongs to shard " + std::to_string(k % n + 1) +
                         " of " + std::to_string(n));
      }
      if (rows[k])
        throw SweepError(at + "run " + std::to_string(k) + " is duplicated (also in " + row_file[k].string() +
                         ")");
      const auto expected = axisCells(sweep, k);
      if (!std::equal(expected.begin(), expected.end(), row.begin())) {
        throw SweepError(at + "run " + std::to_string(k) + ": cells " +
                         csvText({row.begin(), row.begin() + std::ptrdiff_t(expected.size())}) +
                         " differ from the sweep file's " + csvText(expected) +
                         " (was it edited after the shards ran?)");
      }
      rows[k] = row;
      row_file[k] = path;
    }
  }
  for (std::size_t k = 0; k < total; ++k) {
    if (!rows[k]) {
      throw SweepError(where + ": run " + std::to_string(k) + " is missing (expected in " +
                       shardName(Shard{int(k % std::size_t(n)) + 1, n}) + ")");
    }
  }
  std::string text = csvLine(header);
  for (const auto& row : rows) text += csvLine(*row);
  const fs::path csv = out / "results.csv";
  writeText(csv, text);
  if (progress) {
    std::fprintf(stderr, "ambler: merged %d shards into %s (%zu rows)\n", n, csv.string().c_str(), total);
  }
  return csv;
}

}  // namespace ambler::eval
