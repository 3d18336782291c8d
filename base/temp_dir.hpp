#pragma once
// A private temporary directory, removed with everything in it when its owner goes (however it
// goes): renderPlot's gnuplot files, a benchmark's world, a Python run without `out`.
#include <filesystem>
#include <string>

namespace ambler::base {

class TempDir {
 public:
  // Creates temp/ambler-TAG-<random> (mkdtemp: a new directory only its creator can enter).
  // Throws std::runtime_error naming it when it cannot.
  explicit TempDir(const std::string& tag);
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;

  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

}  // namespace ambler::base
