// Running a sweep, or one shard of it: every run an ordinary `ambler run` in its own directory,
// its metrics.json flattened into one row. Rows are assembled in run order whatever the number of
// jobs, so results.csv is byte-identical however it was produced (one process, several jobs, or
// shards merged). docs/sweeps.md is the schema.
#include "eval/tools/sweep/sweep.hpp"

#include <algorithm>
#include <string_view>
#include <atomic>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <thread>
#include <unordered_map>
#include <utility>

#include "base/digest.hpp"
#include "eval/scenario/io.hpp"
#include "eval/tools/jobs.hpp"
#include "eval/tools/journal.hpp"
#include "eval/tools/progress.hpp"
#include "eval/run/runner.hpp"
#include "eval/tools/sweep/sweep_internal.hpp"

namespace ambler::eval {
namespace {

namespace fs = std::filesystem;
using namespace sweep_detail;

using Row = std::vector<std::pair<std::string, std::string>>;  // column, cell text

// The scalar leaves of metrics.json in document order, arrays by index: map.0.rms_error_m. The
// measured times (timing_s, time_s of each registration and a traverse's seconds_per_stop) only
// with `timing`: they are the figures that are not reproducible.
void flatten(const nlohmann::ordered_json& j, const std::string& path, bool timing, Row& out) {
  // A registration's reject_reasons (a list of texts, empty when accepted) is one cell, "; "
  // between them, so that every run has the same columns.
  const std::string_view reasons = ".reject_reasons";
  if (j.is_array() && path.size() >= reasons.size() && path.compare(path.size() - reasons.size(), reasons.size(), reasons) == 0) {
    std::string text;
    for (const auto& e : j) text += (text.empty() ? "" : "; ") + e.get<std::string>();
    out.emplace_back(path, std::move(text));
    return;
  }
  if (j.is_object() || j.is_array()) {
    std::size_t i = 0;
    for (auto it = j.begin(); it != j.end(); ++it, ++i) {
      const std::string key = j.is_object() ? it.key() : std::to_string(i);
      const bool measured_time = (path.empty() && key == "timing_s") ||
                                 (key == "time_s" && path.rfind("registration.", 0) == 0) ||
                                 (path == "traverse" && key == "seconds_per_stop");
      if (!timing && measured_time) continue;
      flatten(*it, path.empty() ? key : path + "." + key, timing, out);
    }
    return;
  }
  std::string text;
  if (j.is_number_float()) {
    text = csvNumber(j.get<double>());
  } else if (j.is_number_unsigned()) {
    text = std::to_string(j.get<std::uint64_t>());
  } else if (j.is_number_integer()) {
    text = std::to_string(j.get<std::int64_t>());
  } else if (j.is_boolean()) {
    text = j.get<bool>() ? "true" : "false";
  } else if (j.is_string()) {
    text = j.get<std::string>();
  }
  out.emplace_back(path, std::move(text));
}

// Metric columns in the order they first appear in run order, a column new in a later run placed
// after its predecessor in that run, so the columns read as metrics.json does.
std::vector<std::string> metricColumns(const Sweep& sweep, const std::vector<Row>& rows) {
  if (!sweep.metrics.empty()) return sweep.metrics;
  std::vector<std::string> columns;
  for (const auto& row : rows) {
    std::size_t at = 0;
    for (const auto& [name, cell] : row) {
      const auto it = std::find(columns.begin(), columns.end(), name);
      if (it == columns.end()) {
        columns.insert(columns.begin() + std::ptrdiff_t(at), name);
        ++at;
      } else {
        at = std::size_t(it - columns.begin()) + 1;
      }
    }
  }
  // An axis that is also a metric (seed) is already a column.
  std::erase_if(columns, [&](const std::string& c) {
    return c == "run" ||
           std::any_of(sweep.axes.begin(), sweep.axes.end(), [&](const SweepAxis& a) { return a.key == c; });
  });
  return columns;
}

// Keeps what `keep` asks for of a finished run directory.
void prune(const fs::path& dir, Keep keep) {
  if (keep == Keep::All) return;
  if (keep == Keep::None) {
    fs::remove_all(dir);
    return;
  }
  std::vector<fs::path> bulky;
  for (const auto& entry : fs::directory_iterator(dir)) {
    const auto name = entry.path().filename();
    if (name != "metrics.json" && name != "scenario.resolved.yaml") bulky.push_back(entry.path());
  }
  for (const auto& path : bulky) fs::remove_all(path);
}

std::string progressLine(const Sweep& sweep, std::size_t k, const nlohmann::ordered_json& metrics) {
  std::string line = "run " + std::to_string(k) + ":";
  const auto combination = sweep.combination(k);
  for (std::size_t a = 0; a < sweep.axes.size(); ++a) {
    line += " " + sweep.axes[a].key + "=" + sweep.axes[a].cells[combination[a]];
  }
  const auto first = [&](const char* section, const char* key) -> std::optional<double> {
    if (!metrics.contains(section) || metrics[section].empty()) return std::nullopt;
    const auto& v = metrics[section][0];
    if (!v.contains(key) || !v[key].is_number()) return std::nullopt;
    return v[key].get<double>();
  };
  char buf[64];
  if (const auto rms = first("map", "rms_error_m")) {
    std::snprintf(buf, sizeof buf, " rms=%.4g m", *rms);
    line += buf;
  } else if (const auto range = first("scan", "range_error_rms_m")) {
    std::snprintf(buf, sizeof buf, " range_rms=%.4g m", *range);
    line += buf;
  }
  if (const auto cartesian = first("map_cartesian", "rms_error_m")) {
    std::snprintf(buf, sizeof buf, " cartesian_rms=%.4g m", *cartesian);
    line += buf;
  }
  return line;
}

// A row as the journal's payload (one line of JSON: [[column, cell], ...]) and back.
std::string rowPayload(const Row& row) {
  nlohmann::json j = nlohmann::json::array();
  for (const auto& [name, cell] : row) j.push_back({name, cell});
  return j.dump();
}

Row rowFromPayload(const std::string& payload, const fs::path& journal, std::size_t k) {
  Row row;
  try {
    const auto j = nlohmann::json::parse(payload);
    if (!j.is_array()) throw std::invalid_argument("not a list");
    for (const auto& cell : j) {
      if (!cell.is_array() || cell.size() != 2 || !cell[0].is_string() || !cell[1].is_string())
        throw std::invalid_argument("not a [column, cell] pair");
      row.emplace_back(cell[0].get<std::string>(), cell[1].get<std::string>());
    }
  } catch (const std::exception& e) {
    throw JournalError(journal.string() + ": run " + std::to_string(k) + ": its recorded row is not readable (" +
                       e.what() + "); run without --resume to start over");
  }
  return row;
}

// DIR/sweep.resolved.yaml: the sweep as it was run (its name, base and axes as read), for `ambler report`
// (docs/report.md), which needs to tell the axis columns of results.csv from the metrics.
std::string sweepSpecText(const Sweep& sweep) {
  std::string y = "# The sweep this directory holds, as `ambler sweep` read it from " + sweep.file.filename().string() +
                  " (docs/sweeps.md)\nname: " + sweep.name + "\n";
  if (!sweep.description.empty()) y += "description: " + nlohmann::json(sweep.description).dump() + "\n";
  y += "base: " + nlohmann::json(sweep.base.generic_string()).dump() + "\naxes:\n";
  for (const auto& axis : sweep.axes) {
    y += "  " + axis.key + ": [";
    for (std::size_t i = 0; i < axis.values.size(); ++i) y += (i ? ", " : "") + axis.values[i];
    y += "]\n";
  }
  if (!sweep.metrics.empty()) {
    y += "metrics: [";
    for (std::size_t i = 0; i < sweep.metrics.size(); ++i) y += (i ? ", " : "") + sweep.metrics[i];
    y += "]\n";
  }
  return y;
}

// What the journal's records depend on: every run's resolved scenario, the metric columns, the
// measured times and the split. A journal with another identity is refused at --resume.
std::string journalIdentity(const Sweep& sweep, const SweepOptions& opt, const std::vector<std::size_t>& todo) {
  std::string text = "sweep\ntiming=" + std::string(opt.timing ? "1" : "0") + "\nshard=" +
                     (opt.shard ? std::to_string(opt.shard->index) + "/" + std::to_string(opt.shard->count) : "") +
                     "\nmetrics=";
  for (const auto& m : sweep.metrics) text += m + ",";
  text += "\ncustom=";  // the user's own methods, by name
  for (const CustomMethod& m : opt.custom) text += m.name + ",";
  for (const std::size_t k : todo) text += "\nrun " + std::to_string(k) + "\n" + resolvedYaml(sweep.runs[k]);
  return base::digest(text);
}

}  // namespace

Keep parseKeep(const std::string& text) {
  if (text == "none") return Keep::None;
  if (text == "metrics") return Keep::Metrics;
  if (text == "all") return Keep::All;
  throw SweepError("--keep: expected one of none, metrics, all, got " + yamlQuoted(text));
}

// GCC 12 warns falsely on "literal" + std::string here (-Wrestrict, PR 105651; inQuotes in
// scenario_reader.cpp dodges the same warning). It did not while this code shared one file with
// the rest of the sweep, where GCC inlined differently.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wrestrict"
fs::path runSweep(const Sweep& sweep, const SweepOptions& opt) {
  if (opt.jobs < 1) throw SweepError("--jobs: expected an integer >= 1, got " + std::to_string(opt.jobs));
  const std::size_t total = sweep.runs.size();
  if (opt.shard && std::size_t(opt.shard->count) > total) {
    throw SweepError("--shard: " + std::to_string(opt.shard->index) + "/" + std::to_string(opt.shard->count) +
                     ": the sweep has " + std::to_string(total) + " runs, so at most " +
                     std::to_string(total) + " shards");
  }
  const std::vector<std::size_t> todo = shardItems(total, opt.shard);
  const fs::path csv = opt.out / (opt.shard ? shardName(*opt.shard, "results") : "results.csv");
  const fs::path journal_file = opt.out / (opt.shard ? shardName(*opt.shard, "results", ".journal") : "results.journal");
  const std::size_t jobs = std::min<std::size_t>(std::size_t(opt.jobs), todo.size());

  const auto mode = Progress::modeFor(opt.progress);
  const auto say = [&](const std::string& line) {
    if (opt.progress) std::fprintf(stderr, "ambler: %s\n", line.c_str());
  };
  createOutDir(opt.out / "runs");

  // The runs an earlier attempt finished (with --resume), then the journal open for this one's.
  Journal journal = openJournal(journal_file, journalIdentity(sweep, opt, todo), total, opt.resume);
  std::vector<Row> rows(todo.size());
  const std::vector<std::size_t> pending =  // indices into todo
      unrecordedItems(journal.done, todo, journal_file, "runs", opt.shard ? "shard" : "sweep",
                      [&](std::size_t i, const std::string& payload) {
                        rows[i] = rowFromPayload(payload, journal_file, todo[i]);
                      });
  writeText(opt.out / "sweep.resolved.yaml", sweepSpecText(sweep));  // once the journal is accepted
  say("sweep " + sweep.name + ": " + std::to_string(todo.size()) + " of " + std::to_string(total) + " runs" +
      (opt.shard
           ? " (shard " + std::to_string(opt.shard->index) + " of " + std::to_string(opt.shard->count) + ")"
           : "") +
      ", " + std::to_string(jobs) + (jobs == 1 ? " job" : " jobs") + " -> " + opt.out.string());
  if (opt.resume)
    say("resuming: " + std::to_string(todo.size() - pending.size()) + " of " + std::to_string(todo.size()) +
        " runs recorded in " + journal_file.string() +
        (journal.done.torn_tail ? " (a run cut short while being recorded is run again)" : ""));

  Progress progress("sweep " + sweep.name, todo.size(), todo.size() - pending.size(), mode);
  const std::optional<JobFailure> error = runJobs(todo, pending, opt.jobs, *journal.writer, progress, [&](std::size_t i) {
    const std::size_t k = todo[i];
    const fs::path dir = opt.out / "runs" / std::to_string(k);
    fs::remove_all(dir);  // no files of an earlier sweep (or a killed attempt) left beside this run's
    const auto metrics = runScenario(sweep.runs[k], RunOptions{dir, false, opt.custom});
    flatten(metrics, "", opt.timing, rows[i]);
    prune(dir, opt.keep);
    return JobRecord{rowPayload(rows[i]), progressLine(sweep, k, metrics)};
  });
  progress.finish();
  if (error) {
    std::string values;
    const auto combination = sweep.combination(error->item);
    for (std::size_t a = 0; a < sweep.axes.size(); ++a) {
      values += (a ? ", " : "") + sweep.axes[a].key + " = " + sweep.axes[a].values[combination[a]];
    }
    throw SweepError(sweep.file.string() + ": run " + std::to_string(error->item) + " (" + values +
                     "): " + error->message);
  }
  if (opt.keep == Keep::None) {
    std::error_code ec;
    fs::remove(opt.out / "runs", ec);  // only if empty
  }

  const auto columns = metricColumns(sweep, rows);
  std::vector<std::string> header{"run"};
  for (const auto& axis : sweep.axes) header.push_back(axis.key);
  header.insert(header.end(), columns.begin(), columns.end());
  std::string text = csvLine(header);
  for (std::size_t i = 0; i < todo.size(); ++i) {
    std::unordered_map<std::string, std::string> cells(rows[i].begin(), rows[i].end());
    auto line = axisCells(sweep, todo[i]);
    for (const auto& column : columns) line.push_back(cells.count(column) ? cells[column] : "");
    text += csvLine(line);
  }
  writeText(csv, text);
  say("wrote " + csv.string() + " (" + std::to_string(todo.size()) + " rows, " +
      std::to_string(header.size()) + " columns)");
  return csv;
}
#pragma GCC diagnostic pop

}  // namespace ambler::eval
