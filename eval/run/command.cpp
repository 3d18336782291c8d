// `ambler run` (docs/scenario.md): one scenario end to end into its run directory.
#include <CLI/CLI.hpp>
#include <memory>
#include <string>

#include "eval/run/runner.hpp"
#include "eval/scenario/io.hpp"
#include "eval/scenario/scenario.hpp"
#include "eval/tools/command.hpp"

namespace ambler::eval {

void addRunCommand(CLI::App& app, Commands& out) {
  struct Options {
    std::string scenario, out;
    bool quiet = false;
  };
  auto o = std::make_shared<Options>();
  CLI::App* run = app.add_subcommand("run", "Run one scenario end to end and write its run directory "
                                            "(metrics.json, world/, scans/, pictures).");
  run->add_option("scenario", o->scenario, "Scenario YAML (see docs/scenario.md)")->required();
  run->add_option("--out,-o", o->out, "Run directory to write (created if missing)")->required();
  run->add_flag("--quiet,-q", o->quiet, "No progress lines on stderr");
  out.push_back({run, [o] {
                   checkOutDir(o->out);
                   const Scenario sc = loadScenario(o->scenario);
                   runScenario(sc, RunOptions{o->out, !o->quiet});
                 }});
}

}  // namespace ambler::eval
