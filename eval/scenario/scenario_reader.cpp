// The strict scenario reader's vocabulary for scalars: how a number is recognised, how a value is
// named in a message, and which key the user probably meant. Reader and Fields
// (scenario_reader.hpp) use these; the schema is in scenario.cpp.
#include "eval/scenario/scenario_reader.hpp"

#include <algorithm>
#include <charconv>
#include <cstddef>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace ambler::eval {
namespace {

using namespace scenario_detail;

std::size_t editDistance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = up;
    }
  }
  return row[b.size()];
}

// The key without its unit suffix: "rpy_deg" -> "rpy".
std::string_view stem(std::string_view key) {
  const auto underscore = key.rfind('_');
  return underscore == std::string_view::npos ? key : key.substr(0, underscore);
}

// Text from the file, made safe for a one-line message: control characters escaped, long text cut.
std::string oneLine(std::string_view text) {
  std::string out;
  for (const char c : text.substr(0, 60)) {
    if (c == '\n')
      out += "\\n";
    else if (c == '\t')
      out += "\\t";
    else if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f)
      out += '?';
    else
      out += c;
  }
  return text.size() > 60 ? out + "..." : out;
}

}  // namespace

namespace scenario_detail {

// The closest of `candidates` to a mistyped `word`, if one is close: a small edit distance, or the
// same name with a missing or different unit suffix (relief -> relief_m, rpy_rad -> rpy_deg).
std::optional<std::string_view> closest(std::string_view word,
                                        const std::vector<std::string_view>& candidates) {
  std::optional<std::string_view> best;
  std::size_t best_distance = std::numeric_limits<std::size_t>::max();
  for (const auto candidate : candidates) {
    const std::size_t distance = editDistance(word, candidate);
    const bool near = distance <= std::max<std::size_t>(1, candidate.size() / 3);
    const bool same_stem = word == stem(candidate) || (word.find('_') != std::string_view::npos &&
                                                       stem(word) == stem(candidate));
    if ((near || same_stem) && distance < best_distance) {
      best = candidate;
      best_distance = distance;
    }
  }
  return best;
}

std::string joined(const std::vector<std::string_view>& words) {
  std::string out;
  for (const auto word : words) out += (out.empty() ? "" : ", ") + std::string(word);
  return out;
}

std::string inQuotes(std::string_view text) {
  std::string out(1, '\'');  // not "'" + ...: GCC 12 warns falsely on it (-Wrestrict, PR 105651)
  out += oneLine(text);
  return out += '\'';
}

// A plain scalar as YAML's core schema reads a number (with .inf/.nan); nullopt if it is not one.
// Out-of-range text (1e999, 1e-400) gives NaN so that it is reported, never rounded away.
std::optional<double> toDouble(std::string_view text) {
  std::string_view body = text;
  if (!body.empty() && (body[0] == '+' || body[0] == '-')) body.remove_prefix(1);
  if (body == ".inf" || body == ".Inf" || body == ".INF") return text[0] == '-' ? -kInf : kInf;
  if (body == ".nan" || body == ".NaN" || body == ".NAN") {
    return std::numeric_limits<double>::quiet_NaN();
  }
  if (body.empty() || body[0] == '+' || body[0] == '-') return std::nullopt;
  const std::string_view digits = text[0] == '+' ? body : text;  // from_chars takes no '+'
  double value = 0.0;
  const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), value);
  if (end != digits.data() + digits.size()) return std::nullopt;
  if (ec == std::errc::result_out_of_range) return std::numeric_limits<double>::quiet_NaN();
  if (ec != std::errc()) return std::nullopt;
  return value;
}

MatchMethod readMatchMethod(const Reader& reader, const YAML::Node& node, const std::string& path) {
  std::vector<std::string_view> names;
  for (const MatchMethod k : matchMethods()) names.emplace_back(matchMethodName(k));
  return *matchMethodFromName(reader.choice(node, path, names));
}

bool isQuoted(const YAML::Node& node) { return node.Tag() == "!"; }

// How a value is named in "got ..." of a message.
std::string shown(const YAML::Node& node) {
  switch (node.Type()) {
    case YAML::NodeType::Null:
      return "nothing";
    case YAML::NodeType::Sequence:
      return "a list of " + std::to_string(node.size());
    case YAML::NodeType::Map:
      return "a mapping";
    case YAML::NodeType::Scalar:
      if (isQuoted(node)) return "the string " + inQuotes(node.Scalar());
      return toDouble(node.Scalar()) ? oneLine(node.Scalar()) : inQuotes(node.Scalar());
    case YAML::NodeType::Undefined:
      break;
  }
  return "nothing";
}

}  // namespace scenario_detail
}  // namespace ambler::eval
