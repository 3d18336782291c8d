// results.csv: its cells and the names of its shard files, and merging the shards back into the
// rows one process would have written (rows by run index, checked against the sweep file).
// docs/sweeps.md is the schema.
#include "eval/tools/sweep/sweep.hpp"

#include <algorithm>
#include <cstdio>
#include <optional>
#include <string>
#include <utility>

#include "eval/scenario/io.hpp"
#include "base/text.hpp"
#include "eval/scenario/message_text.hpp"
#include "eval/tools/sweep/sweep_internal.hpp"

namespace ambler::eval {
namespace {

namespace fs = std::filesystem;
using namespace sweep_detail;
using base::allDigits;

// ---- results ----------------------------------------------------------------------------------

// RFC 4180 records; nullopt when a quote is left open or stray.
std::optional<std::vector<std::vector<std::string>>> parseCsv(const std::string& text) {
  std::vector<std::vector<std::string>> records;
  std::vector<std::string> record;
  std::string cell;
  bool quoted = false, was_quoted = false;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (quoted) {
      if (c != '"') {
        cell += c;
      } else if (i + 1 < text.size() && text[i + 1] == '"') {
        cell += '"';
        ++i;
      } else {
        quoted = false;
      }
    } else if (c == '"') {
      if (!cell.empty() || was_quoted) return std::nullopt;
      quoted = was_quoted = true;
    } else if (c == ',') {
      record.push_back(std::move(cell));
      cell.clear();
      was_quoted = false;
    } else if (c == '\n' || c == '\r') {
      if (c == '\r' && i + 1 < text.size() && text[i + 1] == '\n') ++i;
      record.push_back(std::move(cell));
      records.push_back(std::move(record));
      record.clear();
      cell.clear();
      was_quoted = false;
    } else {
      if (was_quoted) return std::nullopt;
      cell += c;
    }
  }
  if (quoted) return std::nullopt;
  if (!cell.empty() || !record.empty() || was_quoted) {
    record.push_back(std::move(cell));
    records.push_back(std::move(record));
  }
  return records;
}

}  // namespace

namespace sweep_detail {

std::vector<std::string> axisCells(const Sweep& sweep, std::size_t k) {
  std::vector<std::string> cells{std::to_string(k)};
  const auto combination = sweep.combination(k);
  for (std::size_t a = 0; a < sweep.axes.size(); ++a) cells.push_back(sweep.axes[a].cells[combination[a]]);
  return cells;
}

}  // namespace sweep_detail

std::optional<std::vector<std::vector<std::string>>> parseResultsCsv(const std::string& text) {
  return parseCsv(text);
}

fs::path mergeSweep(const Sweep& sweep, const fs::path& out, bool progress) {
  const std::string where = out.string();
  // The shards' files; what is wrong with them is the sweep's error, as every other merge refusal.
  const auto files = [&] {
    try {
      return shardFiles(out, "results");
    } catch (const ShardError& e) {
      throw SweepError(e.what());
    }
  }();
  const int n = files.front().first.count;

  const std::size_t total = sweep.runs.size();
  std::vector<std::string> axes_header{"run"};
  for (const auto& axis : sweep.axes) axes_header.push_back(axis.key);
  std::vector<std::string> header;
  fs::path header_file;
  std::vector<std::optional<std::vector<std::string>>> rows(total);
  std::vector<fs::path> row_file(total);
  for (const auto& [shard, path] : files) {
    const std::string name = path.string();
    const auto records = parseCsv(readText(path, name));
    if (!records) throw SweepError(name + ": not a CSV file (an open or stray quote)");
    if (records->empty()) throw SweepError(name + ": empty, expected a header row");
    const auto& head = records->front();
    if (header_file.empty()) {
      if (head.size() < axes_header.size() ||
          !std::equal(axes_header.begin(), axes_header.end(), head.begin())) {
        throw SweepError(name + ": header does not start with run and the sweep's axes (" +
                         csvText(axes_header) + ")");
      }
      header = head;
      header_file = path;
    } else if (head != header) {
      throw SweepError(name + ": header differs from " + header_file.string() + "'s");
    }
    for (std::size_t r = 1; r < records->size(); ++r) {
      const auto& row = (*records)[r];
      const std::string at = name + ": row " + std::to_string(r + 1) + ": ";
      if (row.size() != header.size()) {
        throw SweepError(at + "expected " + std::to_string(header.size()) + " cells, got " +
                         std::to_string(row.size()));
      }
      std::size_t k = 0;
      if (!allDigits(row[0]) || row[0].size() > 9 || (k = std::stoul(row[0])) >= total) {
        throw SweepError(at + "expected a run index in [0, " + std::to_string(total - 1) + "], got " +
                         yamlQuoted(row[0]));
      }
      if (k % std::size_t(n) != std::size_t(shard.index - 1)) {
        throw SweepError(at + "run " + std::to_string(k) + " belongs to shard " + std::to_string(k % n + 1) +
                         " of " + std::to_string(n));
      }
      if (rows[k])
        throw SweepError(at + "run " + std::to_string(k) + " is duplicated (also in " + row_file[k].string() +
                         ")");
      const auto expected = axisCells(sweep, k);
      if (!std::equal(expected.begin(), expected.end(), row.begin())) {
        // Escaped: a quoted cell may hold a line break (docs/fuzzing.md).
        throw SweepError(at + "run " + std::to_string(k) + ": cells " +
                         escapedLine(csvText({row.begin(), row.begin() + std::ptrdiff_t(expected.size())})) +
                         " differ from the sweep file's " + escapedLine(csvText(expected)) +
                         " (was it edited after the shards ran?)");
      }
      rows[k] = row;
      row_file[k] = path;
    }
  }
  for (std::size_t k = 0; k < total; ++k) {
    if (!rows[k]) {
      throw SweepError(where + ": run " + std::to_string(k) + " is missing (expected in " +
                       shardName(Shard{int(k % std::size_t(n)) + 1, n}, "results") + ")");
    }
  }
  std::string text = csvLine(header);
  for (const auto& row : rows) text += csvLine(*row);
  const fs::path csv = out / "results.csv";
  writeText(csv, text);
  if (progress) {
    std::fprintf(stderr, "ambler: merged %d shards into %s (%zu rows)\n", n, csv.string().c_str(), total);
  }
  return csv;
}

}  // namespace ambler::eval
