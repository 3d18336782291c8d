#pragma once
// What the scenario tests check of a refusal: the one-line message parseScenario gives for a YAML
// text read as scenarios/x.yaml.
#include <gtest/gtest.h>

#include <string>

#include "eval/scenario/scenario.hpp"

namespace ambler::eval::scenario_test {

inline const std::string kFile = "scenarios/x.yaml";

// The message of the ScenarioError parsing `yaml` throws, or "(no error)".
inline std::string errorOf(const std::string& yaml) {
  try {
    parseScenario(yaml, kFile);
  } catch (const ScenarioError& e) {
    return e.what();
  }
  return "(no error)";
}

// The message is one line, starts with the file and the exact key path (none when empty), and
// says `what`.
inline void expectError(const std::string& yaml, const std::string& key_path, const std::string& what) {
  const std::string message = errorOf(yaml);
  SCOPED_TRACE(yaml);
  const std::string prefix = kFile + ": " + (key_path.empty() ? "" : key_path + ": ");
  EXPECT_EQ(message.rfind(prefix, 0), 0u) << message;
  EXPECT_NE(message.find(what), std::string::npos) << message;
  EXPECT_EQ(message.find('\n'), std::string::npos) << message;
}

}  // namespace ambler::eval::scenario_test
