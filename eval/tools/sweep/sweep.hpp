#pragma once
// `ambler sweep`: the cartesian product of a sweep's axes over a base scenario, one row per run in
// results.csv, split into deterministic shards that merge into the same rows (docs/sweeps.md).
#include <cstddef>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "eval/run/pair_registration.hpp"
#include "eval/scenario/scenario.hpp"
#include "eval/tools/shards.hpp"

namespace ambler::eval {

// Bad input in a sweep file or a sweep option, or a run of the sweep that failed: one line naming
// the file (or option) and the key.
class SweepError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct SweepAxis {
  std::string key;                  // dotted path into the scenario YAML: "views.0.xyz_m"
  std::vector<std::string> values;  // each value as YAML flow text, as written: "[15, 0]"
  std::vector<std::string> cells;   // each value as its results.csv cell: "15;0"
};

struct Sweep {
  std::filesystem::path file;
  std::string name;
  std::string description;
  std::filesystem::path base;  // the base scenario, resolved against the sweep file
  std::vector<SweepAxis> axes;
  std::vector<std::string> metrics;  // the metric columns; empty: every scalar leaf of metrics.json
  std::vector<Scenario> runs;        // run k: its combination, parsed and validated, named <name>_<k>

  // The value index on each axis of run k; the last axis varies fastest.
  std::vector<std::size_t> combination(std::size_t k) const;
};

// Loads a sweep and validates every combination with the scenario reader, so a bad value fails
// before anything runs. Throws SweepError naming the sweep file, the key, and for a bad
// combination the axis, the value and the scenario reader's message.
Sweep loadSweep(const std::filesystem::path& file);
// The same from YAML text; `file` names it in messages and anchors the relative `base` path.
Sweep parseSweep(const std::string& yaml_text, const std::filesystem::path& file);

enum class Keep { None, Metrics, All };  // what stays of each run directory after its row is read

struct SweepOptions {
  std::filesystem::path out;
  std::optional<Shard> shard;  // absent: every run, written to out/results.csv
  int jobs = 1;                // scenarios run at once (each already uses every core)
  Keep keep = Keep::Metrics;
  bool timing = false;   // also the timing_s.* columns (then rows are not reproducible)
  bool progress = true;  // a progress bar on a terminal, one line per run otherwise
  bool resume = false;   // keep the runs the journal records as finished; run only the rest
  CustomMethods custom;  // a user's own registration methods, in every run (RunOptions::custom)
};

// "none", "metrics" or "all". Throws SweepError naming --keep.
Keep parseKeep(const std::string& text);

// Runs the sweep (or its shard) into out/runs/<k>/ and writes out/results.csv (or
// out/results.shard-K-of-N.csv); returns the CSV's path. Each finished run's row is first recorded
// in out/results.journal (results.shard-K-of-N.journal), so `resume` after a kill runs only the
// runs not recorded (docs/sweeps.md, "Resuming"). Throws SweepError for a bad option or a failed
// run (no CSV is written then), JournalError for a journal that cannot be read or written.
std::filesystem::path runSweep(const Sweep& sweep, const SweepOptions& options);

// Merges out/results.shard-*-of-N.csv into out/results.csv, rows by run index; returns its path.
// Throws SweepError when a run is missing or duplicated, headers differ, or rows do not match the
// sweep file.
std::filesystem::path mergeSweep(const Sweep& sweep, const std::filesystem::path& out, bool progress = true);

// The records of a results.csv (RFC 4180; the reader `--merge` uses), header first; nullopt when a
// quote is left open or stray.
std::optional<std::vector<std::vector<std::string>>> parseResultsCsv(const std::string& text);

}  // namespace ambler::eval
