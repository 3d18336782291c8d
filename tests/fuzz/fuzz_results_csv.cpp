// libFuzzer target: results.csv as `ambler sweep --merge` reads it. Two readers:
//  - eval::parseResultsCsv (RFC 4180 records, nullopt for an open or stray quote; never throws),
//    checked by a round trip: the records written back as CSV lines parse to the same records;
//  - eval::mergeSweep over scenarios/sweeps/noise_check.yaml (4 runs), the input written as its
//    shard files into a directory of this process (pieces separated by a form feed, \f, are
//    shards 1..N of N, N <= 4). Contract: results.csv is written, or SweepError with one line
//    naming the directory or a shard file (docs/fuzzing.md).
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "eval/scenario/io.hpp"
#include "eval/tools/sweep/sweep.hpp"
#include "base/read_file.hpp"
#include "base/text.hpp"
#include "eval/tools/shards.hpp"
#include "fuzz_support.hpp"

namespace {

namespace fs = std::filesystem;
using namespace ambler;

const fs::path& workDir() {
  static const fs::path dir = [] {
    fs::path d = fs::temp_directory_path() / ("ambler-fuzz-results-" + std::to_string(::getpid()));
    fs::create_directories(d);
    std::atexit([] {
      std::error_code ec;
      fs::remove_all(workDir(), ec);
    });
    return d;
  }();
  return dir;
}

const eval::Sweep& sweep() {
  static const eval::Sweep s = eval::loadSweep(AMBLER_SOURCE_DIR "/scenarios/sweeps/noise_check.yaml");
  return s;
}

void roundTrip(const std::string& text) {
  const auto records = eval::parseResultsCsv(text);
  if (!records) return;
  std::string again;
  for (const auto& r : *records) again += eval::csvLine(r);
  const auto back = eval::parseResultsCsv(again);
  if (!back || *back != *records) fuzz::finding("CSV records do not read back the same after csvLine");
}

void merge(const std::string& text) {
  std::vector<std::string> pieces = base::split(text, '\f');
  if (pieces.size() > 4) return;
  const fs::path& dir = workDir();
  for (const auto& entry : fs::directory_iterator(dir)) fs::remove(entry.path());
  const int n = int(pieces.size());
  for (int k = 1; k <= n; ++k)
    eval::writeText(dir / eval::shardName(eval::Shard{k, n}, "results"), pieces[std::size_t(k - 1)]);
  try {
    const fs::path csv = eval::mergeSweep(sweep(), dir, false);
    const auto records = eval::parseResultsCsv(base::readFile(csv));
    if (!records || records->size() != sweep().runs.size() + 1)
      fuzz::finding("a merged results.csv without one row per run");
  } catch (const eval::SweepError& e) {
    fuzz::checkMessage(e, dir.string(), true);
  }
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  sweep();
  workDir();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text = fuzz::text(data, size);
  roundTrip(text);
  merge(text);
  return 0;
}
