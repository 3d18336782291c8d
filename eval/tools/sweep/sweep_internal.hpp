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

// Defined in sweep.cpp. The whole file; throws SweepError "<who>: <cause>" when it cannot be read.
std::string readText(const std::filesystem::path& file, const std::string& who);

// Defined in sweep_results.cpp. The run index and the axis cells of run k: the first columns of its row.
std::vector<std::string> axisCells(const Sweep& sweep, std::size_t k);

}  // namespace ambler::eval::sweep_detail
