#pragma once
// `ambler bench`: measured speed, medians of repetitions in one process.
#include <filesystem>
#include <nlohmann/json.hpp>

namespace ambler::eval {

struct BenchOptions {
  int repetitions = 5;
  std::filesystem::path json;  // empty: no file
};

// The scanner benchmark (issue 2): emulator vs a single-thread mj_ray loop on a 64×256 scan,
// and emulator vs a bare Embree packet cast on a 1024×4096 scan over all cores. Prints a table.
nlohmann::ordered_json benchScan(const BenchOptions& options);

// The mapping benchmark (issue 3): nanoseconds per cell of the locus map at 2, 5, 10 and 20 cm on
// one thread and on all cores, against the Cartesian baseline on the same scan. Prints a table.
nlohmann::ordered_json benchMap(const BenchOptions& options);

}  // namespace ambler::eval
