#pragma once
// Reading a whole file (standard library only). Writing one: base/atomic_file.hpp.
#include <filesystem>
#include <stdexcept>
#include <string>

namespace ambler::base {

// Why a file could not be read; what() is the cause alone ("cannot open file", "cannot read
// file"), so each reader puts the file's name (and its own exception type) before it.
class ReadError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The file's bytes. Throws ReadError "cannot open file" when it cannot be opened (missing, a
// directory, no permission) and "cannot read file" when reading it fails.
std::string readFile(const std::filesystem::path& file);

}  // namespace ambler::base
