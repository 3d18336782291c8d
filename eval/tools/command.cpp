// The dispatcher of the CLI (eval/tools/command.hpp).
#include "eval/tools/command.hpp"

#include <CLI/CLI.hpp>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <string>

namespace ambler::eval {

namespace {

// The library's words ("filesystem error: cannot create directories: Not a directory [x]") as the
// program's: "x: cannot create directories: Not a directory".
std::string fileSystemMessage(const std::filesystem::filesystem_error& e) {
  std::string what = e.what();
  const std::string prefix = "filesystem error: ";
  std::string suffix = " [" + e.path1().string() + "]";
  if (!e.path2().empty()) suffix += " [" + e.path2().string() + "]";
  if (what.starts_with(prefix)) what.erase(0, prefix.size());
  if (what.ends_with(suffix)) what.erase(what.size() - suffix.size());
  return (e.path1().empty() ? "" : e.path1().string() + ": ") + what;
}

}  // namespace

int dispatch(CLI::App& app, const Commands& commands, int argc, char** argv) {
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
    for (const Command& c : commands)
      if (c.cli->parsed()) {
        c.run();
        break;
      }
  } catch (const std::filesystem::filesystem_error& e) {
    std::fprintf(stderr, "ambler: error: %s\n", fileSystemMessage(e).c_str());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ambler: error: %s\n", e.what());
    return 1;
  }
  return 0;
}

}  // namespace ambler::eval
