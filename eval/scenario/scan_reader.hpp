#pragma once
// A run's range scans, scans/view_<k>_range.tiff and view_<k>_meta.json (the scan stage,
// eval/run/stages/scan.cpp): the writer's half (scanMeta, writeScan) and a strict reader that gives
// back what was written. The reader refuses anything the writer cannot have written, each time
// with one line naming the file and the key or the cause.
#include <filesystem>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "eval/scenario/scenario.hpp"
#include "perception/range_image.hpp"

namespace ambler::eval {

// A scan file that cannot be read or is not what the scan stage writes: one line,
// "<file>: <key>: <what is wrong>" or "<file>: <what is wrong>".
class ScanError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// What the scan stage writes a scan from.
struct ScanFile {
  perception::RangeImage image;  // ranges, φ per row, θ per column; T_WS = sensorPose(view)
  ViewSpec view;                 // the pose of the meta file (rpy in radians)
};

// <stem>_meta.json: {"phi_rad": [...], "theta_rad": [...], "pose": {"xyz_m": [x, y, z],
// "rpy_deg": [roll, pitch, yaw]}}.
nlohmann::ordered_json scanMeta(const perception::RangeImage& image, const ViewSpec& view);
// <stem>_range.tiff (float32, NaN where nothing returned) and <stem>_meta.json, each atomically.
void writeScan(const std::filesystem::path& stem, const perception::RangeImage& image, const ViewSpec& view);

// Reads <stem>_range.tiff and <stem>_meta.json back. The ranges and angles are the written bits;
// an angle of the pose may be one ulp off (it went through degrees). Throws ScanError for a missing
// or unreadable file, a TIFF that is not single-channel float32, a size that differs from the
// meta's rows (phi_rad) and columns (theta_rad), a range that is negative or infinite (NaN, no
// return, is the writer's and is kept), JSON that does not parse, a missing, unknown or ill-typed
// key, a non-finite number, and angles out of order or out of (−90°, 90°).
ScanFile readScan(const std::filesystem::path& stem);

// The pieces, from memory; `file` names the source in messages.
struct ScanMeta {
  std::vector<double> phi;    // per row, radians
  std::vector<double> theta;  // per column, radians
  ViewSpec view;
};
ScanMeta parseScanMeta(const std::string& json_text, const std::string& file);
// A range image's TIFF bytes, decoded (cv::imdecode) and checked as readScan checks the file.
perception::Raster<float> decodeRangeTiff(const std::string& bytes, const std::string& file);
// The scan of a decoded TIFF and its meta; throws ScanError naming `tiff_file` when the sizes differ.
ScanFile assembleScan(perception::Raster<float> range, ScanMeta meta, const std::string& tiff_file,
                      const std::string& meta_file);

}  // namespace ambler::eval
