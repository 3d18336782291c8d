#pragma once
// The readers' error contract is one line per message ("<file>: <key>: <what is wrong>"). Text
// that a message quotes from elsewhere (a key or cell of the file, a library's own message) may
// hold line breaks; this escapes them. Found by the fuzz targets (docs/fuzzing.md).
#include <cstdio>
#include <string>
#include <string_view>

namespace ambler::eval {

// `text` with \n, \r and \t written as those escapes and any other control character as \xHH;
// everything else (and text that is already one line) unchanged.
inline std::string escapedLine(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (const char c : text) {
    const auto u = static_cast<unsigned char>(c);
    if (c == '\n') {
      out += "\\n";
    } else if (c == '\r') {
      out += "\\r";
    } else if (c == '\t') {
      out += "\\t";
    } else if (u < 0x20 || u == 0x7f) {
      char hex[8];
      std::snprintf(hex, sizeof hex, "\\x%02x", unsigned(u));
      out += hex;
    } else {
      out += c;
    }
  }
  return out;
}

}  // namespace ambler::eval
