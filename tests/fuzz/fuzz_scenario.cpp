// libFuzzer target: the scenario reader (eval::parseScenario). Contract: the text parses, or
// ScenarioError with one line naming the file; a parsed scenario's resolvedYaml parses again to
// the same resolvedYaml (docs/fuzzing.md).
#include <string>

#include "eval/scenario/scenario.hpp"
#include "fuzz_support.hpp"

namespace {
// Beside the repository's scenarios, so that relative paths (terrain.mjcf) resolve as for them.
const std::string kFile = AMBLER_SOURCE_DIR "/scenarios/fuzz.yaml";
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace ambler;
  std::string resolved;
  try {
    resolved = eval::resolvedYaml(eval::parseScenario(fuzz::text(data, size), kFile));
  } catch (const eval::ScenarioError& e) {
    fuzz::checkMessage(e, kFile);
    return 0;
  }
  try {
    const std::string again = eval::resolvedYaml(eval::parseScenario(resolved, kFile));
    if (again != resolved) fuzz::finding("resolvedYaml does not read back the same:\n" + resolved + "\n---\n" + again);
  } catch (const eval::ScenarioError& e) {
    fuzz::finding(std::string("resolvedYaml of an accepted scenario is refused: ") + e.what() + "\n" + resolved);
  }
  return 0;
}
