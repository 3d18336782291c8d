// `ambler bench leg` (docs/benchmarks.md, docs/leg.md): the leg built once (sim::Leg, as the leg stage
// builds it) against one per step (sim::stepLeg) and against MuJoCo's own heightfield collision
// (LegConfig::cull_prisms off), on a scenario's world and footfall region.
#include <tbb/global_control.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <ctime>
#include <cstdio>
#include <filesystem>
#include <vector>

#include "base/stopwatch.hpp"
#include "eval/geo/dem.hpp"
#include "eval/run/stages.hpp"
#include "eval/scenario/io.hpp"
#include "eval/score/stats.hpp"
#include "eval/tools/bench/bench.hpp"
#include "base/temp_dir.hpp"
#include "eval/tools/progress.hpp"
#include "sim/leg.hpp"
#include "sim/world.hpp"

namespace ambler::eval {

namespace fs = std::filesystem;

namespace {

// This thread's CPU seconds: on a shared machine, what the step cost whatever else ran.
double cpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

}  // namespace

nlohmann::ordered_json benchLeg(const Scenario& sc, const BenchOptions& opt) {
  if (!sc.footfall || !sc.leg)
    throw std::runtime_error(sc.file.string() + ": bench leg needs a scenario with footfall and leg sections");
  std::fprintf(stderr, "bench leg: building %s's world...\n", sc.name.c_str());
  const base::TempDir scratch("bench-leg");
  const fs::path& dir = scratch.path();
  const fs::path world = sc.terrain.kind == terrains::TerrainKind::Mjcf
                             ? fs::path(sc.terrain.mjcf)
                             : sim::writeWorld(scenarioTerrain(sc), dir, "bench");
  const sim::LegConfig config = legConfig(sc);
  const sim::LegRegion region = legRegion(sc);
  // 3 × 3 footfalls over the candidate centres (a foot radius inside the region, docs/footfall.md).
  const double r = 0.5 * config.foot_diameter_m;
  std::vector<Eigen::Vector2d> at;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      const auto lerp = [r](double lo, double hi, int k) {
        return lo + r > hi - r ? 0.5 * (lo + hi) : lo + r + 0.5 * k * (hi - lo - 2 * r);
      };
      at.emplace_back(lerp(region.x_min, region.x_max, j), lerp(region.y_min, region.y_max, i));
    }

  tbb::global_control one_thread(tbb::global_control::max_allowed_parallelism, 1);
  Progress progress("bench leg", opt.repetitions + 2, 0, Progress::modeFor(opt.progress));
  std::vector<double> build_s, step_s, step_cpu_s, whole_s, whole_cpu_s, reference_s, reference_cpu_s;
  std::vector<double> unculled_s, unculled_cpu_s;
  std::vector<sim::LegOutcome> fast(at.size()), reference(at.size()), unculled(at.size());
  // The same leg with MuJoCo's own heightfield collision (every prism under a tile's box to MPR:
  // the leg before issue 28's speed-up), stepped in turn with the culling one on every footfall.
  sim::LegConfig mujoco_collision = config;
  mujoco_collision.cull_prisms = false;
  sim::Leg legacy(world, region, mujoco_collision);
  for (int k = 0; k < opt.repetitions; ++k) {
    base::Stopwatch t;
    sim::Leg leg(world, region, config);
    build_s.push_back(t.seconds());
    if (k == 0) leg.step(at[0].x(), at[0].y());  // warm-up
    for (std::size_t i = 0; i < at.size(); ++i) {
      base::Stopwatch ts;
      const double c0 = cpuSeconds();
      fast[i] = leg.step(at[i].x(), at[i].y());
      step_cpu_s.push_back(cpuSeconds() - c0);
      step_s.push_back(ts.seconds());
      base::Stopwatch tu;
      const double u0 = cpuSeconds();
      unculled[i] = legacy.step(at[i].x(), at[i].y());
      unculled_cpu_s.push_back(cpuSeconds() - u0);
      unculled_s.push_back(tu.seconds());
    }
    progress.step("leg built once");
  }
  sim::Leg probe(world, region, config);
  sim::Leg whole(world, config);
  for (std::size_t i = 0; i < at.size(); ++i) {
    base::Stopwatch t;
    const double c0 = cpuSeconds();
    whole.step(at[i].x(), at[i].y());
    whole_cpu_s.push_back(cpuSeconds() - c0);
    whole_s.push_back(t.seconds());
  }
  progress.step("the whole world built once");
  for (std::size_t i = 0; i < at.size(); ++i) {
    base::Stopwatch t;
    const double c0 = cpuSeconds();
    reference[i] = sim::stepLeg(world, at[i].x(), at[i].y(), config);
    reference_cpu_s.push_back(cpuSeconds() - c0);
    reference_s.push_back(t.seconds());
  }
  progress.step("stepLeg per step");
  progress.finish();
  double d_tilt = 0, d_sink = 0, d_slip = 0, u_tilt = 0, u_sink = 0, u_slip = 0, u_time = 0;
  for (std::size_t i = 0; i < at.size(); ++i) {
    d_tilt = std::max(d_tilt, std::abs(fast[i].tilt_deg - reference[i].tilt_deg));
    d_sink = std::max(d_sink, std::abs(fast[i].sink_m - reference[i].sink_m));
    d_slip = std::max(d_slip, std::abs(fast[i].slip_m - reference[i].slip_m));
    u_tilt = std::max(u_tilt, std::abs(fast[i].tilt_deg - unculled[i].tilt_deg));
    u_sink = std::max(u_sink, std::abs(fast[i].sink_m - unculled[i].sink_m));
    u_slip = std::max(u_slip, std::abs(fast[i].slip_m - unculled[i].slip_m));
    u_time = std::max(u_time, std::abs(fast[i].time_s - unculled[i].time_s));
  }

  std::printf("ambler bench leg (%s, %s, %.0f N; %zu footfalls, 1 thread; medians of %d builds and %zu steps)\n",
              sc.name.c_str(), config.soil == sim::Soil::Sand ? "sand" : "rock", config.load_n, at.size(),
              opt.repetitions, step_s.size());
  std::printf("  %-52s %10s %12s\n", "", "wall ms", "CPU ms");
  std::printf("  %-52s %10.1f\n", "build once (the world loaded, cropped, compiled)", 1e3 * median(build_s));
  std::printf("  %-52s %10.1f %12.1f\n", "a step of the leg built once (sim::Leg::step)", 1e3 * median(step_s),
              1e3 * median(step_cpu_s));
  std::printf("  %-52s %10.1f %12.1f\n", "the same, MuJoCo's heightfield collision (no culling)",
              1e3 * median(unculled_s), 1e3 * median(unculled_cpu_s));
  std::printf("  %-52s %10.1f %12.1f\n", "a step of the whole world built once (no crop)", 1e3 * median(whole_s),
              1e3 * median(whole_cpu_s));
  std::printf("  %-52s %10.1f %12.1f\n", "a step built from the world file (sim::stepLeg)", 1e3 * median(reference_s),
              1e3 * median(reference_cpu_s));
  std::printf("  the world cropped to the region: %d geoms kept, %d dropped%s\n", probe.terrainGeoms(),
              probe.droppedGeoms(), probe.cropped() ? "" : " (not cropped: the whole world)");
  std::printf("  largest difference built-once - per-step: tilt %.2g deg, sink %.2g m, slip %.2g m\n", d_tilt, d_sink,
              d_slip);
  std::printf("  largest difference culled - MuJoCo's collision: tilt %.2g deg, sink %.2g m, slip %.2g m, settled %.2g s\n",
              u_tilt, u_sink, u_slip, u_time);
  nlohmann::ordered_json j;
  j["scenario"] = sc.file.string();
  j["footfalls"] = at.size();
  j["repetitions"] = opt.repetitions;
  j["build_ms"] = 1e3 * median(build_s);
  j["step_ms"] = 1e3 * median(step_s);
  j["step_cpu_ms"] = 1e3 * median(step_cpu_s);
  j["unculled_step_ms"] = 1e3 * median(unculled_s);
  j["unculled_step_cpu_ms"] = 1e3 * median(unculled_cpu_s);
  j["whole_world_step_ms"] = 1e3 * median(whole_s);
  j["whole_world_step_cpu_ms"] = 1e3 * median(whole_cpu_s);
  j["reference_step_ms"] = 1e3 * median(reference_s);
  j["reference_step_cpu_ms"] = 1e3 * median(reference_cpu_s);
  j["cropped"] = probe.cropped();
  j["geoms_kept"] = probe.terrainGeoms();
  j["geoms_dropped"] = probe.droppedGeoms();
  j["max_abs_diff"] = {{"tilt_deg", d_tilt}, {"sink_m", d_sink}, {"slip_m", d_slip}};
  j["max_abs_diff_unculled"] = {{"tilt_deg", u_tilt}, {"sink_m", u_sink}, {"slip_m", u_slip}, {"time_s", u_time}};
  if (!opt.json.empty()) writeJson(opt.json, j);
  return j;
}

}  // namespace ambler::eval
