#pragma once
// Text every module writes or reads the same way (standard library only).
#include <string>
#include <string_view>
#include <vector>

namespace ambler::base {

// The shortest text that reads back as the same double (std::to_chars' shortest round trip:
// "0.1", "1e-05", "1e+21"). The caller decides what a non-finite value is ("nan", "inf" here).
std::string shortestText(double v);

// The same, in fixed notation where a person would write it so (0.0003, 40, -2.5) and in
// scientific notation otherwise (1e-05, 1e+21): what the scenario files and messages print.
std::string plainText(double v);

// `text` cut at every `sep`: n separators give n + 1 pieces (empty ones kept).
std::vector<std::string> split(std::string_view text, char sep);

// Non-empty and only the digits 0–9.
bool allDigits(std::string_view s);

}  // namespace ambler::base
