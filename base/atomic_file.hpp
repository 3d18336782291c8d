#pragma once
// Whole-file writes that never leave a half-written file: write a temporary beside the target,
// then rename it over the target.
#include <filesystem>
#include <string_view>

namespace ambler::base {

// Throws std::runtime_error naming the path if the file cannot be written.
void writeFileAtomic(const std::filesystem::path& path, std::string_view bytes);

}  // namespace ambler::base
