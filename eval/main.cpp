// The ambler command line: run a scenario, sweep scenarios, run experiments and benchmarks.
#include <CLI/CLI.hpp>

#include <cstdio>
#include <exception>
#include <filesystem>
#include <iostream>
#include <string>

#include "eval/tools/basin/basin.hpp"
#include "eval/tools/bench/bench.hpp"
#include "eval/geo/dem.hpp"
#include "eval/tools/experiment/experiment.hpp"
#include "eval/scenario/io.hpp"
#include "eval/tools/report/report.hpp"
#include "eval/run/runner.hpp"
#include "eval/scenario/scenario.hpp"
#include "eval/tools/sweep/sweep.hpp"

int main(int argc, char** argv) {
  using namespace ambler::eval;
  CLI::App app{"ambler: a simulation-and-evaluation testbed for planetary-rover terrain mapping\n"
               "(the Ambler's ERIM range sensor, locus-algorithm elevation maps, matching, footfalls)."};
  app.require_subcommand(1);

  std::string scenario_file, out_dir;
  bool quiet = false;
  auto* run = app.add_subcommand("run", "Run one scenario end to end and write its run directory "
                                        "(metrics.json, world/, scans/, pictures).");
  run->add_option("scenario", scenario_file, "Scenario YAML (see docs/scenario.md)")->required();
  run->add_option("--out,-o", out_dir, "Run directory to write (created if missing)")->required();
  run->add_flag("--quiet,-q", quiet, "No progress lines on stderr");

  std::string sweep_file, sweep_out, sweep_shard, sweep_keep = "metrics";
  int sweep_jobs = 1;
  bool sweep_merge = false, sweep_timing = false, sweep_quiet = false, sweep_resume = false;
  auto* sweep = app.add_subcommand("sweep", "Run the cartesian product of a sweep's axes over a base scenario; "
                                            "one row per run in DIR/results.csv (see docs/sweeps.md).");
  sweep->add_option("sweep", sweep_file, "Sweep YAML (see docs/sweeps.md)")->required();
  sweep->add_option("--out,-o", sweep_out, "Sweep directory: results.csv and runs/<k>/")->required();
  auto* shard_opt = sweep->add_option("--shard", sweep_shard,
                                      "Run only shard K of N (1-based): the runs k with k mod N = K-1, "
                                      "into DIR/results.shard-K-of-N.csv");
  sweep->add_flag("--merge", sweep_merge, "Merge DIR/results.shard-*-of-N.csv into DIR/results.csv; runs nothing");
  sweep->add_option("--jobs,-j", sweep_jobs, "Scenarios run at once (each already uses every core)")
      ->capture_default_str();
  sweep->add_option("--keep", sweep_keep, "What stays of each run directory: none, metrics (metrics.json and "
                                          "scenario.resolved.yaml) or all")
      ->capture_default_str();
  sweep->add_flag("--timing", sweep_timing, "Also the timing_s.* columns (rows then differ from run to run)");
  sweep->add_flag("--quiet,-q", sweep_quiet, "No progress lines on stderr");
  sweep->add_flag("--resume", sweep_resume, "Keep the runs DIR's journal records as finished (a sweep killed "
                                            "before it ended); run only the rest");

  std::string basin_file, basin_out, basin_shard, basin_t, basin_r;
  BasinOptions basin_opt;
  bool basin_merge = false, basin_quiet = false;
  auto* basin = app.add_subcommand("basin", "The convergence basin of every matching method of a scenario on its "
                                            "first pair: DIR/basin.csv, DIR/basin_METHOD.png, "
                                            "DIR/basin_boundary.png (see docs/basin.md).");
  basin->add_option("scenario", basin_file, "Scenario YAML with map and matching sections")->required();
  basin->add_option("--out,-o", basin_out, "Basin directory to write (created if missing)")->required();
  auto* basin_t_opt = basin->add_option("--translation-m", basin_t, "Initial translation magnitudes, metres, comma-separated "
                                                "(default 0,0.5,1,1.5,2,2.5,3)");
  auto* basin_r_opt = basin->add_option("--rotation-deg", basin_r, "Initial rotation magnitudes, degrees, comma-separated "
                                               "(default 0,5,10,15,20,25,30)");
  basin->add_option("--trials", basin_opt.grid.trials, "Seeded trials per cell")->capture_default_str();
  std::string basin_axis = "random";
  basin->add_option("--rotation-axis", basin_axis, "random (uniform on the sphere) or vertical (yaw errors only)")
      ->capture_default_str();
  auto* basin_shard_opt = basin->add_option("--shard", basin_shard,
                                            "Run only shard K of N (1-based): the draws u with u mod N = K-1, into "
                                            "DIR/basin.shard-K-of-N.csv");
  basin->add_flag("--merge", basin_merge, "Merge DIR/basin.shard-*-of-N.csv into DIR/basin.csv and draw the "
                                          "figures; runs nothing (give the same grid options)");
  basin->add_option("--jobs,-j", basin_opt.jobs, "Draws registered at once (each already uses every core)")
      ->capture_default_str();
  basin->add_flag("--timing", basin_opt.timing, "Fill the time_s column (rows then differ from run to run)");
  basin->add_flag("--quiet,-q", basin_quiet, "No progress lines on stderr");
  basin->add_flag("--resume", basin_opt.resume, "Keep the draws DIR's journal records as finished (a basin "
                                                "killed before it ended); register only the rest");

  std::string report_dir, report_out;
  std::string make_dem_out;
  std::uint64_t make_dem_seed = 1;
  auto* make_dem = app.add_subcommand("make-dem", "Write the sample DEM (a HiRISE-like 1 m Mars DTM of the documented "
                                                  "procedural model, docs/terrains.md) as a GeoTIFF.");
  make_dem->add_option("--out,-o", make_dem_out, "GeoTIFF to write (scenarios/dem/sample_dtm.tif is seed 1)")->required();
  make_dem->add_option("--seed", make_dem_seed, "Seed of the fBm and the craters")->capture_default_str();

  auto* report = app.add_subcommand("report", "Write one self-contained HTML report of a run, sweep or basin directory: "
                                              "the scenario, every picture embedded, the metrics as tables, the goals, "
                                              "a sweep's plots against its axes (see docs/report.md).");
  report->add_option("dir", report_dir, "Run, sweep or basin directory (as `ambler run`, `sweep`, `basin` write it)")
      ->required();
  report->add_option("--out,-o", report_out, "HTML file to write (default DIR/report.html)");

  auto* bench = app.add_subcommand("bench", "Measure speed; prints a table of medians.");
  bench->require_subcommand(1);
  // A bench subcommand with the options every benchmark has: --json FILE and --reps N.
  const auto benchCommand = [&](const char* name, const char* what, std::string& json, BenchOptions& opt) {
    CLI::App* b = bench->add_subcommand(name, what);
    b->add_option("--json", json, "Also write the figures to this JSON file");
    b->add_option("--reps", opt.repetitions, "Repetitions per measurement (median reported)")->check(CLI::Range(1, 1000));
    b->add_flag_callback("--quiet,-q", [&opt] { opt.progress = false; }, "No progress on stderr");
    return b;
  };
  BenchOptions bench_opt;
  std::string bench_json;
  auto* bench_scan = benchCommand("scan", "ERIM emulator vs mj_ray (1 thread, 64x256) and vs a "
                                          "bare Embree packet cast (all cores, 1024x4096).", bench_json, bench_opt);

  std::string bench_map_json;
  BenchOptions bench_map_opt;
  auto* bench_map = benchCommand("map", "Locus map ns/cell at 2, 5, 10, 20 cm (1 thread and all "
                                        "cores) vs the Cartesian baseline.", bench_map_json, bench_map_opt);

  std::string bench_match_json, bench_match_scenario = "scenarios/demo.yaml";
  BenchOptions bench_match_opt;
  auto* bench_match = benchCommand("match", "Every matching method per pair, ms and iterations (1 thread and "
                                            "all cores), on a scenario's first pair.", bench_match_json, bench_match_opt);
  bench_match->add_option("--scenario", bench_match_scenario, "A scenario with map and matching sections")
      ->capture_default_str();

  std::string bench_footfall_json;
  BenchOptions bench_footfall_opt;
  auto* bench_footfall = benchCommand("footfall", "Footfall evaluation, all methods dense over 10 000 candidates "
                                                  "at 10 and 2 cm (1 thread and all cores).", bench_footfall_json,
                                      bench_footfall_opt);

  auto* experiment = app.add_subcommand("experiment", "Run one of the paper's experiments as sweeps; prints its "
                                                      "markdown tables (see docs/experiments/).");
  experiment->require_subcommand(1);
  ExperimentOptions exp_opt;
  std::string exp_out, exp_sweeps = exp_opt.sweeps.string();
  bool exp_quiet = false;
  auto* locus_vs_cartesian = experiment->add_subcommand(
      "locus-vs-cartesian", "Locus map vs Cartesian baseline across tilt, noise and map resolution (§6): "
                            "DIR/table.md, DIR/*.png and each sweep's DIR/<sweep>/results.csv.");
  locus_vs_cartesian->add_option("--out,-o", exp_out, "Experiment directory to write (created if missing)")
      ->required();
  locus_vs_cartesian->add_flag("--quick", exp_opt.quick,
                               "A reduced run: the first and last value of every axis, the first seed");
  locus_vs_cartesian->add_option("--sweeps", exp_sweeps, "Directory of tilt_noise.yaml and resolution.yaml")
      ->capture_default_str();
  locus_vs_cartesian->add_option("--jobs,-j", exp_opt.jobs, "Scenarios run at once (each already uses every core)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  locus_vs_cartesian->add_flag("--quiet,-q", exp_quiet, "No progress lines on stderr");

  ExperimentOptions match_opt;
  std::string match_out, match_sweeps = match_opt.sweeps.string();
  bool match_quiet = false, match_report = false;
  auto* matching = experiment->add_subcommand(
      "matching", "Every matching method against the rover's initial error, translation x rotation x seed (§6, "
                  "fig. 5): DIR/table.md, DIR/basin.png and the sweep's DIR/basin/results.csv.");
  matching->add_option("--out,-o", match_out, "Experiment directory to write (created if missing)")->required();
  matching->add_flag("--quick", match_opt.quick, "A reduced run: the first and last value of every axis, the first seed");
  matching->add_option("--sweeps", match_sweeps, "Directory of matching_basin.yaml")->capture_default_str();
  matching->add_option("--jobs,-j", match_opt.jobs, "Scenarios run at once (each already uses every core)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  matching->add_flag("--report", match_report,
                     "Run nothing: report DIR/basin/results.csv as it is (e.g. merged from shards)");
  matching->add_flag("--quiet,-q", match_quiet, "No progress lines on stderr");

  ExperimentOptions acc_opt;
  std::string acc_out, acc_sweeps = acc_opt.sweeps.string();
  bool acc_quiet = false, acc_report = false;
  auto* acceptance = experiment->add_subcommand(
      "acceptance", "The rover's verdict on every matching method against the truth, three terrains x 100 seeds: "
                    "DIR/table.md and each terrain's DIR/TERRAIN/results.csv.");
  acceptance->add_option("--out,-o", acc_out, "Experiment directory to write (created if missing)")->required();
  acceptance->add_flag("--quick", acc_opt.quick, "A reduced run: the first seed of each terrain");
  acceptance->add_option("--sweeps", acc_sweeps, "Directory of acceptance_{mars,fractal,dem}_seeds.yaml")
      ->capture_default_str();
  acceptance->add_option("--jobs,-j", acc_opt.jobs, "Scenarios run at once (each already uses every core)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  acceptance->add_flag("--report", acc_report, "Run nothing: report DIR/TERRAIN/results.csv as they are");
  acceptance->add_flag("--quiet,-q", acc_quiet, "No progress lines on stderr");

  DescentOptions desc_opt;
  std::string desc_out, desc_sweeps = desc_opt.experiment.sweeps.string();
  bool desc_quiet = false, desc_report = false;
  auto* descent = experiment->add_subcommand(
      "descent", "The iconic descent's departures from the paper's, added one at a time and removed one at a time, "
                 "on the acceptance pairs: DIR/table.md and DIR/results.csv.");
  descent->add_option("--out,-o", desc_out, "Experiment directory to write (created if missing)")->required();
  auto* desc_quick =
      descent->add_flag("--quick", desc_opt.experiment.quick, "A reduced run: the first seed of each terrain");
  auto* desc_seeds =
      descent->add_option("--seeds", desc_opt.seeds, "The first N seeds of each terrain")->capture_default_str();
  desc_quick->excludes(desc_seeds);
  descent->add_option("--sweeps", desc_sweeps, "Directory of acceptance_{mars,fractal,dem}_seeds.yaml")
      ->capture_default_str();
  auto* desc_timing = descent->add_flag("--timing", desc_opt.timing,
                                        "Fill time_s and the time column (they then differ from run to run)");
  auto* desc_report_flag = descent->add_flag("--report", desc_report, "Run nothing: report DIR/results.csv as it is");
  desc_report_flag->excludes(desc_quick)->excludes(desc_seeds)->excludes(desc_timing);
  descent->add_flag("--quiet,-q", desc_quiet, "No progress lines on stderr");

  // CLI11 would say "A subcommand is required" for a mistyped command.
  if (argc > 1 && argv[1][0] != '-') {
    std::string names;
    bool known = false;
    for (const CLI::App* sub : app.get_subcommands([](const CLI::App*) { return true; })) {
      names += (names.empty() ? "" : ", ") + sub->get_name();
      known = known || sub->get_name() == argv[1];
    }
    if (!known) {
      std::fprintf(stderr, "ambler: error: %s: unknown command (expected one of %s; see --help)\n", argv[1], names.c_str());
      return 1;
    }
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help
    // One line, as every other refusal (CLI11's own adds "Run with --help ..." on a second line).
    std::fprintf(stderr, "ambler: error: %s (see --help)\n", e.what());
    return e.get_exit_code();
  }

  try {
    if (*run) {
      checkOutDir(out_dir);
      const Scenario sc = loadScenario(scenario_file);
      runScenario(sc, RunOptions{out_dir, !quiet});
    } else if (*sweep) {
      checkOutDir(sweep_out);
      SweepOptions opt{sweep_out, std::nullopt, sweep_jobs, parseKeep(sweep_keep), sweep_timing, !sweep_quiet,
                       sweep_resume};
      if (shard_opt->count()) opt.shard = parseShard(sweep_shard);
      if (opt.jobs < 1) throw SweepError("--jobs: expected an integer >= 1, got " + std::to_string(opt.jobs));
      if (sweep_merge && (opt.shard || sweep_timing || sweep_resume)) {
        throw SweepError(std::string("--merge: merges the shards' files; ") +
                         (opt.shard ? "--shard" : sweep_timing ? "--timing" : "--resume") + " does not apply");
      }
      const Sweep sw = loadSweep(sweep_file);
      if (sweep_merge)
        mergeSweep(sw, sweep_out, !sweep_quiet);
      else
        runSweep(sw, opt);
    } else if (*basin) {
      checkOutDir(basin_out);
      basin_opt.out = basin_out;
      basin_opt.progress = !basin_quiet;
      if (basin_t_opt->count()) basin_opt.grid.translation_m = parseBasinAxis(basin_t, "--translation-m", 100.0);
      if (basin_r_opt->count()) basin_opt.grid.rotation_deg = parseBasinAxis(basin_r, "--rotation-deg", 180.0);
      if (basin_shard_opt->count()) basin_opt.shard = parseShard(basin_shard);
      if (basin_axis != "random" && basin_axis != "vertical")
        throw BasinError("--rotation-axis: expected random or vertical, got " + yamlQuoted(basin_axis));
      basin_opt.grid.vertical_axis = basin_axis == "vertical";
      if (basin_merge && (basin_opt.shard || basin_opt.timing || basin_opt.resume))
        throw BasinError(std::string("--merge: merges the shards' files; ") +
                         (basin_opt.shard ? "--shard" : basin_opt.timing ? "--timing" : "--resume") +
                         " does not apply");
      const Scenario sc = loadScenario(basin_file);
      if (basin_merge)
        mergeBasin(sc, basin_opt);
      else
        runBasin(sc, basin_opt);
    } else if (*make_dem) {
      writeSampleDem(make_dem_out, make_dem_seed);
      std::fprintf(stderr, "ambler: wrote %s\n", make_dem_out.c_str());
    } else if (*report) {
      std::filesystem::path out = report_out.empty() ? std::filesystem::path(report_dir) / "report.html"
                                                     : std::filesystem::path(report_out);
      if (out.has_parent_path()) checkOutDir(out.parent_path());
      writeReport(report_dir, out);
    } else if (*locus_vs_cartesian) {
      checkOutDir(exp_out);
      exp_opt.out = exp_out;
      exp_opt.sweeps = exp_sweeps;
      exp_opt.progress = !exp_quiet;
      std::fputs(runLocusVsCartesian(exp_opt).c_str(), stdout);
    } else if (*matching) {
      checkOutDir(match_out);
      match_opt.out = match_out;
      match_opt.sweeps = match_sweeps;
      match_opt.progress = !match_quiet;
      std::fputs((match_report ? reportMatching(match_opt) : runMatching(match_opt)).c_str(), stdout);
    } else if (*acceptance) {
      checkOutDir(acc_out);
      acc_opt.out = acc_out;
      acc_opt.sweeps = acc_sweeps;
      acc_opt.progress = !acc_quiet;
      std::fputs((acc_report ? reportAcceptance(acc_opt) : runAcceptance(acc_opt)).c_str(), stdout);
    } else if (*descent) {
      checkOutDir(desc_out);
      desc_opt.experiment.out = desc_out;
      desc_opt.experiment.sweeps = desc_sweeps;
      desc_opt.experiment.progress = !desc_quiet;
      std::fputs((desc_report ? reportDescent(desc_opt) : runDescent(desc_opt)).c_str(), stdout);
    } else if (*bench_scan) {
      bench_opt.json = bench_json;
      benchScan(bench_opt);
    } else if (*bench_map) {
      bench_map_opt.json = bench_map_json;
      benchMap(bench_map_opt);
    } else if (*bench_footfall) {
      bench_footfall_opt.json = bench_footfall_json;
      benchFootfall(bench_footfall_opt);
    } else if (*bench_match) {
      bench_match_opt.json = bench_match_json;
      benchMatch(loadScenario(bench_match_scenario), bench_match_opt);
    }
  } catch (const std::filesystem::filesystem_error& e) {
    // The library's words ("filesystem error: cannot create directories: Not a directory [x]")
    // as the program's: "x: cannot create directories: Not a directory".
    std::string what = e.what();
    const std::string prefix = "filesystem error: ";
    std::string suffix = " [" + e.path1().string() + "]";
    if (!e.path2().empty()) suffix += " [" + e.path2().string() + "]";
    if (what.starts_with(prefix)) what.erase(0, prefix.size());
    if (what.ends_with(suffix)) what.erase(what.size() - suffix.size());
    std::fprintf(stderr, "ambler: error: %s%s\n", e.path1().empty() ? "" : (e.path1().string() + ": ").c_str(),
                 what.c_str());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ambler: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
