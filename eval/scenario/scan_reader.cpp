// Writing and reading back a run's range scans (eval/scenario/scan_reader.hpp).
#include "eval/scenario/scan_reader.hpp"

#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <numbers>
#include <set>
#include <sstream>
#include <string_view>
#include <utility>

#include "base/read_file.hpp"
#include "base/text.hpp"
#include "eval/scenario/io.hpp"
#include "eval/scenario/message_text.hpp"
#include "perception/sensor_geometry.hpp"

namespace ambler::eval {

namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

double degrees(double rad) { return rad * 180.0 / std::numbers::pi; }
double radians(double deg) { return deg * std::numbers::pi / 180.0; }

// One line: keys and library messages are escaped (eval/scenario/message_text.hpp).
[[noreturn]] void fail(const std::string& file, const std::string& key, const std::string& what) {
  throw ScanError(file + ": " + (key.empty() ? "" : escapedLine(key) + ": ") + escapedLine(what));
}

std::string shortest(double v) { return base::shortestText(v); }

std::string readBytes(const fs::path& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) fail(path.string(), "", "cannot open file (no such file)");
  try {
    return base::readFile(path);
  } catch (const base::ReadError& e) {
    fail(path.string(), "", e.what());
  }
}

// The object at `key`, with exactly the keys `allowed`, all present.
const Json& object(const std::string& file, const Json& j, const std::string& key,
                   const std::vector<std::string>& allowed) {
  const std::string where = key.empty() ? "" : key;
  if (!j.is_object()) fail(file, where, std::string("expected an object, got ") + j.type_name());
  for (const auto& [k, v] : j.items()) {
    if (std::find(allowed.begin(), allowed.end(), k) == allowed.end()) {
      std::string list;
      for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
      fail(file, (where.empty() ? "" : where + ".") + k, "unknown key (allowed: " + list + ")");
    }
  }
  for (const auto& a : allowed)
    if (!j.contains(a)) fail(file, (where.empty() ? "" : where + ".") + a, "missing key");
  return j;
}

std::vector<double> numbers(const std::string& file, const Json& j, const std::string& key) {
  if (!j.is_array()) fail(file, key, std::string("expected a list of numbers, got ") + j.type_name());
  std::vector<double> out;
  out.reserve(j.size());
  for (std::size_t i = 0; i < j.size(); ++i) {
    const Json& v = j[i];
    const std::string at = key + "[" + std::to_string(i) + "]";
    if (!v.is_number()) fail(file, at, std::string("expected a number, got ") + v.type_name());
    const double d = v.get<double>();
    if (!std::isfinite(d)) fail(file, at, "expected a finite number, got " + shortest(d));
    out.push_back(d);
  }
  return out;
}

Eigen::Vector3d triple(const std::string& file, const Json& j, const std::string& key) {
  const auto v = numbers(file, j, key);
  if (v.size() != 3) fail(file, key, "expected 3 numbers, got " + std::to_string(v.size()));
  return {v[0], v[1], v[2]};
}

// Scan angles: at least one, inside (−90°, 90°) (a field of view under 180° centred on the
// boresight) and strictly monotonic as the writer lays them out (φ falling, θ rising).
std::vector<double> angles(const std::string& file, const Json& j, const std::string& key, bool falling) {
  auto v = numbers(file, j, key);
  if (v.empty()) fail(file, key, "expected at least one angle, got none");
  for (std::size_t i = 0; i < v.size(); ++i) {
    if (!(std::abs(v[i]) < std::numbers::pi / 2))
      fail(file, key + "[" + std::to_string(i) + "]", "expected an angle in (-pi/2, pi/2), got " + shortest(v[i]));
    if (i > 0 && !(falling ? v[i] < v[i - 1] : v[i] > v[i - 1])) {
      fail(file, key + "[" + std::to_string(i) + "]",
           std::string("expected strictly ") + (falling ? "falling" : "rising") + " angles, got " +
               shortest(v[i - 1]) + " then " + shortest(v[i]));
    }
  }
  return v;
}

// Refuses a key given twice in one object (JSON allows it; the writer never does it).
struct DuplicateKeys {
  std::string file;
  std::vector<std::set<std::string>> open;
  bool operator()(int /*depth*/, Json::parse_event_t event, Json& parsed) {
    switch (event) {
      case Json::parse_event_t::object_start:
        open.emplace_back();
        break;
      case Json::parse_event_t::object_end:
        if (!open.empty()) open.pop_back();
        break;
      case Json::parse_event_t::key:
        if (!open.empty() && !open.back().insert(parsed.get<std::string>()).second)
          fail(file, parsed.get<std::string>(), "duplicate key");
        break;
      default:
        break;
    }
    return true;
  }
};

bool isTiff(const std::string& bytes) {
  return bytes.size() >= 4 && (bytes.compare(0, 4, std::string("II*\0", 4)) == 0 ||
                               bytes.compare(0, 4, std::string("MM\0*", 4)) == 0);
}

}  // namespace

nlohmann::ordered_json scanMeta(const perception::RangeImage& img, const ViewSpec& view) {
  nlohmann::ordered_json j;
  j["phi_rad"] = img.phi;
  j["theta_rad"] = img.theta;
  j["pose"]["xyz_m"] = {view.xyz_m.x(), view.xyz_m.y(), view.xyz_m.z()};
  j["pose"]["rpy_deg"] = {degrees(view.rpy_rad.x()), degrees(view.rpy_rad.y()), degrees(view.rpy_rad.z())};
  return j;
}

void writeScan(const fs::path& stem, const perception::RangeImage& image, const ViewSpec& view) {
  writeTiff(stem.string() + "_range.tiff", image.range);
  writeJson(stem.string() + "_meta.json", scanMeta(image, view));
}

ScanMeta parseScanMeta(const std::string& json_text, const std::string& file) {
  Json j;
  try {
    j = Json::parse(json_text, DuplicateKeys{file, {}});
  } catch (const Json::exception& e) {
    fail(file, "", std::string("not JSON: ") + e.what());
  }
  object(file, j, "", {"phi_rad", "theta_rad", "pose"});
  ScanMeta meta;
  meta.phi = angles(file, j["phi_rad"], "phi_rad", true);
  meta.theta = angles(file, j["theta_rad"], "theta_rad", false);
  const Json& pose = object(file, j["pose"], "pose", {"xyz_m", "rpy_deg"});
  meta.view.xyz_m = triple(file, pose["xyz_m"], "pose.xyz_m");
  const Eigen::Vector3d rpy_deg = triple(file, pose["rpy_deg"], "pose.rpy_deg");
  meta.view.rpy_rad = {radians(rpy_deg.x()), radians(rpy_deg.y()), radians(rpy_deg.z())};
  return meta;
}

perception::Raster<float> decodeRangeTiff(const std::string& bytes, const std::string& file) {
  if (!isTiff(bytes)) fail(file, "", "not a TIFF file (no II*/MM* signature)");
  cv::Mat m;
  try {
    const cv::Mat buf(1, int(bytes.size()), CV_8UC1, const_cast<char*>(bytes.data()));
    m = cv::imdecode(buf, cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& e) {
    fail(file, "", std::string("cannot decode TIFF: ") + e.what());
  }
  if (m.empty()) fail(file, "", "cannot decode TIFF");
  if (m.type() != CV_32FC1) {
    fail(file, "", "expected a single-channel float32 TIFF, got " + std::to_string(m.channels()) +
                       " channel(s) of OpenCV depth " + std::to_string(m.depth()));
  }
  perception::Raster<float> out(m.rows, m.cols);
  for (int r = 0; r < m.rows; ++r) {
    for (int c = 0; c < m.cols; ++c) {
      const float v = m.at<float>(r, c);
      // NaN is the writer's "no return"; a range is never negative or infinite.
      if (std::isinf(v) || v < 0.0f) {
        fail(file, "row " + std::to_string(r) + ", column " + std::to_string(c),
             "expected a range >= 0 m or NaN (no return), got " + shortest(v));
      }
      out(r, c) = v;
    }
  }
  return out;
}

ScanFile assembleScan(perception::Raster<float> range, ScanMeta meta, const std::string& tiff_file,
                      const std::string& meta_file) {
  if (range.rows() != Eigen::Index(meta.phi.size()) || range.cols() != Eigen::Index(meta.theta.size())) {
    fail(tiff_file, "", std::to_string(range.rows()) + " x " + std::to_string(range.cols()) + " pixels, but " +
                            meta_file + " has " + std::to_string(meta.phi.size()) + " rows (phi_rad) and " +
                            std::to_string(meta.theta.size()) + " columns (theta_rad)");
  }
  ScanFile scan;
  scan.image.range = std::move(range);
  scan.image.phi = std::move(meta.phi);
  scan.image.theta = std::move(meta.theta);
  scan.view = meta.view;
  scan.image.T_WS = perception::sensorPose(scan.view.xyz_m, scan.view.rpy_rad);
  return scan;
}

ScanFile readScan(const fs::path& stem) {
  const std::string meta_file = stem.string() + "_meta.json";
  const std::string tiff_file = stem.string() + "_range.tiff";
  ScanMeta meta = parseScanMeta(readBytes(meta_file), meta_file);
  return assembleScan(decodeRangeTiff(readBytes(tiff_file), tiff_file), std::move(meta), tiff_file, meta_file);
}

}  // namespace ambler::eval
