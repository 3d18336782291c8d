#pragma once
// `ambler report DIR`: one self-contained HTML file a person reads (docs/report.md), of a run
// directory (what `ambler run` writes: the scenario, the goals the docs state, every picture
// embedded as a data URI, metrics.json as tables, in sections that appear only for the stages that
// ran), a sweep directory (the sweep, gnuplot plots of each metric against each axis, the worst
// runs) or a basin directory (the scenario and grid, the success rates, the heatmaps). No network,
// no JavaScript, no external URL; the same directory gives the same bytes.
#include <filesystem>
#include <string>
#include <string_view>

namespace ambler::eval {

enum class ReportKind { Run, Sweep, Basin };

// What DIR is: a run (metrics.json), a sweep (results.csv) or a basin (basin.csv). Throws
// std::runtime_error "<dir>: not a run, sweep or basin directory (no metrics.json, results.csv or
// basin.csv)" otherwise.
ReportKind reportKind(const std::filesystem::path& dir);

// Writes the report of `dir`, whatever its kind, to `out_html` (atomically) and returns it. Links
// to a sweep's run directories are relative to out_html's directory. Throws as reportKind does,
// and with one line naming the file when a file the report reads is malformed; nothing is written
// then.
std::filesystem::path writeReport(const std::filesystem::path& dir, const std::filesystem::path& out_html);

// The HTML of a sweep's report; links to run directories relative to `html_dir`.
std::string sweepReportHtml(const std::filesystem::path& sweep_dir, const std::filesystem::path& html_dir);

// The HTML of a basin's report.
std::string basinReportHtml(const std::filesystem::path& basin_dir);

// Writes the report of the run directory `run_dir` to `out_html` (atomically, eval::writeText)
// and returns `out_html`. Throws std::runtime_error "<run_dir>: not a run directory (no
// metrics.json)" when run_dir has no metrics.json (nothing is written then), and a one-line
// message naming the file when metrics.json is not JSON.
std::filesystem::path writeRunReport(const std::filesystem::path& run_dir, const std::filesystem::path& out_html);

// The HTML of the report, as writeRunReport writes it (for tests).
std::string runReportHtml(const std::filesystem::path& run_dir);

// Base64 of RFC 4648 §4 (the standard alphabet, '=' padding, no line breaks).
std::string base64Encode(std::string_view bytes);

// Text made safe inside HTML elements and attribute values: & < > " ' escaped.
std::string htmlEscape(std::string_view text);

}  // namespace ambler::eval
