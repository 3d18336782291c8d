#include "eval/score/map_metrics.hpp"

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <limits>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "eval/scenario/io.hpp"

namespace ambler::eval {

namespace {

using perception::CellState;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

double ratio(long num, long den) { return den > 0 ? double(num) / double(den) : kNaN; }

// Linear interpolation between order statistics (numpy's default); `sorted` is non-empty.
double quantile(const std::vector<double>& sorted, double p) {
  const double h = p * double(sorted.size() - 1);
  const auto lo = std::size_t(std::floor(h));
  if (lo + 1 >= sorted.size()) return sorted.back();
  return sorted[lo] + (h - double(lo)) * (sorted[lo + 1] - sorted[lo]);
}

// The sums of one range band while the cells are scanned.
struct BandSums {
  long visible = 0, known = 0, covered = 0, with_sigma = 0, in1 = 0;
  double sum2 = 0;
  std::vector<double> abs_err;
};

// The band of a cell whose true surface point is `range` m from the sensor.
std::size_t bandOf(double range) {
  std::size_t b = 0;
  while (b + 2 < kRangeBandEdgesM.size() && range >= kRangeBandEdgesM[b + 1]) ++b;
  return b;
}

nlohmann::ordered_json bandsJson(const std::vector<BandMetrics>& bands) {
  auto out = nlohmann::ordered_json::array();
  for (const auto& b : bands) {
    nlohmann::ordered_json j;
    j["range_m"] = {b.lo_m, jsonNumber(b.hi_m)};
    j["visible"] = b.visible;
    j["known"] = b.known;
    j["coverage"] = jsonNumber(b.coverage);
    j["rms_error_m"] = jsonNumber(b.rms_error_m);
    j["median_abs_error_m"] = jsonNumber(b.median_abs_error_m);
    j["within_1sigma"] = jsonNumber(b.within_1sigma);
    out.push_back(std::move(j));
  }
  return out;
}

}  // namespace

MapMetrics mapMetrics(const perception::ElevationMap& map, const perception::ElevationMap& truth_map,
                      const perception::Raster<std::uint8_t>& visibility, const Eigen::Vector3d* sensor_xyz) {
  const auto& grid = map.grid();
  const auto same = [&](const auto& m) { return m.rows() == grid.rows && m.cols() == grid.cols; };
  if (!truth_map.grid().sameAs(grid) || !same(visibility))
    throw std::invalid_argument("mapMetrics: the truth must be on the map's grid (frame, placement, size) and the "
                                "visibility " + std::to_string(grid.rows) + " x " + std::to_string(grid.cols));
  const perception::Raster<float>& truth = truth_map.elevation();

  MapMetrics m;
  m.cells = grid.cells();
  long covered = 0, shadow_hit = 0, with_sigma = 0, in1 = 0, in2 = 0;
  double sum2 = 0;
  std::vector<double> abs_err;
  std::vector<BandSums> bands(sensor_xyz ? kRangeBandEdgesM.size() - 1 : 0);
  for (int r = 0; r < grid.rows; ++r)
    for (int c = 0; c < grid.cols; ++c) {
      const auto state = map.stateAt(r, c);
      const auto vis = sim::Visibility(visibility(r, c));
      const bool known = state == CellState::Known;
      BandSums* band = nullptr;
      if (sensor_xyz && std::isfinite(truth(r, c))) {
        band = &bands[bandOf((grid.worldPoint(r, c, double(truth(r, c))) - *sensor_xyz).norm())];
        band->visible += vis == sim::Visibility::Visible;
        band->known += known;
        band->covered += known && vis == sim::Visibility::Visible;
      }
      m.known += known;
      m.shadow += state == CellState::Shadow;
      m.visible += vis == sim::Visibility::Visible;
      m.hidden += vis == sim::Visibility::Hidden;
      covered += known && vis == sim::Visibility::Visible;
      shadow_hit += state == CellState::Shadow && vis == sim::Visibility::Hidden;
      if (!known || !std::isfinite(truth(r, c))) continue;
      const double e = double(map.elevation()(r, c)) - double(truth(r, c));
      sum2 += e * e;
      abs_err.push_back(std::abs(e));
      if (band) {
        band->sum2 += e * e;
        band->abs_err.push_back(std::abs(e));
      }
      const double sigma = map.sigma()(r, c);
      if (!std::isfinite(sigma)) continue;
      ++with_sigma;
      in1 += std::abs(e) <= sigma;
      in2 += std::abs(e) <= 2 * sigma;
      m.known_in_shadow_above_3sigma += vis == sim::Visibility::Hidden && std::abs(e) > 3 * sigma;
      if (band) {
        ++band->with_sigma;
        band->in1 += std::abs(e) <= sigma;
      }
    }
  m.compared = long(abs_err.size());
  m.coverage = ratio(covered, m.visible);
  m.shadow_precision = ratio(shadow_hit, m.shadow);
  m.shadow_recall = ratio(shadow_hit, m.hidden);
  m.within_1sigma = ratio(in1, with_sigma);
  m.within_2sigma = ratio(in2, with_sigma);
  if (abs_err.empty()) {
    m.rms_error_m = m.median_abs_error_m = m.p95_abs_error_m = m.max_abs_error_m = kNaN;
  } else {
    std::sort(abs_err.begin(), abs_err.end());
    m.rms_error_m = std::sqrt(sum2 / double(abs_err.size()));
    m.median_abs_error_m = quantile(abs_err, 0.5);
    m.p95_abs_error_m = quantile(abs_err, 0.95);
    m.max_abs_error_m = abs_err.back();
  }
  for (std::size_t i = 0; i < bands.size(); ++i) {
    BandSums& s = bands[i];
    BandMetrics b;
    b.lo_m = kRangeBandEdgesM[i];
    b.hi_m = kRangeBandEdgesM[i + 1];
    b.visible = s.visible;
    b.known = s.known;
    b.coverage = ratio(s.covered, s.visible);
    b.within_1sigma = ratio(s.in1, s.with_sigma);
    if (s.abs_err.empty()) {
      b.rms_error_m = b.median_abs_error_m = kNaN;
    } else {
      std::sort(s.abs_err.begin(), s.abs_err.end());
      b.rms_error_m = std::sqrt(s.sum2 / double(s.abs_err.size()));
      b.median_abs_error_m = quantile(s.abs_err, 0.5);
    }
    m.bands.push_back(b);
  }
  return m;
}

namespace {

// The named figures of `m`, in the order given, into `j` (NaN → null): the three entries of
// metrics.json that a map's metrics fill differ only in which and in what order.
void putFigures(nlohmann::ordered_json& j, const MapMetrics& m, std::initializer_list<std::string_view> names) {
  for (const std::string_view name : names) {
    const std::string key(name);
    if (name == "cells") j[key] = m.cells;
    else if (name == "known") j[key] = m.known;
    else if (name == "shadow") j[key] = m.shadow;
    else if (name == "visible") j[key] = m.visible;
    else if (name == "hidden") j[key] = m.hidden;
    else if (name == "compared") j[key] = m.compared;
    else if (name == "known_in_shadow_above_3sigma") j[key] = m.known_in_shadow_above_3sigma;
    else if (name == "coverage") j[key] = jsonNumber(m.coverage);
    else if (name == "rms_error_m") j[key] = jsonNumber(m.rms_error_m);
    else if (name == "median_abs_error_m") j[key] = jsonNumber(m.median_abs_error_m);
    else if (name == "p95_abs_error_m") j[key] = jsonNumber(m.p95_abs_error_m);
    else if (name == "max_abs_error_m") j[key] = jsonNumber(m.max_abs_error_m);
    else if (name == "shadow_precision") j[key] = jsonNumber(m.shadow_precision);
    else if (name == "shadow_recall") j[key] = jsonNumber(m.shadow_recall);
    else if (name == "within_1sigma") j[key] = jsonNumber(m.within_1sigma);
    else if (name == "within_2sigma") j[key] = jsonNumber(m.within_2sigma);
    else throw std::logic_error("putFigures: no figure " + key);
  }
}

}  // namespace

nlohmann::ordered_json toJson(const MapMetrics& m, int view) {
  nlohmann::ordered_json j;
  j["view"] = view;
  putFigures(j, m, {"cells", "coverage", "rms_error_m", "median_abs_error_m", "shadow_precision", "shadow_recall",
                    "within_1sigma", "within_2sigma", "known", "max_abs_error_m", "p95_abs_error_m",
                    "known_in_shadow_above_3sigma", "shadow", "visible", "hidden", "compared"});
  if (!m.bands.empty()) j["by_range"] = bandsJson(m.bands);
  return j;
}

nlohmann::ordered_json cartesianJson(const MapMetrics& m, int view) {
  nlohmann::ordered_json j;
  j["view"] = view;
  putFigures(j, m, {"coverage", "rms_error_m", "median_abs_error_m", "cells", "known", "max_abs_error_m",
                    "p95_abs_error_m", "within_1sigma", "within_2sigma", "compared"});
  if (!m.bands.empty()) j["by_range"] = bandsJson(m.bands);
  return j;
}

nlohmann::ordered_json compositeJson(const MapMetrics& m, int views, const char* poses) {
  nlohmann::ordered_json j;
  j["views"] = views;
  j["poses"] = poses;
  putFigures(j, m, {"cells", "coverage", "rms_error_m", "median_abs_error_m", "within_1sigma", "within_2sigma",
                    "known", "shadow", "compared", "p95_abs_error_m", "max_abs_error_m"});
  return j;
}

}  // namespace ambler::eval
