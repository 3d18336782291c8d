#include "base/digest.hpp"

#include <cstdint>

namespace ambler::base {

std::string digest(std::string_view text) {
  std::uint64_t h = 0xcbf29ce484222325ULL;
  for (const char ch : text) {
    h ^= std::uint8_t(ch);
    h *= 0x100000001b3ULL;
  }
  static const char* digits = "0123456789abcdef";
  std::string out(16, '0');
  for (int i = 15; i >= 0; --i, h >>= 4) out[std::size_t(i)] = digits[h & 0xF];
  return out;
}

}  // namespace ambler::base
