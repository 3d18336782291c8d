// `ambler bench scan|map|match|footfall|traverse|leg` (docs/benchmarks.md): speed, as tables of medians.
#include <CLI/CLI.hpp>
#include <functional>
#include <memory>
#include <string>

#include "eval/scenario/scenario.hpp"
#include "eval/tools/bench/bench.hpp"
#include "eval/tools/command.hpp"

namespace ambler::eval {

void addBenchCommands(CLI::App& app, Commands& out) {
  CLI::App* bench = app.add_subcommand("bench", "Measure speed; prints a table of medians.");
  bench->require_subcommand(1);
  // A bench subcommand with the options every benchmark has (--json FILE, --reps N, --quiet) and
  // its action, which gets them.
  const auto add = [&](const char* name, const char* what, std::function<void(const BenchOptions&)> action) {
    struct Options {
      std::string json;
      BenchOptions bench;
    };
    auto o = std::make_shared<Options>();
    CLI::App* b = bench->add_subcommand(name, what);
    b->add_option("--json", o->json, "Also write the figures to this JSON file");
    b->add_option("--reps", o->bench.repetitions, "Repetitions per measurement (median reported)")
        ->check(CLI::Range(1, 1000));
    b->add_flag_callback("--quiet,-q", [o] { o->bench.progress = false; }, "No progress on stderr");
    out.push_back({b, [o, action] {
                     o->bench.json = o->json;
                     action(o->bench);
                   }});
    return b;
  };
  add("scan", "ERIM emulator vs mj_ray (1 thread, 64x256) and vs a bare Embree packet cast (all cores, 1024x4096).",
      benchScan);
  add("map", "Locus map ns/cell at 2, 5, 10, 20 cm (1 thread and all cores) vs the Cartesian baseline.", benchMap);
  auto scenario = std::make_shared<std::string>("scenarios/demo.yaml");
  CLI::App* match = add("match", "Every matching method per pair, ms and iterations (1 thread and all cores), on a "
                                 "scenario's first pair.",
                        [scenario](const BenchOptions& opt) { benchMatch(loadScenario(*scenario), opt); });
  match->add_option("--scenario", *scenario, "A scenario with map and matching sections")->capture_default_str();
  auto traverse = std::make_shared<std::string>("scenarios/traverse.yaml");
  CLI::App* trav = add("traverse", "A traverse run whole: seconds per run and per stop of the rover's loop, peak memory.",
                       [traverse](const BenchOptions& opt) { benchTraverse(loadScenario(*traverse), opt); });
  trav->add_option("--scenario", *traverse, "A scenario with a traverse section")->capture_default_str();
  auto leg_scenario = std::make_shared<std::string>("scenarios/experiments/sandbox.yaml");
  CLI::App* leg = add("leg", "The leg built once vs per step: ms to build, ms per step (1 thread), on a scenario's "
                             "footfall region.",
                      [leg_scenario](const BenchOptions& opt) { benchLeg(loadScenario(*leg_scenario), opt); });
  leg->add_option("--scenario", *leg_scenario, "A scenario with footfall and leg sections")->capture_default_str();
  add("footfall", "Footfall evaluation, all methods dense over 10 000 candidates at 10 and 2 cm (1 thread and all cores).",
      benchFootfall);
}

}  // namespace ambler::eval
