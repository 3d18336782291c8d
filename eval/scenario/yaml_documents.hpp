#pragma once
// YAML::LoadAll with a guard. yaml-cpp 0.7.0 (Debian 12) loops for ever, allocating, on a stream
// whose next token starts no node (a lone ",", yaml-cpp issue 1040, fixed upstream in 0.8.x by
// PR 1319): each turn of LoadAll adds one more null document without consuming the token. Found
// by the fuzz targets (docs/fuzzing.md).
#include <yaml-cpp/yaml.h>

#include <string>
#include <vector>

namespace ambler::eval {

// The documents of `text`, as YAML::LoadAll gives them. Throws YAML::ParserException (marked
// where the parser stopped moving) where LoadAll would not return, and whatever LoadAll throws.
std::vector<YAML::Node> loadAllDocuments(const std::string& text);

}  // namespace ambler::eval
