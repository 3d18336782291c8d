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

}  // namespace ambler::eval
