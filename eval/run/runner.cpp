#include "eval/run/runner.hpp"

#include "base/random.hpp"
#include "eval/scenario/io.hpp"
#include "eval/run/stages.hpp"

namespace ambler::eval {

namespace fs = std::filesystem;


nlohmann::ordered_json runScenario(const Scenario& sc, const RunOptions& opt) {
  return runScenarioKeeping(sc, opt).metrics;
}

RunProducts runScenarioKeeping(const Scenario& sc, const RunOptions& opt) {
  base::Stopwatch total;
  checkCustomMethods(opt.custom, sc.file.empty() ? sc.name : sc.file.string());
  RunState state{sc, opt.out, opt.progress};
  state.custom = &opt.custom;
  // No directory yet: the world stage makes it once the views are checked against the terrain,
  // so a refused scenario leaves nothing behind.
  state.metrics["name"] = sc.name;
  state.metrics["seed"] = sc.seed;
  for (const Stage& stage : runStages())
    if (stage.wanted(sc)) stage.run(state);

  nlohmann::ordered_json metrics = std::move(state.metrics);
  metrics["timing_s"] = std::move(state.timing);
  metrics["timing_s"]["total"] = total.seconds();
  // Defaults the world stage found in a file (a DEM's centre and offset) are written as values.
  Scenario resolved = sc;
  if (state.terrain_resolved) resolved.terrain = *state.terrain_resolved;
  writeText(state.out / "scenario.resolved.yaml", resolvedYaml(resolved));
  writeJson(state.out / "metrics.json", metrics);
  state.say("wrote     " + (state.out / "metrics.json").string() + ", " + (state.out / "terrain.png").string() +
            ", " + (state.out / "scans").string() + "/, " + (sc.map ? (state.out / "maps").string() + "/, " : std::string()) +
            (sc.matching ? (state.out / "matching").string() + "/, " : std::string()) +
            (state.out / "world").string() + "/");
  RunProducts products;
  products.metrics = std::move(metrics);
  for (std::size_t k = 0; k < state.views.size(); ++k) {
    ViewState& v = state.views[k];
    if (v.locus) products.maps.emplace_back("view_" + std::to_string(k), std::move(v.locus->map));
    if (v.scan) products.scans.push_back(std::move(v.scan->image));
  }
  if (state.composite) products.maps.emplace_back("composite", std::move(*state.composite));
  return products;
}

}  // namespace ambler::eval
