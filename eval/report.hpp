#pragma once
// `ambler report DIR`: one self-contained HTML file a person reads (docs/report.md). This slice
// reports run directories (what `ambler run` writes): the scenario, every picture of the run
// embedded as a data URI, and metrics.json as tables, in sections that appear only for the stages
// that ran. No network, no JavaScript, no external URL; the same run directory gives the same bytes.
#include <filesystem>
#include <string>
#include <string_view>

namespace ambler::eval {

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
