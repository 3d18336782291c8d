// `ambler bench traverse` (docs/benchmarks.md): a traverse scenario run whole, repeatedly.
#include <sys/resource.h>

#include <cstdio>
#include <filesystem>
#include <vector>

#include "base/stopwatch.hpp"
#include "eval/run/runner.hpp"
#include "eval/scenario/io.hpp"
#include "eval/score/stats.hpp"
#include "eval/tools/bench/bench.hpp"

namespace ambler::eval {

nlohmann::ordered_json benchTraverse(const Scenario& sc, const BenchOptions& opt) {
  if (!sc.traverse) throw std::runtime_error(sc.file.string() + ": traverse: bench traverse needs a traverse section");
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "ambler-bench-traverse";
  std::vector<double> total, stage;
  int stops = 0;
  for (int k = 0; k < opt.repetitions; ++k) {
    std::filesystem::remove_all(dir);
    base::Stopwatch t;
    const nlohmann::ordered_json m = runScenario(sc, {dir, false});
    total.push_back(t.seconds());
    stage.push_back(m["timing_s"].value("traverse", 0.0));
    stops = m["traverse"]["stops"].get<int>();
    if (opt.progress)
      std::fprintf(stderr, "bench traverse: run %d of %d, %.2f s (the traverse %.2f s)\n", k + 1, opt.repetitions,
                   total.back(), stage.back());
  }
  std::filesystem::remove_all(dir);
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  const double peak_mib = double(usage.ru_maxrss) / 1024.0;  // kilobytes on Linux
  nlohmann::ordered_json j;
  j["scenario"] = sc.file.string();
  j["stops"] = stops;
  j["repetitions"] = opt.repetitions;
  j["run_s"] = median(total);
  j["traverse_s"] = median(stage);
  j["traverse_ms_per_stop"] = 1e3 * median(stage) / stops;
  j["peak_rss_mib"] = peak_mib;
  std::printf("ambler bench traverse (%s, %d stops, medians of %d runs)\n", sc.file.string().c_str(), stops,
              opt.repetitions);
  std::printf("  whole run (world, scans, traverse, scores, files)  %8.2f s\n", median(total));
  std::printf("  the rover's loop (map, register, merge)            %8.2f s  (%.0f ms a stop)\n", median(stage),
              1e3 * median(stage) / stops);
  std::printf("  peak memory of the process                          %8.0f MiB\n", peak_mib);
  if (!opt.json.empty()) writeJson(opt.json, j);
  return j;
}

}  // namespace ambler::eval
