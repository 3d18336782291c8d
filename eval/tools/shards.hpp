#pragma once
// The shards of a sweep or a basin (docs/sweeps.md, "Shards"): which items shard K of N runs, the
// names of its files, finding all N again to merge them, and the CSV lines both write.
#include <cstddef>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace ambler::eval {
// A shard option or a set of shard files that cannot be used: one line naming the option or file.
class ShardError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct Shard {
  int index = 1;  // K, 1-based: this shard runs the items u with u mod count == K - 1
  int count = 1;  // N
};

// "K/N" with 1 <= K <= N. Throws ShardError naming --shard.
Shard parseShard(const std::string& text);

// The items of 0 … total − 1 that `shard` runs (u mod N = K − 1), in order; all of them without one.
std::vector<std::size_t> shardItems(std::size_t total, const std::optional<Shard>& shard);

// <stem>.shard-K-of-N<ext>: stem "results" for a sweep, "basin" for a basin; ext ".csv" for the
// shard's CSV, ".journal" for its resume journal.
std::string shardName(const Shard& s, const std::string& stem, const std::string& ext = ".csv");

// The <stem>.shard-K-of-N.csv files in `out`, ordered by K: all N of one split. Throws ShardError
// naming the directory or the file when there are none, a split is mixed or a shard is missing.
std::vector<std::pair<Shard, std::filesystem::path>> shardFiles(const std::filesystem::path& out,
                                                                const std::string& stem);

// CSV cells (RFC 4180): quoted where needed, comma-separated; csvLine ends them with "\n".
std::string csvText(const std::vector<std::string>& cells);
std::string csvLine(const std::vector<std::string>& cells);
// A number as a CSV cell: the shortest text that reads back as the same double, "" for a
// non-finite one (null in metrics.json).
std::string csvNumber(double v);

}  // namespace ambler::eval
