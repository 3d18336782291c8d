#include "base/atomic_file.hpp"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <string>
#include <unistd.h>

namespace ambler::base {

void writeFileAtomic(const std::filesystem::path& path, std::string_view bytes) {
  const auto tmp = path.string() + ".tmp" + std::to_string(::getpid());
  std::FILE* f = std::fopen(tmp.c_str(), "wb");
  if (!f) throw std::runtime_error(path.string() + ": cannot write file: " + std::strerror(errno));
  // The cause of a failed write (a full disk, a file-size limit) is in errno after fwrite or
  // fclose, whichever first meets it.
  int err = 0;
  if (std::fwrite(bytes.data(), 1, bytes.size(), f) != bytes.size() || std::fflush(f) != 0) err = errno;
  if (std::fclose(f) != 0 && err == 0) err = errno;
  if (err != 0) {
    std::remove(tmp.c_str());
    throw std::runtime_error(path.string() + ": write failed: " + std::strerror(err));
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::remove(tmp.c_str());
    throw std::runtime_error(path.string() + ": cannot rename into place: " + ec.message());
  }
}

}  // namespace ambler::base
