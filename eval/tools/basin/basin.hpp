#pragma once
// `ambler basin`: the convergence basin of every matching method of a scenario on its first pair
// (docs/basin.md; ../shared/SCENARIO.md, "Convergence basins"). A grid of initial translation ×
// rotation magnitudes, seeded trials per cell (translation in a random horizontal direction,
// rotation about a random axis), every method on the same draws; one row per method and trial in
// basin.csv, split into deterministic shards that merge into the same bytes.
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "eval/run/pair_registration.hpp"
#include "eval/scenario/scenario.hpp"
#include "eval/tools/sweep/sweep.hpp"

namespace ambler::eval {

// Bad basin input (an option or the scenario): one line naming the option or the file and key.
class BasinError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct BasinGrid {
  std::vector<double> translation_m{0, 0.5, 1, 1.5, 2, 2.5, 3};
  std::vector<double> rotation_deg{0, 5, 10, 15, 20, 25, 30};
  int trials = 10;
  bool vertical_axis = false;  // rotations about the world's vertical (yaw) instead of a random axis
};

// "0,0.5,1": finite values ≥ 0, strictly increasing, at most `max`. Throws BasinError naming
// `option` for an empty list, a value that is not a number, negative, repeated, out of order or
// beyond `max`.
std::vector<double> parseBasinAxis(const std::string& text, const std::string& option, double max);

struct BasinOptions {
  std::filesystem::path out;
  BasinGrid grid;
  std::optional<Shard> shard;  // absent: every draw, into out/basin.csv with the figures
  int jobs = 1;                // draws registered at once (each registration already uses every core)
  bool timing = false;         // fill time_s (rows then differ from run to run); empty otherwise
  bool progress = true;        // a progress bar on a terminal, progress lines otherwise
  bool resume = false;         // keep the draws the journal records as finished; register only the rest
  // A user's own methods (the Python module's ambler.basin), after the scenario's, scored alike.
  // The journal knows them by name only: resuming with another function under the same name
  // keeps the first one's rows.
  CustomMethods custom;
};

// The initial error of trial `trial` at magnitudes (t, r): E = (R, t·h) in sensor J's frame, h
// the unit horizontal (world) direction and R the rotation by r about the unit axis that the
// trial draws from the scenario's seed (uniform on the sphere; with `vertical_axis`, the world's
// vertical, a yaw error as the paper's). The directions depend on the seed and the trial alone,
// so every cell (and every method) sees the same directions: the cells differ in magnitude only.
Eigen::Isometry3d basinError(std::uint64_t seed, int trial, double translation_m, double rotation_deg,
                             const Eigen::Isometry3d& T_WS_j, bool vertical_axis = false);

// Runs the basin (or its shard): the scenario's world, the pair's scans and view I's map once
// (into out/pair/, as `ambler run` writes them), then every draw. Writes out/basin.csv and the
// figures (basin_METHOD.png, basin_boundary.png), or for a shard out/basin.shard-K-of-N.csv alone;
// returns the CSV's path. Throws BasinError for a scenario without matching or an option out of
// range, before anything is written.
std::filesystem::path runBasin(const Scenario& scenario, const BasinOptions& options);

// Merges out/basin.shard-*-of-N.csv into out/basin.csv and draws the figures; checks every row
// against the grid (options.grid) and the scenario's methods. Returns basin.csv's path.
std::filesystem::path mergeBasin(const Scenario& scenario, const BasinOptions& options);

}  // namespace ambler::eval
