#pragma once
// The CLI's commands (docs/architecture.md, "Commands"). Each command's folder adds its own
// subcommand to the app, with the options it reads and the action that runs when the command line
// chose it; main.cpp only adds them in order and calls dispatch.
#include <functional>
#include <vector>

namespace CLI {
class App;
}

namespace ambler::eval {

struct Command {
  const CLI::App* cli = nullptr;  // the (sub)command; chosen when it was parsed
  std::function<void()> run;      // what it does; a failure throws, its message is the one line printed
};
using Commands = std::vector<Command>;

// Parses the command line, runs the command it chose and returns the exit code. Every refusal is
// one line on stderr, "ambler: error: <what>": an unknown command (with the known ones), a parse
// error, a file-system error (path first) or any exception the command throws.
int dispatch(CLI::App& app, const Commands& commands, int argc, char** argv);

// Each command, defined in its own folder.
void addRunCommand(CLI::App& app, Commands& out);         // eval/run/command.cpp
void addSweepCommand(CLI::App& app, Commands& out);       // eval/tools/sweep/command.cpp
void addBasinCommand(CLI::App& app, Commands& out);       // eval/tools/basin/command.cpp
void addMakeDemCommand(CLI::App& app, Commands& out);     // eval/tools/make_dem/command.cpp
void addReportCommand(CLI::App& app, Commands& out);      // eval/tools/report/command.cpp
void addBenchCommands(CLI::App& app, Commands& out);      // eval/tools/bench/command.cpp
void addExperimentCommands(CLI::App& app, Commands& out); // eval/tools/experiment/command.cpp

}  // namespace ambler::eval
