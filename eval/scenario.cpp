// Scenario YAML: a strict reader (every key known, every value typed and range-checked, errors that
// name the file and the key path) and the resolved form (every default written out, numbers that
// read back bit for bit). docs/scenario.md is the schema; keep the two in step.
#include "eval/scenario.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cctype>
#include <charconv>
#include <cmath>
#include <fstream>
#include <initializer_list>
#include <limits>
#include <numbers>
#include <sstream>
#include <string_view>
#include <utility>

namespace ambler::eval {
namespace {

namespace fs = std::filesystem;
using terrains::TerrainKind;

constexpr double kInf = std::numeric_limits<double>::infinity();
// Bounds a grid (terrain samples or map cells) so a typo in a cell size cannot exhaust memory.
constexpr double kMaxGridPoints = 25e6;

constexpr std::array<std::pair<std::string_view, TerrainKind>, 6> kKinds{{
    {"plane", TerrainKind::Plane},
    {"fractal", TerrainKind::Fractal},
    {"sinusoid", TerrainKind::Sinusoid},
    {"steps", TerrainKind::Steps},
    {"mars", TerrainKind::Mars},
    {"mjcf", TerrainKind::Mjcf},
}};

// The same expression as SensorSpec's defaults (deg·π/180), so `fov_deg: [30, 80]` gives exactly
// the default radians.
double degToRad(double deg) { return deg * std::numbers::pi / 180.0; }

bool sameBits(double a, double b) {
  return std::bit_cast<std::uint64_t>(a) == std::bit_cast<std::uint64_t>(b);
}

// The shortest text that reads back as the same double, in fixed notation where that is how a
// person would write it (0.0003, 40) and in scientific notation otherwise (1e-05, 1e+21).
std::string shortest(double v) {
  std::array<char, 64> buf{};  // fixed: at most 16 digits before the point and 21 after it
  const double magnitude = std::abs(v);
  const auto format = (magnitude == 0.0 || (magnitude >= 1e-4 && magnitude < 1e16))
                          ? std::chars_format::fixed
                          : std::chars_format::scientific;
  const auto end = std::to_chars(buf.data(), buf.data() + buf.size(), v, format).ptr;
  return std::string(buf.data(), end);
}

// The shortest degree text that degToRad maps back to exactly `rad`. Degrees are read as doubles
// and converted with one rounding per operation, so every parsed angle has such a text within a
// few ulps of rad·180/π (usually the text the user wrote). A radian value set in code may have
// none; then the degree value nearest to it is written.
std::string degreesText(double rad) {
  const double centre = rad * (180.0 / std::numbers::pi);
  if (!std::isfinite(centre)) return shortest(centre);
  // Stepping by nextafter skips one of ±0, so walk out from the centre in both directions.
  std::vector<double> candidates{centre};
  for (double up = centre, down = centre; candidates.size() < 17;) {
    candidates.push_back(up = std::nextafter(up, kInf));
    candidates.push_back(down = std::nextafter(down, -kInf));
  }
  std::string best;
  bool exact = false;
  double best_error = kInf;
  for (const double d : candidates) {
    const double back = degToRad(d);
    if (sameBits(back, rad)) {
      std::string text = shortest(d);
      if (!exact || text.size() < best.size()) best = std::move(text);
      exact = true;
    } else if (!exact && std::abs(back - rad) < best_error) {
      best_error = std::abs(back - rad);
      best = shortest(d);
    }
  }
  return best;
}

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
    throw ScenarioError(file_ + ": " + (path.empty() ? "" : std::string(path) + ": ") + what);
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

void checkGridSize(const Reader& reader, const std::string& path, double nx, double ny) {
  const auto count = [](double n) {
    if (n < 1e15) return shortest(n);
    std::array<char, 32> buf{};
    return std::string(
        buf.data(),
        std::to_chars(buf.data(), buf.data() + buf.size(), n, std::chars_format::general, 3).ptr);
  };
  if (nx * ny > kMaxGridPoints) {
    reader.fail(path, "expected at most " + shortest(kMaxGridPoints) + " grid points, got " +
                          count(nx) + " x " + count(ny));
  }
}

terrains::TerrainSpec readTerrain(const Reader& reader, const YAML::Node& node,
                                  const fs::path& file) {
  const Fields f(reader, node, "terrain",
                 {"kind", "size_m", "cell_m", "relief_m", "hurst", "slope_deg", "sinusoid", "steps",
                  "rocks", "craters", "mjcf"});
  terrains::TerrainSpec t;
  std::vector<std::string_view> kind_names;
  for (const auto& [name, kind] : kKinds) kind_names.push_back(name);
  const std::string_view kind_name =
      reader.choice(f.required("kind"), f.pathOf("kind"), kind_names);
  for (const auto& [name, kind] : kKinds) {
    if (name == kind_name) t.kind = kind;
  }

  if (const auto size = f.numbers<2>("size_m", {0.0, 500.0, true, false})) {
    t.size_m = {(*size)[0], (*size)[1]};
  }
  t.cell_m = f.number("cell_m", {0.0, 1.0, true, false}, t.cell_m);
  // Samples per side as terrains::makeTerrain counts them.
  const double samples_x = std::round(t.size_m.x() / t.cell_m) + 1;
  const double samples_y = std::round(t.size_m.y() / t.cell_m) + 1;
  if (samples_x < 2 || samples_y < 2) {
    reader.fail(f.pathOf("cell_m"), "expected at most twice the smaller side of size_m (" +
                                        shortest(2 * t.size_m.minCoeff()) +
                                        ") for two samples per side, got " + shortest(t.cell_m));
  }
  checkGridSize(reader, f.pathOf("cell_m"), samples_x, samples_y);
  t.relief_m = f.number("relief_m", kNonNegative, t.relief_m);
  t.hurst = f.number("hurst", {0.0, 1.0, true, true}, t.hurst);
  if (const auto slope = f.numbers<2>("slope_deg", {-60.0, 60.0, true, true})) {
    t.slope_deg = {(*slope)[0], (*slope)[1]};
  }

  if (const auto node_s = f.get("sinusoid")) {
    const Fields s(reader, *node_s, f.pathOf("sinusoid"), {"amplitude_m", "wavelength_m"});
    terrains::SinusoidSpec spec;
    spec.amplitude_m = s.number("amplitude_m", kNonNegative, spec.amplitude_m);
    spec.wavelength_m = s.number("wavelength_m", kPositive, spec.wavelength_m);
    t.sinusoid = spec;
  } else if (t.kind == TerrainKind::Sinusoid) {
    t.sinusoid = terrains::SinusoidSpec{};
  }

  if (const auto node_s = f.get("steps")) {
    if (!node_s->IsSequence() || (t.kind == TerrainKind::Steps && node_s->size() == 0)) {
      reader.fail(
          f.pathOf("steps"),
          std::string(t.kind == TerrainKind::Steps ? "expected a non-empty" : "expected a") +
              " list of steps, got " + shown(*node_s));
    }
    for (std::size_t i = 0; i < node_s->size(); ++i) {
      const Fields s(reader, (*node_s)[i], f.pathOf("steps") + "[" + std::to_string(i) + "]",
                     {"x_m", "height_m"});
      terrains::StepSpec step;
      step.x_m = s.number("x_m", kAny, step.x_m);
      step.height_m = s.number("height_m", kAny, step.height_m);
      t.steps.push_back(step);
    }
  } else if (t.kind == TerrainKind::Steps) {
    t.steps.push_back(terrains::StepSpec{});
  }

  // Kind mars has rocks and craters: the defaults unless given (as terrains::makeTerrain does).
  bool rock_max_given = false;
  if (const auto node_r = f.get("rocks")) {
    const Fields r(reader, *node_r, f.pathOf("rocks"),
                   {"abundance_k", "min_diameter_m", "max_diameter_m"});
    rock_max_given = r.get("max_diameter_m").has_value();
    terrains::RockSpec rocks;
    rocks.abundance_k = r.number("abundance_k", {0.0, 0.5, true, false}, rocks.abundance_k);
    rocks.min_diameter_m = r.number("min_diameter_m", kPositive, rocks.min_diameter_m);
    rocks.max_diameter_m = r.number("max_diameter_m", kPositive, rocks.max_diameter_m);
    if (!(rocks.max_diameter_m > rocks.min_diameter_m)) {
      reader.fail(r.pathOf("max_diameter_m"), "expected a number > min_diameter_m (" +
                                                  shortest(rocks.min_diameter_m) + "), got " +
                                                  shortest(rocks.max_diameter_m) +
                                                  (rock_max_given ? "" : " (the default)"));
    }
    t.rocks = rocks;
  } else if (t.kind == TerrainKind::Mars) {
    t.rocks = terrains::RockSpec{};
  }
  // Room to place the largest rock on the ground (terrains::makeTerrain's limit).
  if (t.rocks && t.rocks->max_diameter_m > 0.5 * t.size_m.minCoeff()) {
    reader.fail(f.pathOf("rocks") + ".max_diameter_m",
                "expected at most half the smaller side of size_m (" +
                    shortest(0.5 * t.size_m.minCoeff()) + "), got " +
                    shortest(t.rocks->max_diameter_m) + (rock_max_given ? "" : " (the default)"));
  }

  if (const auto node_c = f.get("craters")) {
    const Fields c(reader, *node_c, f.pathOf("craters"),
                   {"count", "min_diameter_m", "max_diameter_m", "sfd_exponent"});
    terrains::CraterSpec craters;
    craters.count = c.integer("count", 0, 1000, craters.count);
    craters.min_diameter_m = c.number("min_diameter_m", kPositive, craters.min_diameter_m);
    craters.max_diameter_m = c.number("max_diameter_m", kPositive, craters.max_diameter_m);
    if (!(craters.max_diameter_m >= craters.min_diameter_m)) {
      reader.fail(c.pathOf("max_diameter_m"),
                  "expected a number >= min_diameter_m (" + shortest(craters.min_diameter_m) +
                      "), got " + shortest(craters.max_diameter_m) +
                      (c.get("max_diameter_m") ? "" : " (the default)"));
    }
    craters.sfd_exponent = c.number("sfd_exponent", kPositive, craters.sfd_exponent);
    t.craters = craters;
  } else if (t.kind == TerrainKind::Mars) {
    t.craters = terrains::CraterSpec{};
  }

  const auto node_m = f.get("mjcf");
  if (t.kind != TerrainKind::Mjcf && node_m) {
    reader.fail(f.pathOf("mjcf"),
                "only allowed with kind: mjcf (kind is " + std::string(kind_name) + ")");
  }
  if (t.kind == TerrainKind::Mjcf) {
    const std::string path = f.pathOf("mjcf");
    const std::string text = reader.string(f.required("mjcf"), path);
    if (text.empty()) reader.fail(path, "expected the path of an MJCF file, got ''");
    // Absolute and normalised, so the resolved scenario reads back the same from any directory.
    std::error_code ec;
    fs::path world = fs::path(text).is_absolute() ? fs::path(text) : file.parent_path() / text;
    world = fs::absolute(world, ec).lexically_normal();
    if (ec || !fs::is_regular_file(world, ec)) {
      reader.fail(path, "cannot find the MJCF file " + inQuotes(text) + " (looked for " +
                            world.string() + ")");
    }
    t.mjcf = world.string();
  }
  return t;
}

SensorSpec readSensor(const Reader& reader, const YAML::Node& node) {
  const Fields f(reader, node, "sensor",
                 {"rows", "cols", "fov_deg", "noise_k", "quantization_m", "ambiguity_m",
                  "mixed_pixels", "max_range_m", "beam_divergence_deg", "dropout"});
  SensorSpec s;
  s.rows = f.integer("rows", 1, 4096, s.rows);
  s.cols = f.integer("cols", 1, 16384, s.cols);
  if (const auto fov = f.numbers<2>("fov_deg", {0.0, 180.0, true, true})) {
    s.fov_v_rad = degToRad((*fov)[0]);
    s.fov_h_rad = degToRad((*fov)[1]);
  }
  s.noise_k = f.number("noise_k", kNonNegative, s.noise_k);
  s.quantization_m = f.number("quantization_m", kNonNegative, s.quantization_m);
  s.ambiguity_m = f.number("ambiguity_m", kNonNegative, s.ambiguity_m);
  s.mixed_pixels = f.boolean("mixed_pixels", s.mixed_pixels);
  s.max_range_m = f.number("max_range_m", kPositive, s.max_range_m);
  if (f.get("beam_divergence_deg")) {
    s.beam_divergence_rad =
        degToRad(f.number("beam_divergence_deg", {0.0, 180.0, false, true}, 0.0));
  }
  s.dropout = f.number("dropout", {0.0, 1.0, false, true}, s.dropout);
  return s;
}

std::vector<ViewSpec> readViews(const Reader& reader, const YAML::Node& node) {
  if (!node.IsSequence() || node.size() == 0) {
    reader.fail("views", "expected a non-empty list of views, got " + shown(node));
  }
  std::vector<ViewSpec> views;
  for (std::size_t i = 0; i < node.size(); ++i) {
    const Fields f(reader, node[i], "views[" + std::to_string(i) + "]", {"xyz_m", "rpy_deg"});
    ViewSpec view;
    const auto xyz = reader.numbers<3>(f.required("xyz_m"), f.pathOf("xyz_m"), kAny);
    view.xyz_m = {xyz[0], xyz[1], xyz[2]};
    if (const auto rpy = f.numbers<3>("rpy_deg", {-360.0, 360.0, false, false})) {
      view.rpy_rad = {degToRad((*rpy)[0]), degToRad((*rpy)[1]), degToRad((*rpy)[2])};
    }
    views.push_back(view);
  }
  return views;
}

MapSpec readMap(const Reader& reader, const YAML::Node& node) {
  const Fields f(reader, node, "map", {"cell_m", "region", "epsilon_rad", "shadows", "baseline"});
  MapSpec m;
  m.cell_m = f.number("cell_m", kPositive, m.cell_m);
  if (const auto node_r = f.get("region")) {
    const Fields r(reader, *node_r, f.pathOf("region"), {"x_m", "y_m"});
    for (const auto& [key, bounds] : {std::pair{"x_m", &m.x_m}, std::pair{"y_m", &m.y_m}}) {
      if (const auto lohi = r.numbers<2>(key, kAny)) {
        if (!((*lohi)[0] < (*lohi)[1])) {
          reader.fail(r.pathOf(key), "expected [lo, hi] with lo < hi, got [" +
                                         shortest((*lohi)[0]) + ", " + shortest((*lohi)[1]) + "]");
        }
        *bounds = {(*lohi)[0], (*lohi)[1]};
      }
    }
  }
  checkGridSize(reader, f.pathOf("cell_m"), std::ceil((m.x_m[1] - m.x_m[0]) / m.cell_m),
                std::ceil((m.y_m[1] - m.y_m[0]) / m.cell_m));
  m.epsilon_rad = f.number("epsilon_rad", kPositive, m.epsilon_rad);
  m.shadows = f.choice("shadows", {"gnc", "none"}, m.shadows);
  m.baseline = f.choice("baseline", {"cartesian", "none"}, m.baseline);
  return m;
}

Scenario readScenario(const Reader& reader, const YAML::Node& root, const fs::path& file) {
  const Fields f(reader, root, "",
                 {"name", "description", "seed", "terrain", "sensor", "views", "map"});
  Scenario s;
  s.file = file;
  s.name = reader.string(f.required("name"), "name");
  const bool valid_name = !s.name.empty() && std::all_of(s.name.begin(), s.name.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' || c == '-';
  });
  if (!valid_name) {
    reader.fail("name",
                "expected lowercase letters, digits, '_' and '-' only, got " + inQuotes(s.name));
  }
  if (const auto node = f.get("description")) s.description = reader.string(*node, "description");
  if (const auto node = f.get("seed")) {
    s.seed =
        reader.integer(*node, "seed", std::uint64_t{0}, std::numeric_limits<std::uint64_t>::max());
  }
  s.terrain = readTerrain(reader, f.required("terrain"), file);
  if (const auto node = f.get("sensor")) s.sensor = readSensor(reader, *node);
  s.views = readViews(reader, f.required("views"));
  if (const auto node = f.get("map")) s.map = readMap(reader, *node);
  return s;
}

// Resolved-YAML pieces.

std::string list(std::initializer_list<std::string> items) {
  std::string out = "[";
  for (const auto& item : items) out += (out.size() > 1 ? ", " : "") + item;
  return out + "]";
}

}  // namespace

Scenario parseScenario(const std::string& yaml_text, const fs::path& file) {
  const Reader reader(file.empty() ? "<string>" : file.string());
  std::vector<YAML::Node> documents;
  try {
    documents = YAML::LoadAll(yaml_text);
  } catch (const YAML::Exception& e) {
    const std::string where = e.mark.is_null()
                                  ? ""
                                  : "line " + std::to_string(e.mark.line + 1) + ", column " +
                                        std::to_string(e.mark.column + 1);
    reader.fail(where, "YAML syntax error: " + e.msg);
  }
  if (documents.empty()) reader.fail("", "expected a mapping of scenario keys, got nothing");
  if (documents.size() > 1) {
    reader.fail("", "expected one YAML document, got " + std::to_string(documents.size()));
  }
  return readScenario(reader, documents.front(), file);
}

Scenario loadScenario(const fs::path& file) {
  std::error_code ec;
  std::ifstream in(file, std::ios::binary);
  if (!in || fs::is_directory(file, ec)) throw ScenarioError(file.string() + ": cannot open file");
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw ScenarioError(file.string() + ": cannot read file");
  return parseScenario(text.str(), file);
}

std::string resolvedYaml(const Scenario& s) {
  const auto num = [](double v) { return shortest(v); };
  const auto deg = [](double rad) { return degreesText(rad); };
  std::string y = "# every key written out, defaults filled in (docs/scenario.md)\n";
  y += "name: " + yamlQuoted(s.name) + "\n";
  y += "description: " + yamlQuoted(s.description) + "\n";
  y += "seed: " + std::to_string(s.seed) + "\n";

  const auto& t = s.terrain;
  std::string kind;
  for (const auto& [name, k] : kKinds) {
    if (k == t.kind) kind = name;
  }
  y += "terrain:\n";
  y += "  kind: " + kind + "\n";
  y += "  size_m: " + list({num(t.size_m.x()), num(t.size_m.y())}) + "\n";
  y += "  cell_m: " + num(t.cell_m) + "\n";
  y += "  relief_m: " + num(t.relief_m) + "\n";
  y += "  hurst: " + num(t.hurst) + "\n";
  y += "  slope_deg: " + list({num(t.slope_deg.x()), num(t.slope_deg.y())}) + "\n";
  if (t.sinusoid) {
    y += "  sinusoid: {amplitude_m: " + num(t.sinusoid->amplitude_m) +
         ", wavelength_m: " + num(t.sinusoid->wavelength_m) + "}\n";
  }
  y += t.steps.empty() ? "  steps: []\n" : "  steps:\n";
  for (const auto& step : t.steps) {
    y += "    - {x_m: " + num(step.x_m) + ", height_m: " + num(step.height_m) + "}\n";
  }
  if (t.rocks) {
    y += "  rocks: {abundance_k: " + num(t.rocks->abundance_k) +
         ", min_diameter_m: " + num(t.rocks->min_diameter_m) +
         ", max_diameter_m: " + num(t.rocks->max_diameter_m) + "}\n";
  }
  if (t.craters) {
    y += "  craters: {count: " + std::to_string(t.craters->count) +
         ", min_diameter_m: " + num(t.craters->min_diameter_m) +
         ", max_diameter_m: " + num(t.craters->max_diameter_m) +
         ", sfd_exponent: " + num(t.craters->sfd_exponent) + "}\n";
  }
  if (t.kind == TerrainKind::Mjcf) y += "  mjcf: " + yamlQuoted(t.mjcf) + "\n";

  const auto& c = s.sensor;
  y += "sensor:\n";
  y += "  rows: " + std::to_string(c.rows) + "\n";
  y += "  cols: " + std::to_string(c.cols) + "\n";
  y += "  fov_deg: " + list({deg(c.fov_v_rad), deg(c.fov_h_rad)}) + "\n";
  y += "  noise_k: " + num(c.noise_k) + "\n";
  y += "  quantization_m: " + num(c.quantization_m) + "\n";
  y += "  ambiguity_m: " + num(c.ambiguity_m) + "\n";
  y += std::string("  mixed_pixels: ") + (c.mixed_pixels ? "true" : "false") + "\n";
  y += "  max_range_m: " + num(c.max_range_m) + "\n";
  y += "  beam_divergence_deg: " + deg(c.beam_divergence_rad) + "\n";
  y += "  dropout: " + num(c.dropout) + "\n";

  y += "views:\n";
  for (const auto& v : s.views) {
    y += "  - {xyz_m: " + list({num(v.xyz_m.x()), num(v.xyz_m.y()), num(v.xyz_m.z())}) +
         ", rpy_deg: " + list({deg(v.rpy_rad.x()), deg(v.rpy_rad.y()), deg(v.rpy_rad.z())}) + "}\n";
  }

  if (s.map) {
    const auto& m = *s.map;
    y += "map:\n";
    y += "  cell_m: " + num(m.cell_m) + "\n";
    y += "  region: {x_m: " + list({num(m.x_m[0]), num(m.x_m[1])}) +
         ", y_m: " + list({num(m.y_m[0]), num(m.y_m[1])}) + "}\n";
    y += "  epsilon_rad: " + num(m.epsilon_rad) + "\n";
    y += "  shadows: " + m.shadows + "\n";
    y += "  baseline: " + m.baseline + "\n";
  }
  return y;
}

std::string yamlQuoted(std::string_view text) {
  std::string out = "\"";
  for (const char c : text) {
    const auto u = static_cast<unsigned char>(c);
    if (c == '"')
      out += "\\\"";
    else if (c == '\\')
      out += "\\\\";
    else if (c == '\n')
      out += "\\n";
    else if (c == '\t')
      out += "\\t";
    else if (u < 0x20 || u == 0x7f) {
      constexpr char kHex[] = "0123456789abcdef";
      out += "\\x";
      out += kHex[u >> 4];
      out += kHex[u & 0xf];
    } else {
      out += c;
    }
  }
  return out + "\"";
}

}  // namespace ambler::eval
