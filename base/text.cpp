#include "base/text.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <charconv>

namespace ambler::base {

std::string shortestText(double v) {
  char buf[32];  // the longest shortest form of a double is 24 characters
  return std::string(buf, std::to_chars(buf, buf + sizeof buf, v).ptr);
}

std::string plainText(double v) {
  std::array<char, 64> buf{};  // fixed: at most 16 digits before the point and 21 after it
  const double magnitude = std::abs(v);
  const auto format = (magnitude == 0.0 || (magnitude >= 1e-4 && magnitude < 1e16)) ? std::chars_format::fixed
                                                                                      : std::chars_format::scientific;
  return std::string(buf.data(), std::to_chars(buf.data(), buf.data() + buf.size(), v, format).ptr);
}

std::vector<std::string> split(std::string_view text, char sep) {
  std::vector<std::string> out;
  for (std::size_t start = 0;;) {
    const auto end = text.find(sep, start);
    out.emplace_back(text.substr(start, end - start));
    if (end == std::string_view::npos) return out;
    start = end + 1;
  }
}

bool allDigits(std::string_view s) {
  return !s.empty() && std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; });
}

}  // namespace ambler::base
