#include "base/random.hpp"
#include "eval/tools/bench/bench.hpp"
#include "base/temp_dir.hpp"

#include <tbb/blocked_range2d.h>
#include <tbb/global_control.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <functional>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <vector>

#include "eval/geo/dem.hpp"
#include "eval/scenario/io.hpp"
#include "eval/tools/progress.hpp"
#include "eval/run/pair_registration.hpp"
#include "eval/run/runner.hpp"
#include "eval/scenario/scenario.hpp"
#include "eval/score/stats.hpp"
#include "perception/cartesian_mapper.hpp"
#include "perception/footfall.hpp"
#include "perception/iconic.hpp"
#include "perception/scan_to_map.hpp"
#include "perception/sensor_geometry.hpp"
#include "sim/erim_scanner.hpp"
#include "sim/ray_scene.hpp"
#include "sim/world.hpp"
#include "terrains/terrain.hpp"

namespace ambler::eval {

namespace fs = std::filesystem;

namespace {

// Median seconds of `reps` runs of `f` (after one warm-up run).
double timeMedian(int reps, const std::function<void()>& f) {
  f();
  std::vector<double> s;
  for (int i = 0; i < reps; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    f();
    s.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
  return median(s);
}

// The benchmark world: the default `mars` terrain (fractal, craters, rocks), seed 1.
struct BenchWorld {
  fs::path dir;
  sim::World world;
  ~BenchWorld() {
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
};

std::unique_ptr<BenchWorld> makeBenchWorld() {
  terrains::TerrainSpec spec;
  spec.kind = terrains::TerrainKind::Mars;
  const terrains::Terrain terrain = terrains::makeTerrain(spec, 1);
  const fs::path dir = fs::temp_directory_path() / ("ambler-bench-" + std::to_string(::getpid()));
  const fs::path xml = sim::writeWorld(terrain, dir, "bench");
  return std::unique_ptr<BenchWorld>(new BenchWorld{dir, sim::World::load(xml)});
}

}  // namespace

nlohmann::ordered_json benchScan(const BenchOptions& opt) {
  std::fprintf(stderr, "bench scan: building the benchmark world (mars terrain, seed 1)...\n");
  const auto bw = makeBenchWorld();
  const sim::RayScene scene(bw->world);
  const Eigen::Isometry3d T = perception::sensorPose({0, -6, 3}, {0, -30.0 * std::numbers::pi / 180, 0});
  const int reps = opt.repetitions;
  Progress progress("bench scan", 4, 0, Progress::modeFor(opt.progress));

  // 1. 64×256, one thread: the emulator (ERIM defaults, one ray per pixel) vs a plain mj_ray loop.
  perception::SensorModel small;  // the ERIM's defaults
  small.mixed_pixels = false;
  const sim::ErimScanner scanner_small(scene, small);
  double emu_s = 0, emu_mixed_s = 0, mj_s = 0;
  long mj_rays = 0;
  {
    tbb::global_control one_thread(tbb::global_control::max_allowed_parallelism, 1);
    sim::Scan out;  // reused, as a sweep would
    emu_s = timeMedian(reps, [&] { scanner_small.scan(T, 1, out); });
    progress.step("emulator 64x256, 1 thread");
    perception::SensorModel mixed = small;
    mixed.mixed_pixels = true;
    const sim::ErimScanner scanner_mixed(scene, mixed);
    emu_mixed_s = timeMedian(reps, [&] { scanner_mixed.scan(T, 1, out); });
    progress.step("emulator 64x256, mixed pixels");
    // mj_ray walks every cell of the hfield the ray's bounding box covers, so a full 64×256 loop
    // takes long: time every `stride`-th pixel of the same scan (the same mix of rays).
    const auto img = perception::RangeImage::blank(small.rows, small.cols, small.fov_v_rad, small.fov_h_rad);
    const int stride = 8;
    mj_s = timeMedian(std::max(1, reps / 2), [&] {
      mj_rays = 0;
      for (int p = 0; p < small.rows * small.cols; p += stride, ++mj_rays) {
        const int r = p / small.cols, c = p % small.cols;
        bw->world.ray(T.translation(), T.linear() * perception::beamDirection(img.phi[r], img.theta[c]));
      }
    });
    progress.step("mj_ray loop 64x256");
  }
  const double rays_small = double(small.rows) * small.cols;
  const double emu_mrays = rays_small / emu_s / 1e6, mj_mrays = mj_rays / mj_s / 1e6;

  // 2. 1024×4096, all cores: the emulator vs a bare Embree packet cast of the same rays.
  perception::SensorModel large = small;
  large.rows = 1024;
  large.cols = 4096;
  const sim::ErimScanner scanner_large(scene, large);
  const auto img_large = perception::RangeImage::blank(large.rows, large.cols, large.fov_v_rad, large.fov_h_rad);
  std::vector<float> t_bare;
  std::vector<double> emu_large_s, bare_s;
  sim::Scan s;  // reused, like the bare cast's output vector
  // Interleave the two so machine noise hits both alike.
  for (int i = 0; i <= reps; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    scanner_large.scan(T, 1, s);
    const auto t1 = std::chrono::steady_clock::now();
    scene.referenceCast(img_large, T, t_bare);
    const auto t2 = std::chrono::steady_clock::now();
    if (i == 0) continue;  // warm-up
    emu_large_s.push_back(std::chrono::duration<double>(t1 - t0).count());
    bare_s.push_back(std::chrono::duration<double>(t2 - t1).count());
  }
  progress.step("emulator and bare Embree 1024x4096");
  progress.finish();
  const double rays_large = double(large.rows) * large.cols;
  const double large_mrays = rays_large / median(emu_large_s) / 1e6;
  const double bare_mrays = rays_large / median(bare_s) / 1e6;

  nlohmann::ordered_json j;
  j["emulator_mrays_s"] = emu_mrays;
  j["mj_ray_mrays_s"] = mj_mrays;
  j["speedup_vs_mj_ray"] = emu_mrays / mj_mrays;
  j["large_emulator_mrays_s"] = large_mrays;
  j["bare_embree_mrays_s"] = bare_mrays;
  j["ratio_vs_bare_embree"] = large_mrays / bare_mrays;
  j["emulator_mixed_pixels_mpixels_s"] = rays_small / emu_mixed_s / 1e6;
  j["threads"] = tbb::info::default_concurrency();
  j["repetitions"] = reps;
  j["mj_ray_rays_timed"] = mj_rays;

  std::printf("ambler bench scan (medians of %d; %d threads for the large scan)\n", reps,
              tbb::info::default_concurrency());
  std::printf("  %-46s %10s\n", "measurement", "Mrays/s");
  std::printf("  %-46s %10.3f\n", "emulator 64x256, 1 thread", emu_mrays);
  std::printf("  %-46s %10.4f\n", "mj_ray loop 64x256, 1 thread", mj_mrays);
  std::printf("  %-46s %10.1fx\n", "  speedup vs mj_ray", emu_mrays / mj_mrays);
  std::printf("  %-46s %10.3f\n", "emulator 64x256, 1 thread, mixed pixels (px/s)", rays_small / emu_mixed_s / 1e6);
  std::printf("  %-46s %10.3f\n", "emulator 1024x4096, all cores", large_mrays);
  std::printf("  %-46s %10.3f\n", "bare Embree rtcIntersect16, all cores", bare_mrays);
  std::printf("  %-46s %10.3f\n", "  ratio emulator / bare Embree", large_mrays / bare_mrays);
  if (!opt.json.empty()) writeJson(opt.json, j);
  return j;
}

namespace {

// One cell size of `ambler bench map`: the locus mapper on one thread and on all, the scalar
// search and the lanes capped at AVX2 (where the CPU has AVX-512) on one thread, the Cartesian
// baseline on one thread. Seconds per map.
struct MapTimes {
  double t1 = 0, ta = 0, sp = 0;  // one thread, all threads, the median of their paired ratios
  double ts = 0, t2 = 0, tc = 0;  // scalar, AVX2 (0: not measured), Cartesian
  long lane_cells = 0;            // cells the lanes completed
};

MapTimes timeMaps(const perception::RangeImage& image, const perception::Raster<std::uint8_t>& edges,
                  const perception::SensorModel& sensor, const perception::LocusConfig& locus,
                  const perception::MapGrid& grid, perception::LaneIsa isa, int repetitions) {
  const perception::LocusMapper mapper(image, sensor, &edges, locus);
  perception::LocusConfig scalar_config = locus;
  scalar_config.vectorized = false;
  const perception::LocusMapper scalar(image, sensor, &edges, scalar_config);
  const double cells = double(grid.cells());
  MapTimes m;
  mapper.map(grid, &m.lane_cells);
  // One thread against all, paired: each repetition times a burst of maps (~5 ms, so that a
  // worker thread's wake-up is not the measurement) on one thread, then on all; the speedup is
  // the median of the repetitions' ratios, which a slow spell of the shared machine shifts less
  // than it shifts either median alone.
  const int burst = std::max(1, int(5e-3 / (cells * 100e-9)));
  const auto timeBurst = [&] {
    const auto t0 = std::chrono::steady_clock::now();
    for (int b = 0; b < burst; ++b) mapper.map(grid);
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / burst;
  };
  std::vector<double> one_s, all_s, ratio;
  timeBurst();
  for (int i = 0; i < repetitions; ++i) {
    double a = 0, b = 0;
    {
      tbb::global_control one_thread(tbb::global_control::max_allowed_parallelism, 1);
      a = timeBurst();
    }
    b = timeBurst();
    one_s.push_back(a), all_s.push_back(b), ratio.push_back(a / b);
  }
  m.t1 = median(one_s), m.ta = median(all_s), m.sp = median(ratio);
  {
    tbb::global_control one_thread(tbb::global_control::max_allowed_parallelism, 1);
    m.ts = timeMedian(repetitions, [&] { scalar.map(grid); });
    if (isa == perception::LaneIsa::Avx512) {  // what a CPU with AVX2 but no AVX-512 would run
      const perception::LaneIsaCap avx2(perception::LaneIsa::Avx2);
      m.t2 = timeMedian(repetitions, [&] { mapper.map(grid); });
    }
    m.tc = timeMedian(repetitions, [&] { perception::cartesianMap(image, grid, {}); });
  }
  return m;
}

}  // namespace

nlohmann::ordered_json benchMap(const BenchOptions& opt) {
  std::fprintf(stderr, "bench map: building the benchmark world (mars terrain, seed 1) and one ERIM scan...\n");
  const auto bw = makeBenchWorld();
  const sim::RayScene scene(bw->world);
  const Eigen::Isometry3d T = perception::sensorPose({0, -6, 3}, {0, -30.0 * std::numbers::pi / 180, 0});
  const perception::SensorModel sensor;  // the ERIM's defaults: noise, quantisation, wrap, mixed pixels
  const sim::Scan scan = sim::ErimScanner(scene, sensor).scan(T, 1);
  // The image and edge mask every map below is made from, as the run's map stage makes them.
  MapSpec region;
  const perception::ScanMap base = perception::scanToMap(scan.image, sensor, T, region.grid());
  const perception::RangeImage& image = base.image;
  const perception::Raster<std::uint8_t>& edges = *base.edges;
  perception::LocusConfig locus;
  locus.epsilon_rad = region.epsilon_rad;

  nlohmann::ordered_json j, one, all, speedup, cart, scalar_one, avx2_one, lanes;
  const perception::LaneIsa isa = perception::LocusMapper::laneIsa();
  const char* isa_name = isa == perception::LaneIsa::Avx512 ? "AVX-512" : isa == perception::LaneIsa::Avx2 ? "AVX2" : "none";
  std::printf("ambler bench map (medians of %d; region x [-5, 5] m, y [-3, 8] m; 64x256 scan; lanes: %s)\n",
              opt.repetitions, isa_name);
  std::printf("  %-8s %10s %14s %14s %10s %16s %16s %14s %8s\n", "cell", "cells", "locus 1t ns", "locus all ns",
              "speedup", "cartesian 1t ns", "scalar 1t ns", "AVX2 1t ns", "lanes");
  Progress progress("bench map", 5, 0, Progress::modeFor(opt.progress));
  for (double cell : {0.02, 0.05, 0.10, 0.20}) {
    MapSpec spec = region;
    spec.cell_m = cell;
    const perception::MapGrid grid = spec.grid();
    const MapTimes m = timeMaps(image, edges, sensor, locus, grid, isa, opt.repetitions);
    const double cells = double(grid.cells()), t1 = m.t1, ta = m.ta, sp = m.sp, ts = m.ts, t2 = m.t2, tc = m.tc;
    const long lane_cells = m.lane_cells;
    char key[16];
    std::snprintf(key, sizeof key, "%.2f", cell);
    one[key] = t1 / cells * 1e9;
    all[key] = ta / cells * 1e9;
    speedup[key] = sp;
    cart[key] = tc / cells * 1e9;
    scalar_one[key] = ts / cells * 1e9;
    if (t2 > 0) avx2_one[key] = t2 / cells * 1e9;
    lanes[key] = double(lane_cells) / cells;
    char avx2_text[32] = "-";  // measured where the CPU has AVX-512 (capped to AVX2)
    if (t2 > 0) std::snprintf(avx2_text, sizeof avx2_text, "%.1f", t2 / cells * 1e9);
    char row[256];
    std::snprintf(row, sizeof row, "  %-8.2f %10.0f %14.1f %14.1f %9.2fx %16.1f %16.1f %14s %7.0f%%\n", cell, cells,
                  t1 / cells * 1e9, ta / cells * 1e9, sp, tc / cells * 1e9, ts / cells * 1e9, avx2_text,
                  100.0 * lane_cells / cells);
    progress.step(std::string("map at ") + key + " m");
    progress.print(stdout, row);
  }
  // Per image: the mapper's tables (returns, edge pixels and σ inputs per 2×2 cell), one thread.
  double setup_s = 0, edges_s = 0;
  {
    tbb::global_control one_thread(tbb::global_control::max_allowed_parallelism, 1);
    edges_s = timeMedian(opt.repetitions, [&] { perception::detectRangeEdges(image, sensor); });
    setup_s = timeMedian(opt.repetitions, [&] { perception::LocusMapper(image, sensor, &edges, locus); });
  }
  progress.step("edge detection and mapper tables");
  progress.finish();
  std::printf("  per image, 1 thread: edge detection (GNC) %.2f ms, locus mapper tables %.2f ms\n", edges_s * 1e3,
              setup_s * 1e3);
  j["ns_per_cell_1t"] = one;
  j["ns_per_cell_all"] = all;
  j["speedup_all"] = speedup;
  j["cartesian_ns_per_cell_1t"] = cart;
  j["scalar_ns_per_cell_1t"] = scalar_one;  // the same maps without the SIMD lanes
  if (!avx2_one.empty()) j["avx2_ns_per_cell_1t"] = avx2_one;  // the lanes capped at AVX2
  j["lane_fraction"] = lanes;               // of all cells, those the lanes completed
  j["lanes"] = isa_name;
  j["edges_ms"] = edges_s * 1e3;
  j["locus_setup_ms"] = setup_s * 1e3;
  j["threads"] = tbb::info::default_concurrency();
  j["repetitions"] = opt.repetitions;
  if (!opt.json.empty()) writeJson(opt.json, j);
  return j;
}

nlohmann::ordered_json benchMatch(const Scenario& sc, const BenchOptions& opt) {
  if (!sc.map || !sc.matching)
    throw std::runtime_error(sc.file.string() + ": bench match needs a scenario with map and matching sections");
  if (sc.traverse) throw std::runtime_error(sc.file.string() + ": traverse: not yet supported by bench match");
  std::fprintf(stderr, "bench match: building %s's world, scans and maps...\n", sc.name.c_str());
  const base::TempDir scratch("bench-match");
  const fs::path& dir = scratch.path();
  const sim::World world = sc.terrain.kind == terrains::TerrainKind::Mjcf
                               ? sim::World::load(sc.terrain.mjcf)
                               : sim::World::load(sim::writeWorld(scenarioTerrain(sc), dir, "bench"));
  const sim::RayScene scene(world);
  const sim::ErimScanner scanner(scene, sc.sensor);
  const auto [i, j] = sc.matching->pairs.front();
  const Eigen::Isometry3d T_i = perception::sensorPose(sc.views[i].xyz_m, sc.views[i].rpy_rad);
  const Eigen::Isometry3d T_j = perception::sensorPose(sc.views[j].xyz_m, sc.views[j].rpy_rad);
  const perception::MapGrid grid = sc.map->grid();
  const perception::ScanToMapConfig config = sc.map->scanToMapConfig();
  const perception::ScanMap map_i = perception::scanToMap(scanner.scan(T_i, base::viewSeed(sc.seed, i)).image, sc.sensor, T_i, grid, config);
  const perception::ScanMap map_j = perception::scanToMap(scanner.scan(T_j, base::viewSeed(sc.seed, j)).image, sc.sensor, T_j, grid, config);
  const PairRegistration pair(map_i, T_i, map_j, T_j, registrationConfig(sc), sc.matching->methods);
  // From the rover's belief, as the match stage starts.
  const Eigen::Isometry3d T_0 = sc.matching->initialEstimate(pair.trueRelative(), sc.seed, i, j);

  nlohmann::ordered_json j_out, methods = nlohmann::ordered_json::array();
  std::printf("ambler bench match (%s, views %d-%d, %dx%d cells of %.2f m; medians of %d)\n", sc.name.c_str(), i, j,
              grid.rows, grid.cols, grid.cell, opt.repetitions);
  std::printf("  %-15s %10s %12s %12s %14s %12s\n", "method", "iterations", "1 thread ms", "all ms", "error m", "error deg");
  Progress progress("bench match", sc.matching->methods.size(), 0, Progress::modeFor(opt.progress));
  for (const MatchMethod m : sc.matching->methods) {
    PairResult res;
    const auto once = [&] { res = pair.run(m, T_0); };
    double one = 0;
    {
      tbb::global_control one_thread(tbb::global_control::max_allowed_parallelism, 1);
      one = timeMedian(opt.repetitions, once);
    }
    const double all = timeMedian(opt.repetitions, once);
    const perception::PoseError err = res.error;
    char row[256];
    std::snprintf(row, sizeof row, "  %-15s %10d %12.1f %12.1f %14.4f %12.3f\n", matchMethodName(m), res.reg.iterations,
                  one * 1e3, all * 1e3, err.translation_m, err.rotation_deg);
    progress.step(matchMethodName(m));
    progress.print(stdout, row);
    nlohmann::ordered_json e;
    e["method"] = matchMethodName(m);
    e["iterations"] = res.reg.iterations;
    e["ms_1t"] = one * 1e3;
    e["ms_all"] = all * 1e3;
    e["translation_error_m"] = err.translation_m;
    e["rotation_error_deg"] = err.rotation_deg;
    methods.push_back(e);
  }
  j_out["scenario"] = sc.name;
  j_out["pair"] = {i, j};
  j_out["cell_m"] = grid.cell;
  j_out["methods"] = methods;
  j_out["threads"] = tbb::info::default_concurrency();
  j_out["repetitions"] = opt.repetitions;
  if (!opt.json.empty()) writeJson(opt.json, j_out);
  return j_out;
}

nlohmann::ordered_json benchFootfall(const BenchOptions& opt) {
  nlohmann::ordered_json out, sizes = nlohmann::ordered_json::array();
  std::printf("ambler bench footfall (10 000 candidates, 30 cm foot, all six methods; medians of %d)\n",
              opt.repetitions);
  std::printf("  %-8s %12s %14s %14s %9s\n", "cell m", "disk cells", "1 thread ms", "all cores ms", "speed-up");
  Progress progress("bench footfall", 2, 0, Progress::modeFor(opt.progress));
  for (const double cell : {0.10, 0.02}) {
    // Fractal ground at the map's resolution, 100 candidate cells and the foot's margin a side.
    terrains::TerrainSpec spec;
    spec.kind = terrains::TerrainKind::Fractal;
    const int n = 100 + 2 * int(std::ceil(0.15 / cell)) + 2;
    spec.size_m = Eigen::Vector2d(cell * (n - 1), cell * (n - 1));
    spec.cell_m = cell;
    const terrains::Terrain t = terrains::makeTerrain(spec, 1);
    const perception::MapGrid grid = perception::MapGrid::covering(-0.5 * cell * n, 0.5 * cell * n, -0.5 * cell * n,
                                                                   0.5 * cell * n, cell);
    perception::ElevationMap map(grid);
    for (int r = 0; r < grid.rows; ++r)
      for (int c = 0; c < grid.cols; ++c)
        map.setKnown(r, c, float(t.ground.at(std::min(r, t.ground.rows() - 1), std::min(c, t.ground.cols() - 1))), 0.01f);
    const int margin = (grid.rows - 100) / 2;
    const perception::CellRegion region{margin, margin, 100, 100};
    std::vector<perception::FootfallScores> res;
    const auto once = [&] { res = perception::evaluateFootfalls(map, region); };
    double one = 0;
    {
      tbb::global_control one_thread(tbb::global_control::max_allowed_parallelism, 1);
      one = timeMedian(opt.repetitions, once);
    }
    const double all = timeMedian(opt.repetitions, once);
    long disk = 0;
    const double rad = 0.15 / cell;
    for (int dr = -int(rad) - 1; dr <= int(rad) + 1; ++dr)
      for (int dc = -int(rad) - 1; dc <= int(rad) + 1; ++dc) disk += dr * dr + dc * dc <= rad * rad + 1e-9;
    char row[160];
    std::snprintf(row, sizeof row, "  %-8.2f %12ld %14.2f %14.2f %8.2fx\n", cell, disk, one * 1e3, all * 1e3, one / all);
    char label[40];
    std::snprintf(label, sizeof label, "footfalls at %.2f m", cell);
    progress.step(label);
    progress.print(stdout, row);
    nlohmann::ordered_json e;
    e["cell_m"] = cell;
    e["candidates"] = 10000;
    e["ms_1t"] = one * 1e3;
    e["ms_all"] = all * 1e3;
    sizes.push_back(e);
  }
  out["sizes"] = sizes;
  out["threads"] = tbb::info::default_concurrency();
  out["repetitions"] = opt.repetitions;
  if (!opt.json.empty()) writeJson(opt.json, out);
  return out;
}

}  // namespace ambler::eval
