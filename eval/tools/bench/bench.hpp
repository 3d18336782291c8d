#pragma once
// `ambler bench`: measured speed, medians of repetitions in one process.
#include <filesystem>
#include <nlohmann/json.hpp>

#include "eval/scenario/scenario.hpp"

namespace ambler::eval {

struct BenchOptions {
  int repetitions = 5;
  std::filesystem::path json;  // empty: no file
  bool progress = true;        // a bar on a terminal, a line per measurement otherwise (stderr)
};

// The scanner benchmark (docs/benchmarks.md): emulator vs a single-thread mj_ray loop on a 64×256
// scan, and emulator vs a bare Embree packet cast of the same rays (sim::RayScene::referenceCast)
// on a 1024×4096 scan over all cores. The ERIM's default sensor model. Prints a table.
nlohmann::ordered_json benchScan(const BenchOptions& options);

// The mapping benchmark (docs/benchmarks.md): nanoseconds per cell of the locus map at 2, 5, 10 and
// 20 cm on one thread and on all cores, against the Cartesian baseline on the same scan. The scan
// is the ERIM's default sensor model (the demo's), unwrapped and edge-detected by
// perception::scanToMap as a run's map stage does; the maps are then timed alone. Prints a table.
nlohmann::ordered_json benchMap(const BenchOptions& options);

// The matching benchmark: the scenario's first matching pair (world, scans and maps built once, as
// a run builds them), each of its methods timed per pair on one thread and on all cores (medians),
// with its iterations and pose error. Throws std::runtime_error if the scenario has no map or
// matching section. Prints a table.
nlohmann::ordered_json benchMatch(const Scenario& scenario, const BenchOptions& options);

// The footfall benchmark (docs/benchmarks.md): every method of docs/footfall.md, dense over 100 × 100
// candidate centres (10 000) of a fractal map (σ 1 cm everywhere), 30 cm foot, at 10 cm cells (a 10 m
// square) and at 2 cm (a 2 m square); medians on one thread and on all cores. Prints a table.
nlohmann::ordered_json benchFootfall(const BenchOptions& options);

// The traverse benchmark: the scenario (a traverse section) run whole `repetitions` times into a
// temporary directory; the median seconds of the run and of its traverse stage (the rover's loop:
// each stop mapped, registered and merged), and the process's peak resident memory. Throws
// std::runtime_error when the scenario has no traverse. Prints a table.
nlohmann::ordered_json benchTraverse(const Scenario& scenario, const BenchOptions& options);

// The leg benchmark (docs/leg.md): the scenario's leg (its foot, load and soil, as the leg stage
// builds it) on its world, stepping on 3 × 3 footfalls over the footfall region's candidate centres,
// on one thread: the median time to build the leg once (sim::Leg), per step of that leg, of the
// whole world's leg built once, and of sim::stepLeg (the model built for every step), with the
// largest difference of the first's outcomes from stepLeg's. Throws std::runtime_error if the scenario has no footfall or leg section. Prints a table.
nlohmann::ordered_json benchLeg(const Scenario& scenario, const BenchOptions& options);

}  // namespace ambler::eval
