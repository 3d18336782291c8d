// The shards of a sweep or a basin (eval/tools/shards.hpp).
#include "eval/tools/shards.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <regex>

#include "base/text.hpp"
#include "eval/scenario/scenario.hpp"

namespace ambler::eval {

namespace fs = std::filesystem;

Shard parseShard(const std::string& text) {
  const auto parts = base::split(text, '/');
  Shard s;
  const auto parse = [](const std::string& p, int& v) {
    return base::allDigits(p) && p.size() <= 9 && std::from_chars(p.data(), p.data() + p.size(), v).ec == std::errc();
  };
  if (parts.size() != 2 || !parse(parts[0], s.index) || !parse(parts[1], s.count) || s.index < 1 || s.index > s.count) {
    throw ShardError("--shard: expected K/N with 1 <= K <= N (shard K of N, 1-based), got " + yamlQuoted(text));
  }
  return s;
}

std::vector<std::size_t> shardItems(std::size_t total, const std::optional<Shard>& shard) {
  std::vector<std::size_t> items;
  for (std::size_t u = 0; u < total; ++u)
    if (!shard || u % std::size_t(shard->count) == std::size_t(shard->index - 1)) items.push_back(u);
  return items;
}

std::string shardName(const Shard& s, const std::string& stem, const std::string& ext) {
  return stem + ".shard-" + std::to_string(s.index) + "-of-" + std::to_string(s.count) + ext;
}

std::vector<std::pair<Shard, fs::path>> shardFiles(const fs::path& out, const std::string& stem) {
  const std::string where = out.string();
  std::error_code ec;
  if (!fs::is_directory(out, ec)) throw ShardError(where + ": no such directory");
  const std::regex pattern(stem + R"(\.shard-([0-9]{1,9})-of-([0-9]{1,9})\.csv)");
  std::vector<std::pair<Shard, fs::path>> files;
  for (const auto& entry : fs::directory_iterator(out)) {
    std::smatch m;
    const std::string name = entry.path().filename().string();
    if (!std::regex_match(name, m, pattern)) continue;
    files.emplace_back(Shard{std::stoi(m[1]), std::stoi(m[2])}, entry.path());
  }
  if (files.empty()) throw ShardError(where + ": no " + stem + ".shard-K-of-N.csv files to merge");
  std::sort(files.begin(), files.end(), [](const auto& a, const auto& b) {
    return std::pair(a.first.count, a.first.index) < std::pair(b.first.count, b.first.index);
  });
  const int n = files.front().first.count;
  if (files.back().first.count != n) {
    throw ShardError(where + ": shards of different splits (" + files.front().second.filename().string() + ", " +
                   files.back().second.filename().string() + "): remove the stale ones");
  }
  for (const auto& [shard, path] : files) {
    if (shard.index < 1 || shard.index > n)
      throw ShardError(path.string() + ": no shard " + std::to_string(shard.index) + " of " + std::to_string(n));
  }
  for (int k = 1; k <= n; ++k) {
    if (std::none_of(files.begin(), files.end(), [&](const auto& f) { return f.first.index == k; })) {
      throw ShardError((out / shardName(Shard{k, n}, stem)).string() + ": missing (shard " + std::to_string(k) + " of " +
                     std::to_string(n) + ")");
    }
  }
  return files;
}

namespace {

std::string csvCell(const std::string& text) {
  if (text.find_first_of(",\"\r\n") == std::string::npos) return text;
  std::string out = "\"";
  for (const char c : text) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

}  // namespace

std::string csvText(const std::vector<std::string>& cells) {
  std::string out;
  for (std::size_t i = 0; i < cells.size(); ++i) {
    if (i) out += ',';
    out += csvCell(cells[i]);
  }
  return out;
}

std::string csvLine(const std::vector<std::string>& cells) { return csvText(cells) + "\n"; }

std::string csvNumber(double v) { return std::isfinite(v) ? base::shortestText(v) : std::string(); }

}  // namespace ambler::eval
