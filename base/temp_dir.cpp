#include "base/temp_dir.hpp"

#include <stdlib.h>

#include <cerrno>
#include <stdexcept>
#include <system_error>

namespace ambler::base {

TempDir::TempDir(const std::string& tag) {
  // mkdtemp's template: six X's it replaces with a unique suffix.
  std::string pattern = (std::filesystem::temp_directory_path() / ("ambler-" + tag + "-XXXXXX")).string();
  if (!::mkdtemp(pattern.data()))
    throw std::runtime_error(pattern + ": cannot create a temporary directory: " +
                             std::error_code(errno, std::generic_category()).message());
  path_ = pattern;
}

TempDir::~TempDir() {
  std::error_code ec;
  std::filesystem::remove_all(path_, ec);
}

}  // namespace ambler::base
