// The ambler CLI: each command adds itself (eval/tools/command.hpp); this only lists them in the
// order --help shows and dispatches.
#include <CLI/CLI.hpp>

#include "eval/tools/command.hpp"

int main(int argc, char** argv) {
  using namespace ambler::eval;
  CLI::App app{"ambler: a simulation-and-evaluation testbed for planetary-rover terrain mapping\n"
               "(the Ambler's ERIM range sensor, locus-algorithm elevation maps, matching, footfalls)."};
  app.require_subcommand(1);
  Commands commands;
  addRunCommand(app, commands);
  addSweepCommand(app, commands);
  addBasinCommand(app, commands);
  addMakeDemCommand(app, commands);
  addReportCommand(app, commands);
  addBenchCommands(app, commands);
  addExperimentCommands(app, commands);
  return dispatch(app, commands, argc, argv);
}
