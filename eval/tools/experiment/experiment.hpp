#pragma once
// `ambler experiment`: the paper's experiments (§6) run as sweeps, aggregated over seeds into
// markdown tables and plots. locus-vs-cartesian: the locus map against the Cartesian baseline
// across surface orientation and noise, and across map resolution
// (docs/experiments/locus_vs_cartesian.md). matching: every matching method against the rover's
// initial error (docs/experiments/matching.md). acceptance: the rover's verdict on every
// registration against the truth (docs/experiments/acceptance.md). footfall: footfalls stepped on
// by the leg, 200 trials a soil and on poorly seen ground (docs/experiments/footfall.md). descent:
// the iconic descent's departures from the paper's, one at a time (docs/experiments/descent.md).
#include <filesystem>
#include <string>

#include "eval/run/pair_registration.hpp"

namespace ambler::eval {

struct ExperimentOptions {
  std::filesystem::path out;                               // DIR: sweeps, table.md, the plots
  std::filesystem::path sweeps = "scenarios/experiments";  // holds the sweep files (tilt_noise.yaml, ...)
  bool quick = false;    // the first and last value of every axis and the first seed only
  int jobs = 1;          // scenarios run at once (as `ambler sweep --jobs`)
  bool progress = true;  // the sweeps' progress lines on stderr
  CustomMethods custom;  // a user's own registration methods, in every run's match stage (docs/python.md)
};

// Runs both sweeps into out/tilt_noise/ and out/resolution/ (results.csv and runs/<k>/), then
// reports them: writes out/table.md, out/tilt_noise.png, out/resolution.png and
// out/range_bands.png, and returns the markdown of table.md. Throws SweepError for a bad sweep
// file, a sweep without the axes the report needs, or a failed run.
std::string runLocusVsCartesian(const ExperimentOptions& options);

// Runs the sweep matching_basin.yaml into out/basin/ (results.csv and runs/<k>/), then
// reportMatching. Throws SweepError for a bad sweep file, a sweep without the initial error's
// axes and the seed or without matching methods, or a failed run.
std::string runMatching(const ExperimentOptions& options);

// Reports an already-run basin sweep from out/basin/results.csv alone (a sweep run in shards and
// merged reports the same): writes out/table.md and out/basin.png and returns the markdown of
// table.md. Throws SweepError as runMatching does, and when the CSV is missing or not the sweep's.
std::string reportMatching(const ExperimentOptions& options);

// Runs the three acceptance sweeps (acceptance_{mars,fractal,dem}_seeds.yaml) into
// out/{mars,fractal,dem}/, then reportAcceptance: writes out/table.md (per terrain and method:
// successes, accepted, false accepts and rejects, worse than the start unflagged) and returns it.
// Throws SweepError for a bad sweep file, a sweep without the seed axis or matching methods, or a
// failed run.
std::string runAcceptance(const ExperimentOptions& options);
std::string reportAcceptance(const ExperimentOptions& options);

// Runs footfall_trials.yaml and footfall_poorly_seen.yaml into out/footfall_trials/ and
// out/footfall_poorly_seen/, then reportFootfall: writes out/table.md (per sweep, soil and method:
// successes with a 95 % interval, tilt, slip, true percentile, regret, the truth's best stepped on,
// the misses by cause) and out/*_{tilt,slip}.png, and returns the markdown. Throws SweepError for a
// bad sweep file, a sweep without the seed axis or without footfall and leg sections, or a failed run.
std::string runFootfall(const ExperimentOptions& options);
std::string reportFootfall(const ExperimentOptions& options);

// `ambler experiment descent` (docs/experiments/descent.md): iconicGradientDescent's four departures
// from the paper's descent (IconicOptions::descent_*), on the acceptance experiment's pairs.
struct DescentOptions {
  ExperimentOptions experiment;  // out, sweeps (acceptance_*_seeds.yaml), quick (one seed), progress
  int seeds = 10;                // the first `seeds` of each terrain's sweep
  bool timing = false;           // fill time_s and the table's time column (they then differ from run to run)
};

// Scans and maps each pair (in out/pair.tmp/, removed after it), registers it by every variant (the ladder
// literal → iconic_robust, and iconic_robust less each departure) from its believed pose, writes
// out/results.csv (a row per pair and variant), then reportDescent. Throws SweepError for a bad
// sweep file, one without the seed axis or the map and matching sections, or --seeds beyond it.
std::string runDescent(const DescentOptions& options);
// Reports out/results.csv as it is: writes out/table.md (per terrain and variant: successes,
// median and 95th-percentile errors, median iterations and time) and returns it. Throws SweepError
// when the CSV is missing or not the experiment's.
std::string reportDescent(const DescentOptions& options);

}  // namespace ambler::eval
