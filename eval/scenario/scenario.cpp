// Scenario YAML: a strict reader (every key known, every value typed and range-checked, errors that
// name the file and the key path). docs/scenario.md is the schema; keep the two in step. The
// typed value reader is scenario_reader.hpp/.cpp; the resolved form (every default written out,
// numbers that read back bit for bit) is scenario_writer.cpp.
#include "eval/scenario/scenario.hpp"

#include "base/random.hpp"
#include "base/read_file.hpp"
#include "perception/sensor_geometry.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>
#include <string_view>
#include <utility>

#include "eval/scenario/scenario_reader.hpp"
#include "eval/scenario/yaml_documents.hpp"

namespace ambler::eval {
namespace {

// The bounds of matching.initial_error (each coordinate, each angle): also the rover's prior.
constexpr double kMaxInitialTranslationM = 3.0;
constexpr double kMaxInitialRotationDeg = 30.0;

namespace fs = std::filesystem;
using terrains::TerrainKind;
using namespace scenario_detail;

// Bounds a grid (terrain samples or map cells) so a typo in a cell size cannot exhaust memory.
constexpr double kMaxGridPoints = 25e6;

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

// terrain.window_m, resample_m (the DEM's names of size_m and cell_m: either may be given, both
// given must agree; docs/scenario.md, "terrain.kind: dem"), centre_m and vertical_offset_m.
void readDemWindow(const Reader& reader, const Fields& f, const Range& size_range, const Range& cell_range,
                   terrains::TerrainSpec& t) {
  // The DEM window is the terrain's extent and it is resampled at the heightfield's spacing:
  // window_m is size_m and resample_m is cell_m, named from the DEM's side. Either name may be
  // given; both given must agree (docs/scenario.md, "terrain.kind: dem").
  if (const auto window = f.numbers<2>("window_m", size_range)) {
    const Eigen::Vector2d w{(*window)[0], (*window)[1]};
    if (f.get("size_m") && w != t.size_m) {
      reader.fail(f.pathOf("window_m"), "expected size_m ([" + shortest(t.size_m.x()) + ", " +
                                            shortest(t.size_m.y()) +
                                            "]) or nothing: the DEM window is the terrain's extent, got [" +
                                            shortest(w.x()) + ", " + shortest(w.y()) + "]");
    }
    t.size_m = w;
  }
  if (f.get("resample_m")) {
    const double r = f.number("resample_m", cell_range, t.cell_m);
    if (f.get("cell_m") && r != t.cell_m) {
      reader.fail(f.pathOf("resample_m"), "expected cell_m (" + shortest(t.cell_m) +
                                              ") or nothing: the DEM is resampled at the heightfield's spacing, got " +
                                              shortest(r));
    }
    t.cell_m = r;
  }
  if (const auto centre = f.numbers<2>("centre_m", kAny)) t.dem_centre_m = Eigen::Vector2d{(*centre)[0], (*centre)[1]};
  if (f.get("vertical_offset_m")) t.dem_vertical_offset_m = f.number("vertical_offset_m", kAny, 0.0);
}

// terrain.sinusoid and terrain.steps (their kinds' defaults when not given).
void readShapes(const Reader& reader, const Fields& f, terrains::TerrainSpec& t) {
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

}

// terrain.rocks and terrain.craters (kind mars has both: the defaults unless given, as
// terrains::makeTerrain does).
void readRocksAndCraters(const Reader& reader, const Fields& f, terrains::TerrainSpec& t) {
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

}

// The file `key` names (`what`: "an MJCF file", "a GeoTIFF DEM"; `noun`: how a missing one is
// called), relative to the scenario's directory, stored absolute and normalised so the resolved
// scenario reads back the same from any directory; refused when it is not there. Its contents are
// checked by the world stage, before the run writes anything.
std::string namedFile(const Reader& reader, const Fields& f, const char* key, const fs::path& file,
                      const std::string& what, const std::string& noun) {
  const std::string path = f.pathOf(key);
  const std::string text = reader.string(f.required(key), path);
  if (text.empty()) reader.fail(path, "expected the path of " + what + ", got ''");
  std::error_code ec;
  fs::path named = fs::path(text).is_absolute() ? fs::path(text) : file.parent_path() / text;
  named = fs::absolute(named, ec).lexically_normal();
  if (ec || !fs::is_regular_file(named, ec)) {
    reader.fail(path, "cannot find the " + noun + " " + inQuotes(text) + " (looked for " + named.string() + ")");
  }
  return named.string();
}

terrains::TerrainSpec readTerrain(const Reader& reader, const YAML::Node& node,
                                  const fs::path& file) {
  const Fields f(reader, node, "terrain",
                 {"kind", "size_m", "cell_m", "relief_m", "hurst", "slope_deg", "sinusoid", "steps",
                  "rocks", "craters", "mjcf", "dem", "window_m", "resample_m", "centre_m",
                  "vertical_offset_m"});
  terrains::TerrainSpec t;
  std::vector<std::string_view> kind_names;
  for (const auto& [name, kind] : kKinds) kind_names.push_back(name);
  const std::string_view kind_name =
      reader.choice(f.required("kind"), f.pathOf("kind"), kind_names);
  for (const auto& [name, kind] : kKinds) {
    if (name == kind_name) t.kind = kind;
  }

  // The DEM-only keys: refused with any other kind before their values are read.
  for (const char* key : {"dem", "window_m", "resample_m", "centre_m", "vertical_offset_m"}) {
    if (t.kind != TerrainKind::Dem && f.get(key)) {
      reader.fail(f.pathOf(key), "only allowed with kind: dem (kind is " + std::string(kind_name) + ")");
    }
  }

  const Range size_range{0.0, 500.0, true, false}, cell_range{0.0, 1.0, true, false};
  if (const auto size = f.numbers<2>("size_m", size_range)) {
    t.size_m = {(*size)[0], (*size)[1]};
  }
  t.cell_m = f.number("cell_m", cell_range, t.cell_m);
  if (t.kind == TerrainKind::Dem) readDemWindow(reader, f, size_range, cell_range, t);
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

  readShapes(reader, f, t);
  readRocksAndCraters(reader, f, t);

  if (t.kind != TerrainKind::Mjcf && f.get("mjcf")) {
    reader.fail(f.pathOf("mjcf"), "only allowed with kind: mjcf (kind is " + std::string(kind_name) + ")");
  }
  if (t.kind == TerrainKind::Mjcf) t.mjcf = namedFile(reader, f, "mjcf", file, "an MJCF file", "MJCF file");
  if (t.kind == TerrainKind::Dem) t.dem = namedFile(reader, f, "dem", file, "a GeoTIFF DEM", "DEM file");
  return t;
}

perception::SensorModel readSensor(const Reader& reader, const YAML::Node& node) {
  const Fields f(reader, node, "sensor",
                 {"rows", "cols", "fov_deg", "noise_k", "quantization_m", "ambiguity_m",
                  "mixed_pixels", "max_range_m", "beam_divergence_deg", "dropout"});
  perception::SensorModel s;
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

std::vector<ViewSpec> readViews(const Reader& reader, const YAML::Node& node, const terrains::TerrainSpec& t) {
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
    // A generated terrain spans its heightfield's samples, as terrains::makeTerrain lays them out;
    // an MJCF world's extent is only known once it is loaded (the world stage checks it there).
    if (t.kind != TerrainKind::Mjcf) {
      const double hx = std::round(t.size_m.x() / t.cell_m) * t.cell_m / 2.0;
      const double hy = std::round(t.size_m.y() / t.cell_m) * t.cell_m / 2.0;
      if (std::abs(xyz[0]) > hx || std::abs(xyz[1]) > hy) {
        const auto m = [](double v) { return shortest(std::round(v * 1e6) / 1e6); };  // 10, not 10.000000000000002
        reader.fail(f.pathOf("xyz_m"), "expected x in [" + m(-hx) + ", " + m(hx) + "] and y in [" + m(-hy) + ", " +
                                           m(hy) + "] (over the terrain), got [" +
                                           shortest(xyz[0]) + ", " + shortest(xyz[1]) + ", " + shortest(xyz[2]) + "]");
      }
    }
    views.push_back(view);
  }
  return views;
}

// A section's `region: {x_m: [lo, hi], y_m: [lo, hi]}` into x_m, y_m (kept where absent).
void readRegion(const Reader& reader, const Fields& f, Eigen::Vector2d& x_m, Eigen::Vector2d& y_m) {
  if (const auto node_r = f.get("region")) {
    const Fields r(reader, *node_r, f.pathOf("region"), {"x_m", "y_m"});
    for (const auto& [key, bounds] : {std::pair{"x_m", &x_m}, std::pair{"y_m", &y_m}}) {
      if (const auto lohi = r.numbers<2>(key, kAny)) {
        if (!((*lohi)[0] < (*lohi)[1])) {
          reader.fail(r.pathOf(key), "expected [lo, hi] with lo < hi, got [" +
                                         shortest((*lohi)[0]) + ", " + shortest((*lohi)[1]) + "]");
        }
        *bounds = {(*lohi)[0], (*lohi)[1]};
      }
    }
  }
}

MapSpec readMap(const Reader& reader, const YAML::Node& node) {
  const Fields f(reader, node, "map", {"cell_m", "region", "epsilon_rad", "shadows", "baseline"});
  MapSpec m;
  m.cell_m = f.number("cell_m", kPositive, m.cell_m);
  readRegion(reader, f, m.x_m, m.y_m);
  checkGridSize(reader, f.pathOf("cell_m"), std::ceil((m.x_m[1] - m.x_m[0]) / m.cell_m),
                std::ceil((m.y_m[1] - m.y_m[0]) / m.cell_m));
  m.epsilon_rad = f.number("epsilon_rad", kPositive, m.epsilon_rad);
  const std::string shadows = f.choice("shadows", {"gnc", "gnc_bridge", "none"}, shadowsName(m.shadows));
  m.shadows = shadows == "gnc" ? perception::ShadowMethod::Gnc
              : shadows == "gnc_bridge" ? perception::ShadowMethod::GncBridge
                                        : perception::ShadowMethod::None;
  m.baseline = f.choice("baseline", {"cartesian", "none"}, baselineName(m.baseline)) == "cartesian" ? Baseline::Cartesian
                                                                                                   : Baseline::None;
  return m;
}

// `traverse`: the scenario is a traverse, whose views the run generates; its matching section
// gives the success bounds and the odometry model alone.
MatchingSpec readMatching(const Reader& reader, const YAML::Node& node, int views, bool traverse) {
  const Fields f(reader, node, "matching", {"pairs", "methods", "initial_error", "success", "prior", "odometry", "gate",
                                                     "draw_initial_error"});
  MatchingSpec m;
  if (traverse) refuseMatchingKeysInTraverse(reader, f);
  if (!traverse && views < 2) reader.fail("matching", "needs at least two views, the scenario has " + std::to_string(views));
  if (const auto p = f.get("pairs")) {
    if (!p->IsSequence() || p->size() == 0) reader.fail("matching.pairs", "expected a non-empty list of [I, J] pairs, got " + shown(*p));
    for (std::size_t i = 0; i < p->size(); ++i) {
      const std::string path = "matching.pairs[" + std::to_string(i) + "]";
      const auto ij = reader.numbers<2>((*p)[i], path, kAny);
      for (const double v : ij)
        if (v != std::floor(v) || v < 0 || v >= views)
          reader.fail(path, "expected two view indices in [0, " + std::to_string(views - 1) + "], got " + shown((*p)[i]));
      if (ij[0] == ij[1]) reader.fail(path, "a view cannot be registered against itself");
      m.pairs.emplace_back(int(ij[0]), int(ij[1]));
    }
  } else {
    for (int j = 1; j < views; ++j) m.pairs.emplace_back(j - 1, j);
  }
  if (const auto ms = f.get("methods")) {
    if (!ms->IsSequence() || ms->size() == 0) reader.fail("matching.methods", "expected a non-empty list of methods, got " + shown(*ms));
    m.methods.clear();
    for (std::size_t i = 0; i < ms->size(); ++i)
      m.methods.push_back(readMatchMethod(reader, (*ms)[i], "matching.methods[" + std::to_string(i) + "]"));
  }
  if (const auto e = f.get("initial_error")) {
    const Fields fe(reader, *e, "matching.initial_error", {"xyz_m", "rpy_deg"});
    if (const auto xyz = fe.numbers<3>("xyz_m", {-kMaxInitialTranslationM, kMaxInitialTranslationM, false, false}))
      m.initial_error.xyz_m = {(*xyz)[0], (*xyz)[1], (*xyz)[2]};
    if (const auto rpy = fe.numbers<3>("rpy_deg", {-kMaxInitialRotationDeg, kMaxInitialRotationDeg, false, false}))
      m.initial_error.rpy_rad = {degToRad((*rpy)[0]), degToRad((*rpy)[1]), degToRad((*rpy)[2])};
  }
  if (const auto s = f.get("success")) {
    const Fields fs(reader, *s, "matching.success", {"translation_m", "rotation_deg"});
    m.success_translation_m = fs.number("translation_m", kPositive, m.success_translation_m);
    m.success_rotation_deg = fs.number("rotation_deg", kPositive, m.success_rotation_deg);
  }
  if (const auto p = f.get("prior")) {
    const Fields fp(reader, *p, "matching.prior", {"translation_m", "rotation_deg"});
    m.prior_translation_m = fp.number("translation_m", kPositive, m.prior_translation_m);
    m.prior_rotation_deg = fp.number("rotation_deg", {0.0, 180.0, true, false}, m.prior_rotation_deg);
  }
  if (const auto o = f.get("odometry")) {
    const Fields fo(reader, *o, "matching.odometry",
                    {"translation_per_m", "translation_floor_m", "heading_deg_per_m", "heading_floor_deg"});
    perception::OdometryModel& om = m.odometry;
    om.translation_per_m = fo.number("translation_per_m", {0.0, 10.0, false, false}, om.translation_per_m);
    om.translation_floor_m = fo.number("translation_floor_m", kPositive, om.translation_floor_m);
    om.heading_deg_per_m = fo.number("heading_deg_per_m", {0.0, 90.0, false, false}, om.heading_deg_per_m);
    om.heading_floor_deg = fo.number("heading_floor_deg", {0.0, 90.0, true, false}, om.heading_floor_deg);
  }
  m.gate_by_prior = f.choice("gate", {"odometry", "prior"}, "odometry") == "prior";
  m.draw_initial_error = f.boolean("draw_initial_error", false);
  if (m.draw_initial_error && f.get("initial_error"))
    reader.fail("matching.draw_initial_error", "true draws the initial error from the odometry model; remove initial_error");
  return m;
}

MergeSpec readMerge(const Reader& reader, const YAML::Node& node, const Scenario& s) {
  if (s.views.size() < 2)
    reader.fail("merge", "needs at least two views, the scenario has " + std::to_string(s.views.size()));
  const Fields f(reader, node, "merge", {"poses", "cell_m", "region"});
  MergeSpec m;
  m.poses = f.choice("poses", {"matched", "true"}, "matched") == "matched" ? MergePoses::Matched : MergePoses::True;
  m.cell_m = f.number("cell_m", kPositive, s.map->cell_m);
  m.x_m = s.map->x_m;
  m.y_m = s.map->y_m;
  readRegion(reader, f, m.x_m, m.y_m);
  checkGridSize(reader, f.pathOf("cell_m"), std::ceil((m.x_m[1] - m.x_m[0]) / m.cell_m),
                std::ceil((m.y_m[1] - m.y_m[0]) / m.cell_m));
  if (m.poses == MergePoses::Matched) {
    if (!s.matching) reader.fail("merge.poses", "matched needs a matching section (or poses: true)");
    // Every view must be reachable from view 0 through the matched pairs.
    std::vector<char> placed(s.views.size(), 0);
    placed[0] = 1;
    for (bool grew = true; grew;) {
      grew = false;
      for (const auto& [i, j] : s.matching->pairs)
        if (placed[i] != placed[j]) placed[i] = placed[j] = 1, grew = true;
    }
    for (std::size_t k = 0; k < placed.size(); ++k)
      if (!placed[k])
        reader.fail("merge.poses", "matched, but view " + std::to_string(k) +
                                       " is not linked to view 0 by matching.pairs");
  }
  return m;
}

FootfallSpec readFootfall(const Reader& reader, const YAML::Node& node, const Scenario& s) {
  const Fields f(reader, node, "footfall", {"map", "region", "foot_diameter_m", "methods"});
  FootfallSpec ff;
  const std::string fallback = s.merge ? "composite" : "view_0";
  const std::string map = f.get("map") ? reader.string(*f.get("map"), "footfall.map") : fallback;
  perception::MapGrid grid;
  if (map == "composite") {
    if (!s.merge) reader.fail("footfall.map", "composite needs a merge section");
    ff.map_view = -1;
    grid = s.merge->grid();
  } else {
    int k = -1;
    if (map.rfind("view_", 0) == 0 && map.size() > 5 && map.size() < 9 &&
        std::all_of(map.begin() + 5, map.end(), [](char c) { return c >= '0' && c <= '9'; }))
      k = std::stoi(map.substr(5));
    if (k < 0 || k >= int(s.views.size()))
      reader.fail("footfall.map", "expected composite or view_K with K in [0, " + std::to_string(s.views.size() - 1) +
                                      "], got " + inQuotes(map));
    ff.map_view = k;
    grid = s.map->grid();
  }
  readRegion(reader, f, ff.x_m, ff.y_m);
  ff.foot_diameter_m = f.number("foot_diameter_m", kPositive, ff.foot_diameter_m);
  const double gx0 = grid.x_min, gx1 = grid.x_min + grid.cols * grid.cell;
  const double gy1 = grid.y_max, gy0 = grid.y_max - grid.rows * grid.cell;
  if (ff.x_m[0] < gx0 - 1e-9 || ff.x_m[1] > gx1 + 1e-9 || ff.y_m[0] < gy0 - 1e-9 || ff.y_m[1] > gy1 + 1e-9)
    reader.fail("footfall.region", "x_m [" + shortest(ff.x_m[0]) + ", " + shortest(ff.x_m[1]) + "], y_m [" +
                                       shortest(ff.y_m[0]) + ", " + shortest(ff.y_m[1]) + "] is not inside " + map +
                                       "'s map (x [" + shortest(gx0) + ", " + shortest(gx1) + "], y [" +
                                       shortest(gy0) + ", " + shortest(gy1) + "])");
  if (ff.foot_diameter_m > std::min(ff.x_m[1] - ff.x_m[0], ff.y_m[1] - ff.y_m[0]))
    reader.fail("footfall.foot_diameter_m", shortest(ff.foot_diameter_m) +
                                                " m is larger than the region (the foot must fit in R, §5)");
  if (const auto ms = f.get("methods")) {
    if (!ms->IsSequence() || ms->size() == 0)
      reader.fail("footfall.methods", "expected a non-empty list of methods, got " + shown(*ms));
    ff.methods.clear();
    for (std::size_t i = 0; i < ms->size(); ++i) {
      const std::string path = "footfall.methods[" + std::to_string(i) + "]";
      const std::string_view name = reader.choice((*ms)[i], path, {"max_min", "planar_fit", "support_area", "free_volume",
                                                                   "equilibrium", "equilibrium_uncertain",
                                                                   "equilibrium_soil"});
      ff.methods.push_back(perception::footfallMethodFromName(name));
    }
  }
  return ff;
}

LegSpec readLeg(const Reader& reader, const YAML::Node& node) {
  const Fields f(reader, node, "leg", {"soil", "load_n"});
  LegSpec l;
  l.soil = f.choice("soil", {"sand", "rock"}, "sand") == "sand" ? Soil::Sand : Soil::Rock;
  l.load_n = f.number("load_n", kPositive, l.load_n);
  return l;
}

Scenario readScenario(const Reader& reader, const YAML::Node& root, const fs::path& file) {
  const Fields f(reader, root, "",
                 {"name", "description", "seed", "terrain", "sensor", "views", "traverse", "map", "matching", "merge",
                  "footfall", "leg"});
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
  if (const auto node = f.get("traverse")) {
    refuseBesideTraverse(reader, f);
    s.traverse = readTraverse(reader, *node, s.terrain);
  } else {
    s.views = readViews(reader, f.required("views"), s.terrain);
  }
  if (const auto node = f.get("map")) s.map = readMap(reader, *node);
  if (s.traverse && s.traverse->reg != TraverseRegister::None && !s.map)
    reader.fail("traverse.register", std::string(traverseRegisterName(s.traverse->reg)) +
                                         " needs a map section: each stop is registered through its map (or register: none)");
  if (const auto node = f.get("matching")) {
    if (!s.map) reader.fail("matching", "needs a map section: the views are matched through their maps");
    s.matching = readMatching(reader, *node, int(s.views.size()), s.traverse.has_value());
  }
  if (const auto node = f.get("merge")) {
    if (!s.map) reader.fail("merge", "needs a map section: the composite is made of the views' maps");
    s.merge = readMerge(reader, *node, s);
  }
  if (const auto node = f.get("footfall")) {
    if (!s.map) reader.fail("footfall", "needs a map section: footfalls are chosen on a map");
    s.footfall = readFootfall(reader, *node, s);
  }
  if (const auto node = f.get("leg")) {
    if (!s.footfall) reader.fail("leg", "needs a footfall section: the leg steps on the chosen footfalls");
    s.leg = readLeg(reader, *node);
  }
  return s;
}

}  // namespace

perception::CellRegion FootfallSpec::candidates(const perception::MapGrid& grid) const {
  const double r = 0.5 * foot_diameter_m;
  return perception::regionOfBox(grid, x_m[0] + r, x_m[1] - r, y_m[0] + r, y_m[1] - r);
}

const char* soilName(Soil s) { return s == Soil::Sand ? "sand" : "rock"; }
const char* mergePosesName(MergePoses p) { return p == MergePoses::Matched ? "matched" : "true"; }
perception::MapGrid MergeSpec::grid() const {
  return perception::MapGrid::covering(x_m[0], x_m[1], y_m[0], y_m[1], cell_m);
}
const char* shadowsName(perception::ShadowMethod m) {
  return m == perception::ShadowMethod::Gnc ? "gnc" : m == perception::ShadowMethod::GncBridge ? "gnc_bridge" : "none";
}
const char* baselineName(Baseline b) { return b == Baseline::Cartesian ? "cartesian" : "none"; }
const std::vector<MatchMethod>& matchMethods() {
  static const std::vector<MatchMethod> kNamed{
      MatchMethod::Iconic,          MatchMethod::IconicLm, MatchMethod::Features,     MatchMethod::FeaturesIconic,
      MatchMethod::IconicWeighted,  MatchMethod::FeaturesLm, MatchMethod::IcpPointToPlane, MatchMethod::Gicp,
      MatchMethod::Fgr,             MatchMethod::IconicRobust, MatchMethod::FeaturesIconicRobust,
      MatchMethod::FeaturesIconicWeighted};
  return kNamed;
}

std::optional<MatchMethod> matchMethodFromName(std::string_view name) {
  for (const MatchMethod m : matchMethods())
    if (name == matchMethodName(m)) return m;
  return std::nullopt;
}

const char* matchMethodName(MatchMethod m) {
  switch (m) {
    case MatchMethod::Features: return "features";
    case MatchMethod::Iconic: return "iconic";
    case MatchMethod::FeaturesIconic: return "features+iconic";
    case MatchMethod::IconicLm: return "iconic_lm";
    case MatchMethod::IconicWeighted: return "iconic_weighted";
    case MatchMethod::FeaturesLm: return "features+iconic_lm";
    case MatchMethod::IconicRobust: return "iconic_robust";
    case MatchMethod::FeaturesIconicRobust: return "features+iconic_robust";
    case MatchMethod::IcpPointToPlane: return "icp_point_to_plane";
    case MatchMethod::Gicp: return "gicp";
    case MatchMethod::Fgr: return "fgr";
    case MatchMethod::FeaturesIconicWeighted: return "features+iconic_weighted";
  }
  return "?";
}

std::optional<perception::RegistrationMethod> paperMethod(MatchMethod m) {
  using R = perception::RegistrationMethod;
  switch (m) {
    case MatchMethod::Features: return R::Features;
    case MatchMethod::Iconic: return R::Iconic;
    case MatchMethod::FeaturesIconic: return R::FeaturesIconic;
    case MatchMethod::IconicLm: return R::IconicLm;
    case MatchMethod::IconicWeighted: return R::IconicWeighted;
    case MatchMethod::FeaturesLm: return R::FeaturesLm;
    case MatchMethod::IconicRobust: return R::IconicRobust;
    case MatchMethod::FeaturesIconicRobust: return R::FeaturesIconicRobust;
    case MatchMethod::FeaturesIconicWeighted: return R::FeaturesIconicWeighted;
    default: return std::nullopt;
  }
}


Eigen::Isometry3d MatchingSpec::initialEstimate(const Eigen::Isometry3d& T_IJ, std::uint64_t seed, int i, int j) const {
  if (!draw_initial_error) return T_IJ * perception::sensorPose(initial_error.xyz_m, initial_error.rpy_rad);
  // z ~ N(0, I₆) within χ²₆'s 99 % point; E = (σ_t·z_t, rotation vector σ_θ·z_r) with σ the
  // odometry model's at the believed distance |(T_IJ·E).t| (a fixed point: the rover's σ is that
  // of the distance it believes it walked), so the correction's squared Mahalanobis distance under
  // the rover's prior is |z|² exactly.
  base::Rng rng(base::streamKey(seed, 3000 + std::uint64_t(i), std::uint64_t(j)));
  Eigen::Matrix<double, 6, 1> z;
  do {
    for (int k = 0; k < 6; ++k) z(k) = rng.normal();
  } while (z.squaredNorm() > 16.812);
  double d = T_IJ.translation().norm();
  Eigen::Isometry3d E = Eigen::Isometry3d::Identity();
  for (int k = 0; k < 50; ++k) {
    const perception::PriorSigma sigma = odometry.at(d);
    E.linear() = Eigen::AngleAxisd(z.tail<3>().norm() * sigma.rotation_deg * M_PI / 180,
                                   z.tail<3>().norm() > 0 ? Eigen::Vector3d(z.tail<3>().normalized()) : Eigen::Vector3d::UnitZ())
                     .toRotationMatrix();
    E.translation() = sigma.translation_m * z.head<3>();
    const double next = (T_IJ * E).translation().norm();
    if (std::abs(next - d) < 1e-12) break;
    d = next;
  }
  return T_IJ * E;
}

perception::MapGrid MapSpec::grid() const {
  return perception::MapGrid::covering(x_m[0], x_m[1], y_m[0], y_m[1], cell_m);
}

perception::ScanToMapConfig MapSpec::scanToMapConfig() const {
  perception::ScanToMapConfig c;
  c.shadows = shadows;
  c.locus.epsilon_rad = epsilon_rad;
  perception::applyShadowMethod(shadows, c.gnc, c.locus);
  return c;
}

perception::LocusConfig locusConfig(const Scenario& sc) { return sc.map->scanToMapConfig().locus; }

bool covarianceCalibrated(MatchMethod m, const perception::SensorModel& sensor) {
  if (m != MatchMethod::IconicWeighted && m != MatchMethod::FeaturesIconicWeighted) return false;
  // What was measured (docs/matching.md, "Calibration", the sensor grid): the ERIM's pixel grid
  // and beam, and the line through noise × counts on which the mean NEES is inside [4.5, 7.5]: its
  // 7.62 cm counts with noise from k/2 to its own k (4.82–5.94). Off it it is not: noisier is
  // overconfident (1.5·k: 8.67, 2·k: 12.3), quieter or with finer counts conservative (k/4: 4.48;
  // 2 cm counts: 4.20; none: 3.99).
  const perception::SensorModel erim;
  const auto same = [](double a, double b) { return std::abs(a - b) <= 1e-9 * std::max(1.0, std::abs(b)); };
  if (sensor.rows != erim.rows || sensor.cols != erim.cols || !same(sensor.fov_v_rad, erim.fov_v_rad) ||
      !same(sensor.fov_h_rad, erim.fov_h_rad) || !sensor.mixed_pixels ||
      sensor.beam_divergence_rad != erim.beam_divergence_rad || sensor.dropout != erim.dropout)
    return false;
  return same(sensor.quantization_m, erim.quantization_m) && sensor.noise_k >= 0.5 * erim.noise_k * (1 - 1e-9) &&
         sensor.noise_k <= erim.noise_k * (1 + 1e-9);
}

perception::RegistrationConfig registrationConfig(const Scenario& sc) {
  perception::RegistrationConfig c;
  c.locus = locusConfig(sc);
  c.locus.trust_edge_samples = true;  // maps to match, not to stand on (perception::LocusConfig)
  const MatchingSpec defaults;
  const MatchingSpec& m = sc.matching ? *sc.matching : defaults;
  c.prior_translation_m = m.prior_translation_m;
  c.prior_rotation_deg = m.prior_rotation_deg;
  if (m.gate_by_prior)
    c.acceptance.prior = {m.prior_translation_m / 3, m.prior_rotation_deg / 3};
  else
    c.odometry = m.odometry;
  return c;
}

Scenario parseScenario(const std::string& yaml_text, const fs::path& file) {
  const Reader reader(file.empty() ? "<string>" : file.string());
  std::vector<YAML::Node> documents;
  try {
    documents = loadAllDocuments(yaml_text);  // not YAML::LoadAll: it can hang
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
  std::string text;
  try {
    text = base::readFile(file);
  } catch (const base::ReadError& e) {
    throw ScenarioError(file.string() + ": " + e.what());
  }
  return parseScenario(text, file);
}

}  // namespace ambler::eval
