#pragma once
// Run-directory files: every write goes to a temporary file renamed into place, so a file is
// either whole or absent.
#include <Eigen/Core>
#include <filesystem>
#include <nlohmann/json_fwd.hpp>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "perception/raster.hpp"

namespace ambler::eval {

// Output directories (docs/errors.md, "Output directories"). checkOutDir writes nothing: it
// throws std::runtime_error "<label> <dir>: <what is wrong>" when `dir` cannot be a directory the
// program writes in (a file is in the way, or the nearest existing ancestor is not writable), so a
// command can refuse a bad --out before it does any work. createOutDir creates `dir` and its
// parents, with the same one-line message on failure instead of the library's.
void checkOutDir(const std::filesystem::path& dir, const std::string& label = "--out");
void createOutDir(const std::filesystem::path& dir);

void writeText(const std::filesystem::path& path, const std::string& text);
// Pretty-printed with a trailing newline; key order as inserted.
void writeJson(const std::filesystem::path& path, const nlohmann::ordered_json& json);
// Single-channel float32 TIFF (NaN kept as NaN).
void writeTiff(const std::filesystem::path& path, const perception::Raster<float>& raster);
// The PNG bytes of an 8-bit image at zlib's highest level (figures and embedded pictures: half the
// size of the default level for a plot). Throws std::runtime_error if OpenCV cannot encode it.
std::string compactPngBytes(const cv::Mat& image);
// PNG of an 8-bit image (grey or BGR).
void writePng(const std::filesystem::path& path, const cv::Mat& image);
// Binary little-endian PLY of points (float x, y, z).
void writePly(const std::filesystem::path& path, const std::vector<Eigen::Vector3f>& points);

// A number for metrics.json and the run's JSON files: JSON has no NaN or infinity, so a figure
// that is not defined is null.
nlohmann::ordered_json jsonNumber(double v);

// Reads a float32 TIFF back (for tests and tools). Throws std::runtime_error naming the file.
perception::Raster<float> readTiff(const std::filesystem::path& path);

}  // namespace ambler::eval
