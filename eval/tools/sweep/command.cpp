// `ambler sweep` (docs/sweeps.md): a sweep's runs into results.csv, sharded, merged or resumed.
#include <CLI/CLI.hpp>
#include <memory>
#include <string>

#include "eval/scenario/io.hpp"
#include "eval/tools/command.hpp"
#include "eval/tools/sweep/sweep.hpp"

namespace ambler::eval {

void addSweepCommand(CLI::App& app, Commands& out) {
  struct Options {
    std::string file, out, shard, keep = "metrics";
    int jobs = 1;
    bool merge = false, timing = false, quiet = false, resume = false;
  };
  auto o = std::make_shared<Options>();
  CLI::App* sweep = app.add_subcommand("sweep", "Run the cartesian product of a sweep's axes over a base scenario; "
                                                "one row per run in DIR/results.csv (see docs/sweeps.md).");
  sweep->add_option("sweep", o->file, "Sweep YAML (see docs/sweeps.md)")->required();
  sweep->add_option("--out,-o", o->out, "Sweep directory: results.csv and runs/<k>/")->required();
  CLI::Option* shard = sweep->add_option("--shard", o->shard,
                                         "Run only shard K of N (1-based): the runs k with k mod N = K-1, "
                                         "into DIR/results.shard-K-of-N.csv");
  sweep->add_flag("--merge", o->merge, "Merge DIR/results.shard-*-of-N.csv into DIR/results.csv; runs nothing");
  sweep->add_option("--jobs,-j", o->jobs, "Scenarios run at once (each already uses every core)")->capture_default_str();
  sweep->add_option("--keep", o->keep, "What stays of each run directory: none, metrics (metrics.json and "
                                       "scenario.resolved.yaml) or all")
      ->capture_default_str();
  sweep->add_flag("--timing", o->timing, "Also the timing_s.* columns (rows then differ from run to run)");
  sweep->add_flag("--quiet,-q", o->quiet, "No progress lines on stderr");
  sweep->add_flag("--resume", o->resume, "Keep the runs DIR's journal records as finished (a sweep killed "
                                         "before it ended); run only the rest");
  out.push_back({sweep, [o, shard] {
                   checkOutDir(o->out);
                   SweepOptions opt{o->out, std::nullopt, o->jobs, parseKeep(o->keep), o->timing, !o->quiet, o->resume};
                   if (shard->count()) opt.shard = parseShard(o->shard);
                   if (opt.jobs < 1) throw SweepError("--jobs: expected an integer >= 1, got " + std::to_string(opt.jobs));
                   if (o->merge && (opt.shard || o->timing || o->resume)) {
                     throw SweepError(std::string("--merge: merges the shards' files; ") +
                                      (opt.shard ? "--shard" : o->timing ? "--timing" : "--resume") + " does not apply");
                   }
                   const Sweep sw = loadSweep(o->file);
                   if (o->merge)
                     mergeSweep(sw, o->out, !o->quiet);
                   else
                     runSweep(sw, opt);
                 }});
}

}  // namespace ambler::eval
