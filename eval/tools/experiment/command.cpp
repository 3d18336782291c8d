// `ambler experiment locus-vs-cartesian|matching|acceptance|footfall|descent` (docs/experiments/): the
// paper's experiments and ours as sweeps; each prints its markdown table.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <functional>
#include <memory>
#include <string>

#include "eval/scenario/io.hpp"
#include "eval/tools/command.hpp"
#include "eval/tools/experiment/experiment.hpp"

namespace ambler::eval {

namespace {

// What every experiment reads: --out, --sweeps, --quiet (and --jobs where it runs sweeps).
struct Common {
  ExperimentOptions experiment;
  std::string out, sweeps = ExperimentOptions{}.sweeps.string();
  bool quiet = false;

  void addJobs(CLI::App* e) {
    e->add_option("--jobs,-j", experiment.jobs, "Scenarios run at once (each already uses every core)")
        ->capture_default_str()
        ->check(CLI::PositiveNumber);
  }
  void addQuiet(CLI::App* e) { e->add_flag("--quiet,-q", quiet, "No progress lines on stderr"); }
  // The options as the experiment takes them, once the output directory passed its check.
  const ExperimentOptions& resolved() {
    checkOutDir(out);
    experiment.out = out;
    experiment.sweeps = sweeps;
    experiment.progress = !quiet;
    return experiment;
  }
};

// An experiment that runs sweeps and can instead report what a run left (--report).
void addSweepExperiment(CLI::App* parent, Commands& out, const char* name, const char* what, const char* quick,
                        const char* sweeps, const char* report,
                        std::function<std::string(const ExperimentOptions&)> run,
                        std::function<std::string(const ExperimentOptions&)> reported) {
  struct Options {
    Common common;
    bool report = false;
  };
  auto o = std::make_shared<Options>();
  CLI::App* e = parent->add_subcommand(name, what);
  e->add_option("--out,-o", o->common.out, "Experiment directory to write (created if missing)")->required();
  e->add_flag("--quick", o->common.experiment.quick, quick);
  e->add_option("--sweeps", o->common.sweeps, sweeps)->capture_default_str();
  o->common.addJobs(e);
  if (report) e->add_flag("--report", o->report, report);
  o->common.addQuiet(e);
  out.push_back({e, [o, run, reported] {
                   const ExperimentOptions& opt = o->common.resolved();
                   std::fputs((o->report ? reported(opt) : run(opt)).c_str(), stdout);
                 }});
}

}  // namespace

void addExperimentCommands(CLI::App& app, Commands& out) {
  CLI::App* experiment = app.add_subcommand("experiment", "Run one of the paper's experiments as sweeps; prints its "
                                                          "markdown tables (see docs/experiments/).");
  experiment->require_subcommand(1);
  const char* quick = "A reduced run: the first and last value of every axis, the first seed";
  addSweepExperiment(experiment, out, "locus-vs-cartesian",
                     "Locus map vs Cartesian baseline across tilt, noise and map resolution (§6): DIR/table.md, "
                     "DIR/*.png and each sweep's DIR/<sweep>/results.csv.",
                     quick, "Directory of tilt_noise.yaml and resolution.yaml", nullptr, runLocusVsCartesian, nullptr);
  addSweepExperiment(experiment, out, "matching",
                     "Every matching method against the rover's initial error, translation x rotation x seed (§6, "
                     "fig. 5): DIR/table.md, DIR/basin.png and the sweep's DIR/basin/results.csv.",
                     quick, "Directory of matching_basin.yaml",
                     "Run nothing: report DIR/basin/results.csv as it is (e.g. merged from shards)", runMatching,
                     reportMatching);
  addSweepExperiment(experiment, out, "acceptance",
                     "The rover's verdict on every matching method against the truth, three terrains x 100 seeds: "
                     "DIR/table.md and each terrain's DIR/TERRAIN/results.csv.",
                     "A reduced run: the first seed of each terrain", "Directory of acceptance_{mars,fractal,dem}_seeds.yaml",
                     "Run nothing: report DIR/TERRAIN/results.csv as they are", runAcceptance, reportAcceptance);

  addSweepExperiment(experiment, out, "footfall",
                     "Footfalls stepped on by the leg, 200 trials a soil and on poorly seen ground: DIR/table.md, "
                     "DIR/*_tilt.png, DIR/*_slip.png and each sweep's DIR/<sweep>/results.csv.",
                     quick, "Directory of footfall_trials.yaml and footfall_poorly_seen.yaml",
                     "Run nothing: report DIR/<sweep>/results.csv as they are (e.g. merged from shards)", runFootfall,
                     reportFootfall);

  struct Descent {
    Common common;
    DescentOptions descent;
    bool report = false;
  };
  auto d = std::make_shared<Descent>();
  CLI::App* descent = experiment->add_subcommand(
      "descent", "The iconic descent's departures from the paper's, added one at a time and removed one at a time, "
                 "on the acceptance pairs: DIR/table.md and DIR/results.csv.");
  descent->add_option("--out,-o", d->common.out, "Experiment directory to write (created if missing)")->required();
  CLI::Option* d_quick = descent->add_flag("--quick", d->common.experiment.quick, "A reduced run: the first seed of each terrain");
  CLI::Option* d_seeds = descent->add_option("--seeds", d->descent.seeds, "The first N seeds of each terrain")->capture_default_str();
  d_quick->excludes(d_seeds);
  descent->add_option("--sweeps", d->common.sweeps, "Directory of acceptance_{mars,fractal,dem}_seeds.yaml")
      ->capture_default_str();
  CLI::Option* d_timing =
      descent->add_flag("--timing", d->descent.timing, "Fill time_s and the time column (they then differ from run to run)");
  descent->add_flag("--report", d->report, "Run nothing: report DIR/results.csv as it is")
      ->excludes(d_quick)
      ->excludes(d_seeds)
      ->excludes(d_timing);
  d->common.addQuiet(descent);
  out.push_back({descent, [d] {
                   d->descent.experiment = d->common.resolved();
                   std::fputs((d->report ? reportDescent(d->descent) : runDescent(d->descent)).c_str(), stdout);
                 }});
}

}  // namespace ambler::eval
