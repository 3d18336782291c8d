// `ambler basin` (docs/basin.md): every matching method of a scenario from a grid of initial errors.
#include <CLI/CLI.hpp>
#include <memory>
#include <string>

#include "eval/scenario/io.hpp"
#include "eval/scenario/scenario.hpp"
#include "eval/tools/basin/basin.hpp"
#include "eval/tools/command.hpp"
#include "eval/tools/sweep/sweep.hpp"

namespace ambler::eval {

void addBasinCommand(CLI::App& app, Commands& out) {
  struct Options {
    std::string file, out, shard, translation, rotation, axis = "random";
    BasinOptions basin;
    bool merge = false, quiet = false;
  };
  auto o = std::make_shared<Options>();
  CLI::App* basin = app.add_subcommand("basin", "The convergence basin of every matching method of a scenario on its "
                                                "first pair: DIR/basin.csv, DIR/basin_METHOD.png, "
                                                "DIR/basin_boundary.png (see docs/basin.md).");
  basin->add_option("scenario", o->file, "Scenario YAML with map and matching sections")->required();
  basin->add_option("--out,-o", o->out, "Basin directory to write (created if missing)")->required();
  CLI::Option* translation = basin->add_option("--translation-m", o->translation,
                                               "Initial translation magnitudes, metres, comma-separated "
                                               "(default 0,0.5,1,1.5,2,2.5,3)");
  CLI::Option* rotation = basin->add_option("--rotation-deg", o->rotation,
                                            "Initial rotation magnitudes, degrees, comma-separated "
                                            "(default 0,5,10,15,20,25,30)");
  basin->add_option("--trials", o->basin.grid.trials, "Seeded trials per cell")->capture_default_str();
  basin->add_option("--rotation-axis", o->axis, "random (uniform on the sphere) or vertical (yaw errors only)")
      ->capture_default_str();
  CLI::Option* shard = basin->add_option("--shard", o->shard,
                                         "Run only shard K of N (1-based): the draws u with u mod N = K-1, into "
                                         "DIR/basin.shard-K-of-N.csv");
  basin->add_flag("--merge", o->merge, "Merge DIR/basin.shard-*-of-N.csv into DIR/basin.csv and draw the "
                                       "figures; runs nothing (give the same grid options)");
  basin->add_option("--jobs,-j", o->basin.jobs, "Draws registered at once (each already uses every core)")
      ->capture_default_str();
  basin->add_flag("--timing", o->basin.timing, "Fill the time_s column (rows then differ from run to run)");
  basin->add_flag("--quiet,-q", o->quiet, "No progress lines on stderr");
  basin->add_flag("--resume", o->basin.resume, "Keep the draws DIR's journal records as finished (a basin "
                                               "killed before it ended); register only the rest");
  out.push_back({basin, [o, translation, rotation, shard] {
                   checkOutDir(o->out);
                   BasinOptions& opt = o->basin;
                   opt.out = o->out;
                   opt.progress = !o->quiet;
                   if (translation->count()) opt.grid.translation_m = parseBasinAxis(o->translation, "--translation-m", 100.0);
                   if (rotation->count()) opt.grid.rotation_deg = parseBasinAxis(o->rotation, "--rotation-deg", 180.0);
                   if (shard->count()) opt.shard = parseShard(o->shard);
                   if (o->axis != "random" && o->axis != "vertical")
                     throw BasinError("--rotation-axis: expected random or vertical, got " + yamlQuoted(o->axis));
                   opt.grid.vertical_axis = o->axis == "vertical";
                   if (o->merge && (opt.shard || opt.timing || opt.resume))
                     throw BasinError(std::string("--merge: merges the shards' files; ") +
                                      (opt.shard ? "--shard" : opt.timing ? "--timing" : "--resume") + " does not apply");
                   const Scenario sc = loadScenario(o->file);
                   if (o->merge)
                     mergeBasin(sc, opt);
                   else
                     runBasin(sc, opt);
                 }});
}

}  // namespace ambler::eval
