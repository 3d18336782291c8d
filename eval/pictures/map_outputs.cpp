#include "eval/pictures/map_outputs.hpp"

#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <stdexcept>
#include <vector>

#include "eval/pictures/figures.hpp"
#include "eval/pictures/legend.hpp"
#include "eval/scenario/io.hpp"

namespace ambler::eval {

namespace {

using perception::CellState;
using perception::ElevationMap;

const cv::Vec3b kUnseen(40, 40, 40);  // shadedRelief's no-data colour
const cv::Vec3b kUnknown(150, 150, 150);
const cv::Vec3b kNoTruth(95, 95, 95);
const cv::Vec3b kKnown(120, 190, 110);
const cv::Vec3b kShadow(110, 25, 100);  // dark purple under magenta stripes
const cv::Vec3b kStripe(255, 70, 255);

struct Swatch {
  std::string label;
  cv::Vec3b colour;
  bool hatched = false;
};

bool stripe(int x, int y) { return (x + y) / 3 % 3 == 0; }

// One BGR pixel per cell → the enlarged picture, Shadow cells hatched in purple and magenta.
cv::Mat enlarge(const cv::Mat& cells, const ElevationMap& map) {
  const int k = cellEnlargement(cells.rows, cells.cols);
  cv::Mat out;
  cv::resize(cells, out, cv::Size(), k, k, cv::INTER_NEAREST);
  for (int y = 0; y < out.rows; ++y)
    for (int x = 0; x < out.cols; ++x)
      if (map.stateAt(y / k, x / k) == CellState::Shadow)
        out.at<cv::Vec3b>(y, x) = stripe(x, y) ? kStripe : kShadow;
  return out;
}

// A swatch's legend entry: a box of its colour (hatched as the map's shadows where asked), outlined.
cv::Mat withLegend(const cv::Mat& canvas, const std::vector<Swatch>& swatches, const std::string& note = "") {
  std::vector<LegendEntry> entries;
  for (const Swatch& e : swatches)
    entries.push_back({e.label, [e](cv::Mat& out, cv::Point at) {
                         cv::Mat box = out(cv::Rect(at.x, at.y, 14, 14));
                         box.setTo(cv::Scalar(e.colour[0], e.colour[1], e.colour[2]));
                         if (e.hatched)
                           for (int j = 0; j < 14; ++j)
                             for (int i = 0; i < 14; ++i)
                               if (stripe(i, j)) box.at<cv::Vec3b>(j, i) = kStripe;
                         cv::rectangle(out, cv::Rect(at.x, at.y, 14, 14), cv::Scalar(0, 0, 0), 1);
                       }});
  return ambler::eval::withLegend(canvas, entries, note);
}

std::string format(const char* pattern, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, pattern, v);
  return buf;
}

std::string percent(long n, long of) { return format("%.1f%%", of ? 100.0 * double(n) / double(of) : 0.0); }

// Signed error map − truth, blue below and red above the truth; the colour scale is symmetric
// about 0 and ends at the 99th percentile of |error| so one outlier does not wash out the rest.
cv::Mat errorPicture(const ElevationMap& map, const ElevationMap& truth_map, const std::string& title) {
  const perception::Raster<float>& truth = truth_map.elevation();
  const int rows = map.grid().rows, cols = map.grid().cols;
  std::vector<double> abs_err;
  double sum2 = 0;
  bool no_truth = false;
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) {
      if (map.stateAt(r, c) != CellState::Known) continue;
      if (!std::isfinite(truth(r, c))) {
        no_truth = true;
        continue;
      }
      const double e = double(map.elevation()(r, c)) - double(truth(r, c));
      abs_err.push_back(std::abs(e));
      sum2 += e * e;
    }
  double scale = 1e-3;
  if (!abs_err.empty()) {
    auto p99 = abs_err.begin() + std::ptrdiff_t(0.99 * double(abs_err.size() - 1));
    std::nth_element(abs_err.begin(), p99, abs_err.end());
    scale = std::max(scale, *p99);
  }
  const cv::Mat ramp = coolWarmRamp();
  cv::Mat cells(rows, cols, CV_8UC3);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) {
      if (map.stateAt(r, c) != CellState::Known) {
        cells.at<cv::Vec3b>(r, c) = kUnknown;
      } else if (!std::isfinite(truth(r, c))) {
        cells.at<cv::Vec3b>(r, c) = kNoTruth;
      } else {
        const double e = double(map.elevation()(r, c)) - double(truth(r, c));
        const long level = std::clamp(std::lround(127.5 + 127.5 * e / scale), 0L, 255L);
        cells.at<cv::Vec3b>(r, c) = ramp.at<cv::Vec3b>(0, int(level));
      }
    }
  const double rms_cm = abs_err.empty() ? 0.0 : 100.0 * std::sqrt(sum2 / double(abs_err.size()));
  const std::string rms = abs_err.empty() ? "nothing to compare" : format("rms %.2f cm", rms_cm);
  const std::string head = title + ": map - truth, " + rms;
  std::vector<Swatch> legend{{"unknown", kUnknown}, {"range shadow", kShadow, true}};
  if (no_truth) legend.push_back({"known, no truth", kNoTruth});
  const cv::Mat framed = framePicture(enlarge(cells, map), head, ramp, -100.0 * scale, 100.0 * scale, "cm");
  return withLegend(framed, legend, "(scale ends at p99 of |error|)");
}

cv::Mat elevationPicture(const ElevationMap& map, const std::string& title) {
  const Relief relief = reliefImage(map.elevation(), map.grid().cell);
  const cv::Mat framed = framePicture(enlarge(relief.image, map), title + ": elevation",
                                      colourRamp(cv::COLORMAP_VIRIDIS), relief.lo, relief.hi, "m");
  return withLegend(framed, {{"unseen", kUnseen}, {"range shadow", kShadow, true}});
}

cv::Mat sigmaPicture(const ElevationMap& map, const std::string& title) {
  const int rows = map.grid().rows, cols = map.grid().cols;
  double lo = HUGE_VAL, hi = -HUGE_VAL;
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c)
      if (map.stateAt(r, c) == CellState::Known && std::isfinite(map.sigma()(r, c)))
        lo = std::min(lo, double(map.sigma()(r, c))), hi = std::max(hi, double(map.sigma()(r, c)));
  if (lo > hi) lo = hi = 0;
  const double span = std::max(hi - lo, 1e-9);
  const cv::Mat ramp = colourRamp(cv::COLORMAP_INFERNO);
  cv::Mat cells(rows, cols, CV_8UC3);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) {
      const float s = map.sigma()(r, c);
      cells.at<cv::Vec3b>(r, c) =
          map.stateAt(r, c) == CellState::Known && std::isfinite(s)
              ? ramp.at<cv::Vec3b>(0, int(std::clamp(std::lround(255.0 * (s - lo) / span), 0L, 255L)))
              : kUnknown;
    }
  const cv::Mat framed =
      framePicture(enlarge(cells, map), title + ": sigma_z", ramp, 100.0 * lo, 100.0 * hi, "cm");
  return withLegend(framed, {{"unknown", kUnknown}, {"range shadow", kShadow, true}});
}

cv::Mat statePicture(const ElevationMap& map, const std::string& title) {
  const int rows = map.grid().rows, cols = map.grid().cols;
  cv::Mat cells(rows, cols, CV_8UC3);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c)
      cells.at<cv::Vec3b>(r, c) = map.stateAt(r, c) == CellState::Known ? kKnown : kUnseen;
  const cv::Mat picture = enlarge(cells, map);
  const int pad = 8, head = 28, width = std::max(picture.cols + 2 * pad, 360);
  cv::Mat canvas(picture.rows + head + 4, width, CV_8UC3, cv::Scalar(255, 255, 255));
  picture.copyTo(canvas(cv::Rect((width - picture.cols) / 2, head, picture.cols, picture.rows)));
  cv::putText(canvas, title + ": cell state", cv::Point(pad, 20), cv::FONT_HERSHEY_SIMPLEX, 0.5,
              cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  const long n = map.grid().cells();
  const auto entry = [&](const char* name, CellState s) {
    return std::string(name) + " " + percent(map.count(s), n);
  };
  return withLegend(canvas, {{entry("unseen", CellState::Unseen), kUnseen},
                             {entry("known", CellState::Known), kKnown},
                             {entry("range shadow", CellState::Shadow), kShadow, true}});
}

void checkTruth(const ElevationMap& map, const ElevationMap* truth) {
  if (truth && !truth->grid().sameAs(map.grid()))
    throw std::invalid_argument("map files: the ground truth is not on the map's grid");
}

}  // namespace

void writeMapFiles(const std::filesystem::path& dir, const std::string& stem, const ElevationMap& map,
                   const ElevationMap* truth, const std::string& title, const GeoFrame& geo) {
  checkTruth(map, truth);
  const auto& g = map.grid();
  writeGeoTiff(dir / (stem + "_elevation.tiff"), map.elevation(), g, geo);
  writeGeoTiff(dir / (stem + "_sigma.tiff"), map.sigma(), g, geo);
  writeGeoTiff(dir / (stem + "_shadow_ceiling.tiff"), map.shadowCeiling(), g, geo);
  const cv::Mat state(g.rows, g.cols, CV_8UC1, const_cast<std::uint8_t*>(map.state().data()));
  writePng(dir / (stem + "_state.png"), state);
  nlohmann::ordered_json meta;
  meta["x_min_m"] = g.x_min;
  meta["y_max_m"] = g.y_max;
  meta["cell_m"] = g.cell;
  meta["rows"] = g.rows;
  meta["cols"] = g.cols;
  // The map frame M (docs/conventions.md): T_WM's origin in the world and its yaw about z.
  const Eigen::Vector3d o = g.T_WM.translation();
  meta["frame"]["origin_m"] = {o.x(), o.y(), o.z()};
  meta["frame"]["yaw_deg"] = std::atan2(g.T_WM.linear()(1, 0), g.T_WM.linear()(0, 0)) * 180.0 / std::numbers::pi;
  writeJson(dir / (stem + "_meta.json"), meta);

  writePng(dir / (stem + "_elevation.png"), elevationPicture(map, title));
  writePng(dir / (stem + "_sigma.png"), sigmaPicture(map, title));
  writePng(dir / (stem + "_state_view.png"), statePicture(map, title));
  if (truth) writePng(dir / (stem + "_error.png"), errorPicture(map, *truth, title));
}

void writeCartesianFiles(const std::filesystem::path& dir, const std::string& stem, const ElevationMap& map,
                         const ElevationMap* truth, const std::string& title, const GeoFrame& geo) {
  checkTruth(map, truth);
  writeGeoTiff(dir / (stem + "_cartesian_elevation.tiff"), map.elevation(), map.grid(), geo);
  if (truth) writePng(dir / (stem + "_cartesian_error.png"), errorPicture(map, *truth, title));
}

}  // namespace ambler::eval
