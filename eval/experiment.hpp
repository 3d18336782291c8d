#pragma once
// `ambler experiment locus-vs-cartesian`: the paper's first experiment (§6) — the locus map against
// the Cartesian baseline across surface orientation and noise, and across map resolution — run as
// two sweeps, aggregated over seeds into markdown tables and plots
// (docs/experiments/locus_vs_cartesian.md).
#include <filesystem>
#include <string>

namespace ambler::eval {

struct ExperimentOptions {
  std::filesystem::path out;                               // DIR: sweeps, table.md, the plots
  std::filesystem::path sweeps = "scenarios/experiments";  // holds tilt_noise.yaml, resolution.yaml
  bool quick = false;    // the first and last value of every axis and the first seed only
  int jobs = 1;          // scenarios run at once (as `ambler sweep --jobs`)
  bool progress = true;  // the sweeps' progress lines on stderr
};

// Runs both sweeps into out/tilt_noise/ and out/resolution/ (results.csv and runs/<k>/), then
// reports them: writes out/table.md, out/tilt_noise.png, out/resolution.png and
// out/range_bands.png, and returns the markdown of table.md. Throws SweepError for a bad sweep
// file, a sweep without the axes the report needs, or a failed run.
std::string runLocusVsCartesian(const ExperimentOptions& options);

}  // namespace ambler::eval
