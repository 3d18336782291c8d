#pragma once
// A digest of text (standard library only): names what a file or a cache entry was made from.
#include <string>
#include <string_view>

namespace ambler::base {

// 16 lower-case hex digits of FNV-1a (64 bits) over `text`. Not cryptographic: it tells apart
// the texts a run can meet (a journal's identity, a plot's script), not an adversary's.
std::string digest(std::string_view text);

}  // namespace ambler::base
