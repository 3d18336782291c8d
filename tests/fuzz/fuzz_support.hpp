#pragma once
// What every libFuzzer target here shares (docs/fuzzing.md): the input as text, and the error
// contract. A reader either accepts its input or throws its documented exception type whose
// what() is one line starting with the file it was told it reads; anything else (another
// exception, a crash, a sanitizer report, a leak, a hang, a broken contract) is a finding.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <string_view>

namespace ambler::fuzz {

inline std::string text(const std::uint8_t* data, std::size_t size) {
  return std::string(reinterpret_cast<const char*>(data), size);
}

// Stops the run as a finding (libFuzzer saves the input as crash-<sha1>).
[[noreturn]] inline void finding(const std::string& what) {
  std::fprintf(stderr, "FUZZ FINDING: %s\n", what.c_str());
  std::abort();
}

// The one-line error contract: "<file>: ..." (or, with `prefix`, a file whose path starts with
// it: a file in a directory) and no line break.
inline void checkMessage(const std::exception& e, std::string_view file, bool prefix = false) {
  const std::string_view m = e.what();
  if (!m.starts_with(std::string(file) + (prefix ? "" : ": ")))
    finding("message does not start with the file: " + std::string(m));
  if (m.find_first_of("\r\n") != std::string_view::npos) finding("message is not one line: " + std::string(m));
}

}  // namespace ambler::fuzz
