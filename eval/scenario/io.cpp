#include "eval/scenario/io.hpp"

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <optional>
#include <stdexcept>
#include <system_error>

#include "base/atomic_file.hpp"

namespace ambler::eval {

namespace {

std::string encode(const std::filesystem::path& path, const char* ext, const cv::Mat& image,
                   const std::vector<int>& params = {}) {
  std::vector<uchar> buf;
  if (!cv::imencode(ext, image, buf, params))
    throw std::runtime_error(path.string() + ": could not encode image");
  return std::string(buf.begin(), buf.end());
}

namespace fs = std::filesystem;

// What is in the way of writing in directory `dir`, or nullopt when nothing is found. Looks only:
// `dir` must be a directory or not exist, and the nearest existing directory must be writable.
std::optional<std::string> outDirProblem(const fs::path& dir) {
  std::error_code ec;
  const auto kind = [](const fs::file_status& st) {
    return fs::is_regular_file(st) ? std::string("a file") : std::string("not a directory");
  };
  const fs::file_status st = fs::status(dir, ec);
  if (fs::exists(st)) {
    if (!fs::is_directory(st)) return "expected a directory, got " + kind(st);
    if (::access(dir.c_str(), W_OK | X_OK) != 0)
      return "cannot write in the directory (" + std::string(std::strerror(errno)) + ")";
    return std::nullopt;
  }
  // The nearest ancestor that exists: the new directories are made in it.
  for (fs::path parent = dir.parent_path();; parent = parent.parent_path()) {
    const fs::path shown = parent.empty() ? fs::path(".") : parent;
    const fs::file_status ps = fs::status(shown, ec);
    if (!fs::exists(ps)) {
      if (parent.empty() || parent == parent.root_path()) return std::nullopt;  // mkdir will say
      continue;
    }
    if (!fs::is_directory(ps))
      return "cannot create the directory: " + shown.string() + " is " +
             (fs::is_regular_file(ps) ? "a file" : "not a directory");
    if (::access(shown.c_str(), W_OK | X_OK) != 0)
      return "cannot create the directory in " + shown.string() + " (" + std::strerror(errno) + ")";
    return std::nullopt;
  }
}

}  // namespace

void checkOutDir(const fs::path& dir, const std::string& label) {
  if (dir.empty()) throw std::runtime_error(label + ": expected a directory, got \"\"");
  if (const auto problem = outDirProblem(dir))
    throw std::runtime_error(label + " " + dir.string() + ": " + *problem);
}

void createOutDir(const fs::path& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (!ec) return;
  if (const auto problem = outDirProblem(dir)) throw std::runtime_error(dir.string() + ": " + *problem);
  throw std::runtime_error(dir.string() + ": cannot create the directory (" + ec.message() + ")");
}

void writeText(const std::filesystem::path& path, const std::string& text) {
  base::writeFileAtomic(path, text);
}

void writeJson(const std::filesystem::path& path, const nlohmann::ordered_json& json) {
  base::writeFileAtomic(path, json.dump(2) + "\n");
}

void writeTiff(const std::filesystem::path& path, const perception::Raster<float>& raster) {
  const cv::Mat m(int(raster.rows()), int(raster.cols()), CV_32FC1,
                  const_cast<float*>(raster.data()));
  base::writeFileAtomic(path, encode(path, ".tiff", m));
}

std::string compactPngBytes(const cv::Mat& image) {
  return encode("PNG", ".png", image, {cv::IMWRITE_PNG_COMPRESSION, 9});
}

void writePng(const std::filesystem::path& path, const cv::Mat& image) {
  base::writeFileAtomic(path, encode(path, ".png", image));
}

void writePly(const std::filesystem::path& path, const std::vector<Eigen::Vector3f>& points) {
  std::string bytes = "ply\nformat binary_little_endian 1.0\ncomment ambler returns, world frame, metres\n"
                      "element vertex " + std::to_string(points.size()) +
                      "\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
  const std::size_t head = bytes.size();
  bytes.resize(head + points.size() * 12);
  for (std::size_t i = 0; i < points.size(); ++i) std::memcpy(&bytes[head + 12 * i], points[i].data(), 12);
  base::writeFileAtomic(path, bytes);
}

perception::Raster<float> readTiff(const std::filesystem::path& path) {
  const cv::Mat m = cv::imread(path.string(), cv::IMREAD_UNCHANGED);
  if (m.empty()) throw std::runtime_error(path.string() + ": cannot read TIFF");
  if (m.type() != CV_32FC1) throw std::runtime_error(path.string() + ": not a float32 single-channel TIFF");
  perception::Raster<float> out(m.rows, m.cols);
  for (int r = 0; r < m.rows; ++r)
    for (int c = 0; c < m.cols; ++c) out(r, c) = m.at<float>(r, c);
  return out;
}

nlohmann::ordered_json jsonNumber(double v) {
  return std::isfinite(v) ? nlohmann::ordered_json(v) : nlohmann::ordered_json(nullptr);
}

}  // namespace ambler::eval
