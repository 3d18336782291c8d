// `ambler report` (docs/report.md): one self-contained HTML page of a run, sweep or basin directory.
#include <CLI/CLI.hpp>
#include <filesystem>
#include <memory>
#include <string>

#include "eval/scenario/io.hpp"
#include "eval/tools/command.hpp"
#include "eval/tools/report/report.hpp"

namespace ambler::eval {

void addReportCommand(CLI::App& app, Commands& out) {
  struct Options {
    std::string dir, out;
  };
  auto o = std::make_shared<Options>();
  CLI::App* report = app.add_subcommand("report", "Write one self-contained HTML report of a run, sweep or basin "
                                                  "directory: the scenario, every picture embedded, the metrics as "
                                                  "tables, the goals, a sweep's plots against its axes (see "
                                                  "docs/report.md).");
  report->add_option("dir", o->dir, "Run, sweep or basin directory (as `ambler run`, `sweep`, `basin` write it)")
      ->required();
  report->add_option("--out,-o", o->out, "HTML file to write (default DIR/report.html)");
  out.push_back({report, [o] {
                   const std::filesystem::path file = o->out.empty() ? std::filesystem::path(o->dir) / "report.html"
                                                                     : std::filesystem::path(o->out);
                   if (file.has_parent_path()) checkOutDir(file.parent_path());
                   writeReport(o->dir, file);
                 }});
}

}  // namespace ambler::eval
