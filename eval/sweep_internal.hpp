#pragma once
// Internal to eval/sweep*.cpp: the helpers that reading a sweep (sweep.cpp), running it
// (sweep_run.cpp) and writing or merging results.csv (sweep_results.cpp) share. Not part of the eval
// library's interface.
#include <cstddef>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "eval/sweep.hpp"

namespace ambler::eval::sweep_detail {

// Defined in sweep.cpp.
std::vector<std::string> split(std::string_view text, char sep);
bool allDigits(std::string_view s);
// The whole file; throws SweepError naming `who` when it cannot be opened or read.
std::string readText(const std::filesystem::path& file, const std::string& who);

// Defined in sweep_results.cpp.
// One results.csv line: the cells CSV-quoted where needed, comma-separated, "\n"-terminated.
std::string csvLine(const std::vector<std::string>& cells);
// The run index and the axis cells of run k: the first columns of its row.
std::vector<std::string> axisCells(const Sweep& sweep, std::size_t k);
// results.shard-K-of-N.csv
std::string shardName(const Shard& s);

}  // namespace ambler::eval::sweep_detail
