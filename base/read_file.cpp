#include "base/read_file.hpp"

#include <fstream>
#include <sstream>

namespace ambler::base {

std::string readFile(const std::filesystem::path& file) {
  std::error_code ec;
  std::ifstream in(file, std::ios::binary);
  // A directory opens as a stream on Linux and reads as nothing: refuse it as unopenable.
  if (!in || std::filesystem::is_directory(file, ec)) throw ReadError("cannot open file");
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw ReadError("cannot read file");
  return text.str();
}

}  // namespace ambler::base
