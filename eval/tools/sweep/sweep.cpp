// Sweeps: axes of values at dotted key paths into a base scenario's YAML; every combination is
// written back as YAML and read by the strict scenario reader before anything runs.
// docs/sweeps.md is the schema. Running and sharding are in sweep_run.cpp; results.csv and
// merging shards in sweep_results.cpp.
#include "eval/tools/sweep/sweep.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <charconv>
#include <string_view>
#include <unordered_map>
#include <utility>

#include "base/read_file.hpp"
#include "base/text.hpp"
#include "eval/scenario/message_text.hpp"
#include "eval/tools/sweep/sweep_internal.hpp"
#include "eval/scenario/yaml_documents.hpp"

namespace ambler::eval {
namespace {

namespace fs = std::filesystem;
using namespace sweep_detail;
using base::allDigits;
using base::split;

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
      const YAML::Node key = it->first;  // by value: it->first lives only until the ';'
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

}  // namespace

// ---- the sweep file ---------------------------------------------------------------------------

namespace sweep_detail {

std::string readText(const fs::path& file, const std::string& who) {
  try {
    return base::readFile(file);
  } catch (const base::ReadError& e) {
    throw SweepError(who + ": " + e.what());
  }
}

}  // namespace sweep_detail

namespace {

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

class SweepReader {
 public:
  explicit SweepReader(const fs::path& file)
      : file_(file), where_(file.empty() ? "<string>" : file.string()) {}

  [[noreturn]] void fail(const std::string& key, const std::string& what) const {
    // Escaped: a key or a yaml-cpp message may hold a line break (docs/fuzzing.md).
    throw SweepError(where_ + ": " + (key.empty() ? "" : escapedLine(key) + ": ") + escapedLine(what));
  }

  Sweep read(const std::string& text) {
    std::vector<YAML::Node> docs;
    try {
      docs = loadAllDocuments(text);  // not YAML::LoadAll: it can hang
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
      const YAML::Node values = it->second;  // by value: it->second lives only until the ';'
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
      const auto docs = loadAllDocuments(base_text_);
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

}  // namespace ambler::eval
