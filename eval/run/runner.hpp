#pragma once
// `ambler run`: one scenario end to end, its stages (eval/run/stages.hpp) in turn, writing the run
// directory (docs/scenario.md, "The run directory").
#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>

#include <string>
#include <utility>
#include <vector>

#include "eval/run/pair_registration.hpp"
#include "eval/scenario/scenario.hpp"
#include "perception/elevation_map.hpp"
#include "perception/range_image.hpp"

namespace ambler::eval {

struct RunOptions {
  std::filesystem::path out;
  bool progress = true;  // one line per stage on stderr
  // A user's own registration methods (the Python module's `custom`): the match stage runs them
  // after the scenario's on every pair and scores them alike; the merge does not use them.
  CustomMethods custom;
};

// Runs the scenario and returns the metrics it also writes to out/metrics.json.
// Throws std::runtime_error (or ScenarioError) naming the file or the cause.
nlohmann::ordered_json runScenario(const Scenario& scenario, const RunOptions& options);

// What a run leaves in memory besides its files (the Python module's Run, docs/python.md): its
// metrics (as runScenario returns them), each map by the stem of its files (view_K, composite) in
// the order the stages made them, and each view's range image as the rover got it.
struct RunProducts {
  nlohmann::ordered_json metrics;
  std::vector<std::pair<std::string, perception::ElevationMap>> maps;
  std::vector<perception::RangeImage> scans;
};
// runScenario, keeping the products. The same files and metrics.
RunProducts runScenarioKeeping(const Scenario& scenario, const RunOptions& options);

}  // namespace ambler::eval
