#pragma once
// Internal to eval/tools/bench/: what the benchmarks share. Not part of the eval library's interface.
#include <unistd.h>

#include <filesystem>
#include <string>
#include <system_error>

namespace ambler::eval::bench_detail {

// A scratch directory for a benchmark's world, temp/ambler-bench-TAG-PID, removed with everything
// in it when the benchmark ends (however it ends).
struct ScratchDir {
  std::filesystem::path dir;
  explicit ScratchDir(const std::string& tag)
      : dir(std::filesystem::temp_directory_path() / ("ambler-bench-" + tag + "-" + std::to_string(::getpid()))) {}
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;
  ~ScratchDir() {
    std::error_code ec;
    std::filesystem::remove_all(dir, ec);
  }
};

}  // namespace ambler::eval::bench_detail
