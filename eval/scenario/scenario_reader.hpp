#pragma once
// Internal to eval/scenario*.cpp: the strict reader's typed access to YAML values. Reader checks
// one value and fails with "<file>: <key path>: <what is wrong>"; Fields checks one mapping's keys.
// The schema that uses them (which keys, which ranges) is in scenario.cpp and, for the traverse
// section, scenario_traverse.cpp; the helpers declared here are defined in scenario_reader.cpp,
// the traverse section's functions at the end of this file in scenario_traverse.cpp.
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "eval/scenario/message_text.hpp"
#include "eval/scenario/scenario.hpp"
#include "eval/scenario/scenario_internal.hpp"

namespace ambler::eval::scenario_detail {

// The closest of `candidates` to a mistyped `word`, if one is close.
std::optional<std::string_view> closest(std::string_view word,
                                        const std::vector<std::string_view>& candidates);
std::string joined(const std::vector<std::string_view>& words);
// Text from the file in single quotes, made safe for a one-line message.
std::string inQuotes(std::string_view text);
// A plain scalar as YAML's core schema reads a number; nullopt if it is not one.
std::optional<double> toDouble(std::string_view text);
bool isQuoted(const YAML::Node& node);
// How a value is named in "got ..." of a message.
std::string shown(const YAML::Node& node);

struct Range {
  double lo = -kInf;
  double hi = kInf;
  bool lo_open = false;
  bool hi_open = false;

  bool contains(double v) const {
    return (lo_open ? v > lo : v >= lo) && (hi_open ? v < hi : v <= hi);
  }
  std::string text() const {
    if (lo == -kInf && hi == kInf) return "";
    if (hi == kInf) return (lo_open ? " > " : " >= ") + shortest(lo);
    if (lo == -kInf) return (hi_open ? " < " : " <= ") + shortest(hi);
    return std::string(" in ") + (lo_open ? "(" : "[") + shortest(lo) + ", " + shortest(hi) +
           (hi_open ? ")" : "]");
  }
};

constexpr Range kAny{};
constexpr Range kPositive{0.0, kInf, true, false};
constexpr Range kNonNegative{0.0, kInf, false, false};

// Reads values out of one document, failing with "<file>: <key path>: <what is wrong>".
class Reader {
 public:
  explicit Reader(std::string file) : file_(std::move(file)) {}

  [[noreturn]] void fail(std::string_view path, const std::string& what) const {
    // Escaped: a key or a yaml-cpp message may hold a line break (docs/fuzzing.md).
    throw ScenarioError(file_ + ": " + (path.empty() ? "" : escapedLine(path) + ": ") + escapedLine(what));
  }

  double number(const YAML::Node& node, const std::string& path, const Range& range) const {
    const auto value = node.IsScalar() && !isQuoted(node) ? toDouble(node.Scalar()) : std::nullopt;
    if (!value) fail(path, "expected a number" + range.text() + ", got " + shown(node));
    if (!std::isfinite(*value)) {
      std::string text = node.Scalar();
      std::transform(text.begin(), text.end(), text.begin(),
                     [](unsigned char c) { return std::tolower(c); });
      if (text.find("inf") == std::string::npos && text.find("nan") == std::string::npos) {
        fail(path, "expected a number" + range.text() + ", got " + shown(node) +
                       ", beyond the range of a double");
      }
      fail(path, "expected a finite number" + range.text() + ", got " + shown(node));
    }
    if (!range.contains(*value))
      fail(path, "expected a number" + range.text() + ", got " + shown(node));
    return *value;
  }

  // An integer written as one: 2.5, 64.0 and 1e3 are not.
  template <typename Int>
  Int integer(const YAML::Node& node, const std::string& path, Int lo, Int hi) const {
    const std::string top = std::cmp_equal(hi, std::numeric_limits<std::uint64_t>::max())
                                ? "2^64 - 1"
                                : std::to_string(hi);
    const std::string expected =
        "expected an integer in [" + std::to_string(lo) + ", " + top + "], got " + shown(node);
    if (!node.IsScalar() || isQuoted(node)) fail(path, expected);
    std::string_view text = node.Scalar();
    if (!text.empty() && text[0] == '+') text.remove_prefix(1);
    Int value = 0;
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
    if (ec != std::errc() || end != text.data() + text.size() || value < lo || value > hi) {
      fail(path, expected);
    }
    return value;
  }

  bool boolean(const YAML::Node& node, const std::string& path) const {
    if (node.IsScalar() && !isQuoted(node)) {
      const std::string& text = node.Scalar();
      if (text == "true" || text == "True" || text == "TRUE") return true;
      if (text == "false" || text == "False" || text == "FALSE") return false;
    }
    fail(path, "expected true or false, got " + shown(node));
  }

  std::string string(const YAML::Node& node, const std::string& path) const {
    if (!node.IsScalar()) fail(path, "expected a string, got " + shown(node));
    return node.Scalar();
  }

  std::string_view choice(const YAML::Node& node, const std::string& path,
                          const std::vector<std::string_view>& allowed) const {
    if (node.IsScalar()) {
      const auto it = std::find(allowed.begin(), allowed.end(), node.Scalar());
      if (it != allowed.end()) return *it;
    }
    std::string what = "expected one of " + joined(allowed) + ", got " + shown(node);
    if (node.IsScalar()) {
      if (const auto guess = closest(node.Scalar(), allowed)) {
        what += " (did you mean " + std::string(*guess) + "?)";
      }
    }
    fail(path, what);
  }

  template <std::size_t N>
  std::array<double, N> numbers(const YAML::Node& node, const std::string& path,
                                const Range& range) const {
    if (!node.IsSequence() || node.size() != N) {
      fail(path, "expected a list of " + std::to_string(N) + " numbers, got " + shown(node));
    }
    std::array<double, N> out{};
    for (std::size_t i = 0; i < N; ++i) {
      out[i] = number(node[i], path + "[" + std::to_string(i) + "]", range);
    }
    return out;
  }

 private:
  std::string file_;
};

// One YAML mapping, its keys checked against the schema when it is opened: an unknown or
// repeated key fails before any value is read.
class Fields {
 public:
  Fields(const Reader& reader, const YAML::Node& node, std::string path,
         std::vector<std::string_view> allowed)
      : reader_(reader), path_(std::move(path)) {
    if (!node.IsMap()) {
      reader_.fail(path_, std::string(path_.empty() ? "expected a mapping of scenario keys"
                                                    : "expected a mapping") +
                              ", got " + shown(node));
    }
    for (const auto& entry : node) {
      if (!entry.first.IsScalar()) {
        reader_.fail(path_, "expected plain names as keys, got " + shown(entry.first));
      }
      const std::string& key = entry.first.Scalar();
      if (std::find(allowed.begin(), allowed.end(), key) == allowed.end()) {
        const auto guess = closest(key, allowed);
        reader_.fail(pathOf(key), guess ? "unknown key (did you mean " + std::string(*guess) + "?)"
                                        : "unknown key (allowed: " + joined(allowed) + ")");
      }
      for (const auto& [seen, value] : entries_) {
        if (seen == key) reader_.fail(pathOf(key), "duplicate key");
      }
      entries_.emplace_back(key, entry.second);
    }
  }

  std::optional<YAML::Node> get(std::string_view key) const {
    for (const auto& [name, value] : entries_) {
      if (name == key) return value;
    }
    return std::nullopt;
  }

  YAML::Node required(std::string_view key) const {
    auto value = get(key);
    if (!value) reader_.fail(pathOf(key), "missing required key");
    return *value;
  }

  std::string pathOf(std::string_view key) const {
    return path_.empty() ? std::string(key) : path_ + "." + std::string(key);
  }

  // Typed optional values: the fallback when the key is absent.
  double number(std::string_view key, const Range& range, double fallback) const {
    const auto value = get(key);
    return value ? reader_.number(*value, pathOf(key), range) : fallback;
  }
  template <std::size_t N>
  std::optional<std::array<double, N>> numbers(std::string_view key, const Range& range) const {
    const auto value = get(key);
    if (!value) return std::nullopt;
    return reader_.numbers<N>(*value, pathOf(key), range);
  }
  int integer(std::string_view key, int lo, int hi, int fallback) const {
    const auto value = get(key);
    return value ? reader_.integer(*value, pathOf(key), lo, hi) : fallback;
  }
  bool boolean(std::string_view key, bool fallback) const {
    const auto value = get(key);
    return value ? reader_.boolean(*value, pathOf(key)) : fallback;
  }
  std::string choice(std::string_view key, const std::vector<std::string_view>& allowed,
                     const std::string& fallback) const {
    const auto value = get(key);
    return value ? std::string(reader_.choice(*value, pathOf(key), allowed)) : fallback;
  }

 private:
  const Reader& reader_;
  std::string path_;
  std::vector<std::pair<std::string, YAML::Node>> entries_;
};

// A matching method by its scenario name (matchMethodName's words), as matching.methods and
// traverse.method take it; fails naming `path` for any other value.
MatchMethod readMatchMethod(const Reader& reader, const YAML::Node& node, const std::string& path);

// The traverse section (docs/scenario.md, "traverse"), its path checked over the terrain (a
// generated one: an MJCF world's extent is known once it is loaded).
TraverseSpec readTraverse(const Reader& reader, const YAML::Node& node, const terrains::TerrainSpec& terrain);
// The top-level sections a traverse replaces (views, merge) or does not support (footfall, leg),
// refused beside it by name.
void refuseBesideTraverse(const Reader& reader, const Fields& top);
// The matching keys a traverse sets itself (pairs, methods, the initial error) or does not take
// (prior, gate), refused in its matching section by name.
void refuseMatchingKeysInTraverse(const Reader& reader, const Fields& matching);

}  // namespace ambler::eval::scenario_detail
