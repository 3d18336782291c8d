#pragma once
// Internal to eval/sweep*.cpp: the helpers that reading a sweep (sweep.cpp), running it
// (sweep_run.cpp) and writing or merging results.csv (sweep_results.cpp) share. Not part of the eval
// library's interface.
#include <cstddef>
#include <filesystem>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "eval/tools/sweep/sweep.hpp"

namespace ambler::eval::sweep_detail {

// Defined in sweep.cpp.
std::vector<std::string> split(std::string_view text, char sep);
bool allDigits(std::string_view s);
// The whole file; throws SweepError naming `who` when it cannot be opened or read.
std::string readText(const std::filesystem::path& file, const std::string& who);

// Defined in sweep_run.cpp.
// A number as a results.csv cell: the shortest text that reads back to the same double; "" for a
// non-finite one (null in metrics.json).
std::string numberText(double v);

// Defined in sweep_results.cpp.
// One results.csv line: the cells CSV-quoted where needed, comma-separated, "\n"-terminated.
std::string csvLine(const std::vector<std::string>& cells);
// The run index and the axis cells of run k: the first columns of its row.
std::vector<std::string> axisCells(const Sweep& sweep, std::size_t k);
// <stem>.shard-K-of-N<ext> (stem "results" for a sweep, "basin" for a basin; ext ".csv" for the
// shard's CSV, ".journal" for its resume journal)
std::string shardName(const Shard& s, const std::string& stem = "results", const std::string& ext = ".csv");
// The <stem>.shard-K-of-N.csv files in `out`, ordered by K: all N of one split. Throws SweepError
// naming the directory or the file when there are none, a split is mixed or a shard is missing.
std::vector<std::pair<Shard, std::filesystem::path>> shardFiles(const std::filesystem::path& out,
                                                                const std::string& stem);

}  // namespace ambler::eval::sweep_detail
