// libFuzzer target: the sweep reader (eval::parseSweep), which also reads the base scenario it
// names and validates every combination with the scenario reader. Contract: the text parses, or
// SweepError with one line naming the sweep file (docs/fuzzing.md).
#include <string>

#include "eval/tools/sweep/sweep.hpp"
#include "fuzz_support.hpp"

namespace {
// Where scenarios/sweeps/noise_check.yaml is, so a base such as ../plane.yaml or
// ../experiments/plane_base.yaml names a real scenario of the repository.
const std::string kFile = AMBLER_SOURCE_DIR "/scenarios/sweeps/fuzz.yaml";
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace ambler;
  try {
    const eval::Sweep sweep = eval::parseSweep(fuzz::text(data, size), kFile);
    std::size_t count = 1;
    for (const auto& axis : sweep.axes) count *= axis.values.size();
    if (sweep.runs.size() != count) fuzz::finding("runs do not match the product of the axes");
  } catch (const eval::SweepError& e) {
    fuzz::checkMessage(e, kFile);
  }
  return 0;
}
