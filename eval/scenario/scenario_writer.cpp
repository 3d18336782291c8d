// The resolved scenario: every default written out, numbers that read back bit for bit through
// the reader in scenario.cpp. docs/scenario.md is the schema; keep the two in step.
#include "eval/scenario/scenario.hpp"

#include <array>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <initializer_list>
#include <limits>
#include <numbers>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "base/text.hpp"
#include "eval/scenario/scenario_internal.hpp"

namespace ambler::eval {
namespace {

using terrains::TerrainKind;
using namespace scenario_detail;

bool sameBits(double a, double b) {
  return std::bit_cast<std::uint64_t>(a) == std::bit_cast<std::uint64_t>(b);
}

}  // namespace

namespace scenario_detail {

// The same expression as perception::SensorModel's defaults (deg·π/180), so `fov_deg: [30, 80]` gives exactly
// the default radians.
double degToRad(double deg) { return deg * std::numbers::pi / 180.0; }

std::string shortest(double v) { return base::plainText(v); }

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

}  // namespace scenario_detail

namespace {

// Resolved-YAML pieces.

std::string list(std::initializer_list<std::string> items) {
  std::string out = "[";
  for (const auto& item : items) out += (out.size() > 1 ? ", " : "") + item;
  return out + "]";
}

}  // namespace

namespace {

// `terrain:` with every key (a DEM's window as window_m and resample_m).
std::string terrainYaml(const terrains::TerrainSpec& t) {
  const auto num = [](double v) { return shortest(v); };
  std::string y;
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
  if (t.kind == TerrainKind::Dem) {
    y += "  dem: " + yamlQuoted(t.dem) + "\n";
    y += "  window_m: " + list({num(t.size_m.x()), num(t.size_m.y())}) + "\n";
    y += "  resample_m: " + num(t.cell_m) + "\n";
    // Absent: the DEM's centre and its height there, found in the file; a run's resolved scenario
    // has them (the world stage fills them in, eval/run/runner.cpp).
    if (t.dem_centre_m) y += "  centre_m: " + list({num(t.dem_centre_m->x()), num(t.dem_centre_m->y())}) + "\n";
    if (t.dem_vertical_offset_m) y += "  vertical_offset_m: " + num(*t.dem_vertical_offset_m) + "\n";
  }

  return y;
}

// `sensor:` with every key, angles in degrees.
std::string sensorYaml(const perception::SensorModel& c) {
  const auto num = [](double v) { return shortest(v); };
  const auto deg = [](double rad) { return degreesText(rad); };
  std::string y;
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
  return y;
}

// `matching:` with every key; the initial error only when it is given, not drawn. In a traverse,
// only the keys it takes: success and odometry.
std::string matchingYaml(const MatchingSpec& m, bool traverse) {
  const auto num = [](double v) { return shortest(v); };
  const auto deg = [](double rad) { return degreesText(rad); };
  const std::string success = "  success: {translation_m: " + num(m.success_translation_m) +
                              ", rotation_deg: " + num(m.success_rotation_deg) + "}\n";
  const perception::OdometryModel& o = m.odometry;
  const std::string odometry = "  odometry: {translation_per_m: " + num(o.translation_per_m) + ", translation_floor_m: " +
                               num(o.translation_floor_m) + ", heading_deg_per_m: " + num(o.heading_deg_per_m) +
                               ", heading_floor_deg: " + num(o.heading_floor_deg) + "}\n";
  if (traverse) return "matching:\n" + success + odometry;
  std::string y;
  y += "matching:\n  pairs: [";
  for (std::size_t i = 0; i < m.pairs.size(); ++i)
    y += (i ? ", " : "") + list({std::to_string(m.pairs[i].first), std::to_string(m.pairs[i].second)});
  y += "]\n  methods: [";
  for (std::size_t i = 0; i < m.methods.size(); ++i) y += std::string(i ? ", " : "") + matchMethodName(m.methods[i]);
  const auto& e = m.initial_error;
  y += "]\n";
  if (!m.draw_initial_error)  // drawn, it is the odometry model's (and initial_error may not be given)
    y += "  initial_error: {xyz_m: " + list({num(e.xyz_m.x()), num(e.xyz_m.y()), num(e.xyz_m.z())}) +
         ", rpy_deg: " + list({deg(e.rpy_rad.x()), deg(e.rpy_rad.y()), deg(e.rpy_rad.z())}) + "}\n";
  y += success;
  y += "  prior: {translation_m: " + num(m.prior_translation_m) + ", rotation_deg: " + num(m.prior_rotation_deg) + "}\n";
  y += odometry;
  y += std::string("  gate: ") + (m.gate_by_prior ? "prior" : "odometry") + "\n";
  y += std::string("  draw_initial_error: ") + (m.draw_initial_error ? "true" : "false") + "\n";
  return y;
}

// `traverse:` with every key; the path as its waypoints (the start, heading and length form
// written as the two points it makes).
std::string traverseYaml(const TraverseSpec& t) {
  const auto num = [](double v) { return shortest(v); };
  std::string y = "traverse:\n  path: {waypoints_xy_m: [";
  for (std::size_t i = 0; i < t.waypoints_xy_m.size(); ++i)
    y += (i ? ", " : "") + list({num(t.waypoints_xy_m[i].x()), num(t.waypoints_xy_m[i].y())});
  y += "]}\n";
  y += "  stop_spacing_m: " + num(t.stop_spacing_m) + "\n";
  y += "  footprint_radius_m: " + num(t.footprint_radius_m) + "\n";
  y += "  mount: {height_m: " + num(t.mount.height_m) + ", pitch_deg: " + degreesText(t.mount.pitch_rad) + "}\n";
  const TraverseOdometry& o = t.odometry;
  y += "  odometry: {translation_sigma_per_m: " + num(o.translation_sigma_per_m) + ", heading_sigma_deg_per_m: " +
       num(o.heading_sigma_deg_per_m) + ", translation_bias: " + num(o.translation_bias) +
       ", heading_bias_deg_per_m: " + num(o.heading_bias_deg_per_m) + "}\n";
  const perception::LocalisationDrift& d = t.drift;
  y += "  drift: {translation_sigma_per_m: " + num(d.translation_sigma_per_m) + ", vertical_sigma_per_m: " +
       num(d.vertical_sigma_per_m) + ", heading_sigma_deg_per_sqrt_m: " + num(d.heading_sigma_deg_per_sqrt_m) +
       ", shared: " + (d.shared ? "true" : "false") + "}\n";
  y += std::string("  register: ") + traverseRegisterName(t.reg) + "\n";
  y += std::string("  method: ") + matchMethodName(t.method) + "\n";
  return y;
}

}  // namespace

std::string resolvedYaml(const Scenario& s) {
  const auto num = [](double v) { return shortest(v); };
  const auto deg = [](double rad) { return degreesText(rad); };
  std::string y = "# every key written out, defaults filled in (docs/scenario.md)\n";
  y += "name: " + yamlQuoted(s.name) + "\n";
  y += "description: " + yamlQuoted(s.description) + "\n";
  y += "seed: " + std::to_string(s.seed) + "\n";

  y += terrainYaml(s.terrain);
  y += sensorYaml(s.sensor);
  if (s.traverse) {
    y += traverseYaml(*s.traverse);
  } else {
    y += "views:\n";
    for (const auto& v : s.views) {
      y += "  - {xyz_m: " + list({num(v.xyz_m.x()), num(v.xyz_m.y()), num(v.xyz_m.z())}) +
           ", rpy_deg: " + list({deg(v.rpy_rad.x()), deg(v.rpy_rad.y()), deg(v.rpy_rad.z())}) + "}\n";
    }
  }

  if (s.map) {
    const auto& m = *s.map;
    y += "map:\n";
    y += "  cell_m: " + num(m.cell_m) + "\n";
    y += "  region: {x_m: " + list({num(m.x_m[0]), num(m.x_m[1])}) +
         ", y_m: " + list({num(m.y_m[0]), num(m.y_m[1])}) + "}\n";
    y += "  epsilon_rad: " + num(m.epsilon_rad) + "\n";
    y += std::string("  shadows: ") + shadowsName(m.shadows) + "\n";
    y += std::string("  baseline: ") + baselineName(m.baseline) + "\n";
  }
  if (s.matching) y += matchingYaml(*s.matching, s.traverse.has_value());
  if (s.merge) {
    const auto& m = *s.merge;
    y += std::string("merge:\n  poses: ") + mergePosesName(m.poses) + "\n";
    y += "  cell_m: " + num(m.cell_m) + "\n";
    y += "  region: {x_m: " + list({num(m.x_m[0]), num(m.x_m[1])}) + ", y_m: " + list({num(m.y_m[0]), num(m.y_m[1])}) +
         "}\n";
  }
  if (s.footfall) {
    const auto& f = *s.footfall;
    y += "footfall:\n  map: " + (f.map_view < 0 ? std::string("composite") : "view_" + std::to_string(f.map_view)) + "\n";
    y += "  region: {x_m: " + list({num(f.x_m[0]), num(f.x_m[1])}) + ", y_m: " + list({num(f.y_m[0]), num(f.y_m[1])}) +
         "}\n";
    y += "  foot_diameter_m: " + num(f.foot_diameter_m) + "\n  methods: [";
    for (std::size_t i = 0; i < f.methods.size(); ++i)
      y += std::string(i ? ", " : "") + std::string(perception::footfallMethodName(f.methods[i]));
    y += "]\n";
  }
  if (s.leg) y += std::string("leg:\n  soil: ") + soilName(s.leg->soil) + "\n  load_n: " + num(s.leg->load_n) + "\n";
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
