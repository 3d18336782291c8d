// The inputs the fuzz targets found outside the readers' contract (tests/fuzz/, docs/fuzzing.md):
// each input is the one libFuzzer saved (or a readable reduction of it), and each test checks the
// reader's message for it. The contract: one line, "<file>: <key>: <what is wrong>".
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "eval/scenario/io.hpp"
#include "eval/scenario/scenario.hpp"
#include "eval/tools/sweep/sweep.hpp"
#include "test_support.hpp"

namespace ambler::eval {
namespace {

namespace fs = std::filesystem;

template <class Error, class F>
std::string messageOf(F f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

// From fuzz_scenario: yaml-cpp's "unknown escape character: " message ends with the character
// itself, here a line break; the scenario reader escapes it, so the message stays one line.
TEST(FuzzFindings, ScenarioYamlErrorWithALineBreakIsOneLine) {
  const std::string crash("ncml\xa7)iconic_weightede:\x15\x00\n", 26);
  EXPECT_EQ(messageOf<ScenarioError>([&] { parseScenario(crash, "s.yaml"); }),
            "s.yaml: line 2, column 1: YAML syntax error: unknown escape character: \\n");
  // A key with a line break (a quoted YAML key) is escaped too.
  const std::string message =
      messageOf<ScenarioError>([] { parseScenario("\"na\\nme\": t\n", "s.yaml"); });
  EXPECT_TRUE(message.starts_with("s.yaml: na\\nme: ")) << message;
  EXPECT_EQ(message.find('\n'), std::string::npos) << message;
}

// From fuzz_sweep: the same yaml-cpp message through the sweep reader.
TEST(FuzzFindings, SweepYamlErrorWithALineBreakIsOneLine) {
  const std::string crash(
      "n8ame: resoluti9\x00\ndescriptio\x8a\xba \"fr\xf0.0.rms_eactactal ase]\n", 57);
  EXPECT_EQ(messageOf<SweepError>([&] { parseSweep(crash, "w.yaml"); }),
            "w.yaml: line 2, column 1: YAML syntax error: unknown escape character: \\n");
  EXPECT_EQ(messageOf<SweepError>([] { parseSweep("\"a\\nb\": 1\n", "w.yaml"); }),
            "w.yaml: a\\nb: unknown key (allowed: name, description, base, axes, metrics)");
}

// From fuzz_results_csv: a shard row whose axis cells differ from the sweep's is reported with
// its cells, and a quoted cell may hold a line break, which the message escapes.
TEST(FuzzFindings, MergeMessageWithALineBreakInACellIsOneLine) {
  test::TempDir d;
  const Sweep sweep = loadSweep(fs::path(AMBLER_SOURCE_DIR) / "scenarios/sweeps/noise_check.yaml");
  const fs::path shard = d.path() / "results.shard-1-of-1.csv";
  writeText(shard, "run,terrain.slope_deg,sensor,m\n0,30;0,\"a\nb\",1\n");
  EXPECT_EQ(messageOf<SweepError>([&] { mergeSweep(sweep, d.path(), false); }),
            shard.string() +
                ": row 2: run 0: cells 0,30;0,\"a\\nb\" differ from the sweep file's "
                "0,30;0,\"{noise_k: 0, quantization_m: 0}\" (was it edited after the shards ran?)");
}

// From fuzz_scenario and fuzz_sweep: a hang. yaml-cpp 0.7.0's LoadAll loops for ever, allocating,
// on a token that starts no node (a lone ",", yaml-cpp issue 1040); eval/scenario/yaml_documents.hpp
// guards every LoadAll of the readers. The saved inputs are a scenario and a sweep with a stray
// "," at the start of line 2.
TEST(FuzzFindings, ALoneCommaIsASyntaxErrorNotAHang) {
  EXPECT_EQ(messageOf<ScenarioError>([] { parseScenario(",", "s.yaml"); }),
            "s.yaml: line 1, column 1: YAML syntax error: unexpected token (it starts no value)");
  EXPECT_EQ(messageOf<SweepError>([] { parseSweep(",", "w.yaml"); }),
            "w.yaml: line 1, column 1: YAML syntax error: unexpected token (it starts no value)");
  EXPECT_EQ(messageOf<ScenarioError>([] { parseScenario("# a scenario\n,a: 1\nname: t\n", "s.yaml"); }),
            "s.yaml: line 2, column 1: YAML syntax error: unexpected token (it starts no value)");
  // The base scenario a sweep names goes through the same guard.
  test::TempDir d;
  writeText(d.path() / "base.yaml", ",\n");
  EXPECT_EQ(messageOf<SweepError>([&] {
              parseSweep("name: w\nbase: base.yaml\naxes: {seed: [1]}\n", d.path() / "w.yaml");
            }),
            (d.path() / "w.yaml").string() + ": base: " + (d.path() / "base.yaml").string() +
                ": line 1, column 1: YAML syntax error: unexpected token (it starts no value)");
  // Several documents are still counted.
  EXPECT_EQ(messageOf<ScenarioError>([] { parseScenario("name: a\n---\nname: b\n---\nname: c\n", "s.yaml"); }),
            "s.yaml: expected one YAML document, got 3");
}

}  // namespace
}  // namespace ambler::eval
