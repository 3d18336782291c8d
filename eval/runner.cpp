#include "eval/runner.hpp"

#include <chrono>
#include <numbers>
#include <cstdio>
#include <string>

#include "eval/figures.hpp"
#include "eval/io.hpp"
#include "eval/map_metrics.hpp"
#include "eval/map_outputs.hpp"
#include "eval/mapping.hpp"
#include "eval/metrics.hpp"
#include "perception/sensor_geometry.hpp"
#include "sim/ground_truth.hpp"
#include "sim/ray_scene.hpp"
#include "sim/world.hpp"
#include "terrains/random.hpp"

namespace ambler::eval {

namespace fs = std::filesystem;

namespace {

class Stopwatch {
 public:
  double seconds() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }
 private:
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};

struct Progress {
  bool on;
  void operator()(const std::string& line) const {
    if (on) std::fprintf(stderr, "ambler: %s\n", line.c_str());
  }
};

std::string viewName(int k) { return "view_" + std::to_string(k); }

double degrees(double rad) { return rad * 180.0 / std::numbers::pi; }

nlohmann::ordered_json scanMeta(const perception::RangeImage& img, const ViewSpec& view) {
  nlohmann::ordered_json j;
  j["phi_rad"] = img.phi;
  j["theta_rad"] = img.theta;
  j["pose"]["xyz_m"] = {view.xyz_m.x(), view.xyz_m.y(), view.xyz_m.z()};
  j["pose"]["rpy_deg"] = {degrees(view.rpy_rad.x()), degrees(view.rpy_rad.y()), degrees(view.rpy_rad.z())};
  return j;
}

std::vector<Eigen::Vector3f> returnsInWorld(const perception::RangeImage& img) {
  std::vector<Eigen::Vector3f> pts;
  for (int r = 0; r < img.rows(); ++r)
    for (int c = 0; c < img.cols(); ++c)
      if (img.valid(r, c)) pts.push_back(img.pointWorld(r, c).cast<float>());
  return pts;
}

// A picture grid over the world's horizontal extent at about the terrain's resolution.
perception::MapGrid pictureGrid(const Eigen::AlignedBox3d& b, double cell) {
  const double extent = std::max(b.max().x() - b.min().x(), b.max().y() - b.min().y());
  cell = std::max(cell, extent / 1500.0);
  return perception::MapGrid::covering(b.min().x(), b.max().x(), b.min().y(), b.max().y(), cell);
}

// The maps of view k (locus and, if asked, the Cartesian baseline), scored against ground truth
// on the same grid, written to maps/.
void mapView(const Scenario& sc, int k, const sim::Scan& scan, const sim::GroundTruth& truth,
             const sim::ErimConfig& cfg, const fs::path& out, nlohmann::ordered_json& metrics, double& map_s,
             double& cartesian_s, const Progress& say) {
  const MapSpec& spec = *sc.map;
  const perception::MapGrid grid = mapGrid(spec);
  const sim::ElevationRaster z_true = truth.elevation(grid);
  const sim::VisibilityRaster vis = truth.visibility(grid, z_true, scan.image.T_WS, cfg);
  const MapBuild build = buildLocusMap(scan.image, spec, sc.sensor);
  map_s += build.locus_seconds;
  const Eigen::Vector3d sensor_position = scan.image.T_WS.translation();
  const MapMetrics m = mapMetrics(build.locus, z_true, vis, &sensor_position);
  metrics["map"].push_back(toJson(m, k));
  writeMapFiles(out / "maps", viewName(k), build.locus, &z_true, sc.name + ": " + viewName(k) + " locus map");
  char line[200];
  std::snprintf(line, sizeof line,
                "map       %s: %dx%d cells of %.2f m, coverage %.1f%%, RMS error %.4f m, shadow P/R %.2f/%.2f, "
                "within 1σ %.0f%%",
                viewName(k).c_str(), grid.rows, grid.cols, grid.cell, 100 * m.coverage, m.rms_error_m,
                m.shadow_precision, m.shadow_recall, 100 * m.within_1sigma);
  say(line);
  if (spec.baseline != "cartesian") return;
  // A fair baseline: both gap fillings, the better one (by RMS error against truth) reported.
  Stopwatch t_cart;
  std::optional<perception::ElevationMap> best;
  std::optional<MapMetrics> best_m;
  std::string best_fill;
  for (const auto& [fill, name] : {std::pair{perception::GapFill::Nearest, "nearest"},
                                   std::pair{perception::GapFill::Linear, "linear"}}) {
    perception::ElevationMap cart = buildCartesianMap(build.image, spec, fill);
    const MapMetrics cm = mapMetrics(cart, z_true, vis, &sensor_position);
    if (!best_m || cm.rms_error_m < best_m->rms_error_m) best.emplace(std::move(cart)), best_m = cm, best_fill = name;
  }
  cartesian_s += t_cart.seconds() / 2;  // per baseline map
  auto j = cartesianJson(*best_m, k);
  j["gap_fill"] = best_fill;
  metrics["map_cartesian"].push_back(j);
  writeCartesianFiles(out / "maps", viewName(k), *best, &z_true, sc.name + ": " + viewName(k) + " Cartesian baseline");
  std::snprintf(line, sizeof line, "cartesian %s: coverage %.1f%%, RMS error %.4f m (%s gap filling)",
                viewName(k).c_str(), 100 * best_m->coverage, best_m->rms_error_m, best_fill.c_str());
  say(line);
}

}  // namespace

sim::ErimConfig erimConfig(const SensorSpec& s) {
  sim::ErimConfig c;
  c.rows = s.rows;
  c.cols = s.cols;
  c.fov_v_rad = s.fov_v_rad;
  c.fov_h_rad = s.fov_h_rad;
  c.noise_k = s.noise_k;
  c.quantization_m = s.quantization_m;
  c.ambiguity_m = s.ambiguity_m;
  c.mixed_pixels = s.mixed_pixels;
  c.max_range_m = s.max_range_m;
  c.beam_divergence_rad = s.beam_divergence_rad;
  c.dropout = s.dropout;
  return c;
}

std::uint64_t viewSeed(std::uint64_t seed, int view) { return terrains::streamKey(seed, 1000 + view); }

nlohmann::ordered_json runScenario(const Scenario& sc, const RunOptions& opt) {
  const Progress say{opt.progress};
  Stopwatch total;
  const fs::path out = opt.out;
  fs::create_directories(out / "world");
  fs::create_directories(out / "scans");

  // World: generated terrain written as MJCF, or the user's MJCF as it is.
  Stopwatch t_world;
  std::optional<sim::World> world;
  if (sc.terrain.kind == terrains::TerrainKind::Mjcf) {
    world.emplace(sim::World::load(sc.terrain.mjcf));
    world->saveLastXml(out / "world" / "world.xml");
    say("world     " + sc.terrain.mjcf + " (" + std::to_string(world->geomCount()) + " geoms)");
  } else {
    const terrains::Terrain terrain = terrains::makeTerrain(sc.terrain, sc.seed);
    const fs::path xml = sim::writeWorld(terrain, out / "world", sc.name);
    world.emplace(sim::World::load(xml));
    say("world     " + std::to_string(terrain.ground.rows()) + "x" + std::to_string(terrain.ground.cols()) +
        " heightfield, " + std::to_string(terrain.rocks.size()) + " rocks -> " + xml.string());
  }
  const sim::RayScene scene(*world);
  const sim::GroundTruth truth(scene);
  const double world_s = t_world.seconds();

  const auto grid = pictureGrid(scene.bounds(), sc.terrain.cell_m);
  writePng(out / "terrain.png", shadedRelief(truth.elevation(grid), grid.cell, sc.name + ": terrain (ground truth)"));

  const sim::ErimConfig cfg = erimConfig(sc.sensor);
  const sim::ErimScanner scanner(scene, cfg);
  nlohmann::ordered_json metrics;
  metrics["name"] = sc.name;
  metrics["seed"] = sc.seed;
  metrics["scan"] = nlohmann::ordered_json::array();
  if (sc.map) {
    metrics["map"] = nlohmann::ordered_json::array();
    if (sc.map->baseline == "cartesian") metrics["map_cartesian"] = nlohmann::ordered_json::array();
    fs::create_directories(out / "maps");
  }
  double scan_s = 0, map_s = 0, cartesian_s = 0;
  for (int k = 0; k < int(sc.views.size()); ++k) {
    const ViewSpec& v = sc.views[k];
    Stopwatch t_scan;
    const sim::Scan scan = scanner.scan(perception::sensorPose(v.xyz_m, v.rpy_rad), viewSeed(sc.seed, k));
    scan_s += t_scan.seconds();
    const fs::path base = out / "scans" / viewName(k);
    writeTiff(base.string() + "_range.tiff", scan.image.range);
    writeJson(base.string() + "_meta.json", scanMeta(scan.image, v));
    writePly(base.string() + ".ply", returnsInWorld(scan.image));
    writePng(base.string() + ".png", rangePicture(scan.image, cfg.max_range_m, sc.name + ": " + viewName(k) + " range"));
    const ScanMetrics m = scanMetrics(scan, cfg);
    metrics["scan"].push_back(toJson(m, k));
    char line[160];
    std::snprintf(line, sizeof line, "scan      %s: %dx%d, %.1f%% returned, range error RMS %.4f m",
                  viewName(k).c_str(), cfg.rows, cfg.cols, 100.0 * m.valid_fraction, m.range_error_rms_m);
    say(line);
    if (sc.map) mapView(sc, k, scan, truth, cfg, out, metrics, map_s, cartesian_s, say);
  }

  metrics["timing_s"]["world"] = world_s;
  metrics["timing_s"]["scan"] = scan_s;
  if (sc.map) metrics["timing_s"]["map"] = map_s;
  if (sc.map && sc.map->baseline == "cartesian") metrics["timing_s"]["map_cartesian"] = cartesian_s;
  metrics["timing_s"]["total"] = total.seconds();
  writeText(out / "scenario.resolved.yaml", resolvedYaml(sc));
  writeJson(out / "metrics.json", metrics);
  say("wrote     " + (out / "metrics.json").string() + ", " + (out / "terrain.png").string() + ", " +
      (out / "scans").string() + "/, " + (sc.map ? (out / "maps").string() + "/, " : std::string()) +
      (out / "world").string() + "/");
  return metrics;
}

}  // namespace ambler::eval
