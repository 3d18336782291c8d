#pragma once
// `ambler run`: one scenario end to end, its stages (eval/run/stages.hpp) in turn, writing the run
// directory (docs/scenario.md, "The run directory").
#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "eval/scenario/scenario.hpp"

namespace ambler::eval {

struct RunOptions {
  std::filesystem::path out;
  bool progress = true;  // one line per stage on stderr
};

// Runs the scenario and returns the metrics it also writes to out/metrics.json.
// Throws std::runtime_error (or ScenarioError) naming the file or the cause.
nlohmann::ordered_json runScenario(const Scenario& scenario, const RunOptions& options);

}  // namespace ambler::eval
