#include "base/atomic_file.hpp"

#include <cstdio>
#include <stdexcept>
#include <string>
#include <unistd.h>

namespace ambler::base {

void writeFileAtomic(const std::filesystem::path& path, std::string_view bytes) {
  const auto tmp = path.string() + ".tmp" + std::to_string(::getpid());
  std::FILE* f = std::fopen(tmp.c_str(), "wb");
  if (!f) throw std::runtime_error(path.string() + ": cannot write file");
  const bool ok = std::fwrite(bytes.data(), 1, bytes.size(), f) == bytes.size();
  if (std::fclose(f) != 0 || !ok) {
    std::remove(tmp.c_str());
    throw std::runtime_error(path.string() + ": write failed");
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::remove(tmp.c_str());
    throw std::runtime_error(path.string() + ": cannot rename into place: " + ec.message());
  }
}

}  // namespace ambler::base
