#pragma once
// Figures of merit of an elevation map against ground truth (the "map" and "map_cartesian" keys of
// metrics.json, docs/scenario.md). A figure whose population is empty is NaN, written as JSON null.
#include <Eigen/Core>
#include <array>
#include <limits>
#include <nlohmann/json.hpp>
#include <vector>

#include "perception/elevation_map.hpp"
#include "sim/ground_truth.hpp"

namespace ambler::eval {

// Range bands of the per-band figures: the 3-D distance from the sensor to the true surface point
// at the cell centre, [0, 6), [6, 9), [9, 12), [12, 16), [16, ∞) m. A cell without a true surface
// (NaN truth) is in no band.
inline constexpr std::array<double, 6> kRangeBandEdgesM{0, 6, 9, 12, 16,
                                                        std::numeric_limits<double>::infinity()};

// The figures of MapMetrics restricted to the cells of one range band.
struct BandMetrics {
  double lo_m = 0, hi_m = 0;  // [lo, hi); hi is +∞ for the last band
  long visible = 0;           // cells of the band whose true surface the sensor sees
  long known = 0;             // cells of the band the map reports Known: the error figures' population
  double coverage = 0;        // Known ∩ visible / visible
  double rms_error_m = 0;
  double median_abs_error_m = 0;
  double within_1sigma = 0;   // of the compared cells with a finite σ_z
};

struct MapMetrics {
  long cells = 0;     // cells of the region (rows · cols)
  long known = 0;     // cells the map reports Known
  long shadow = 0;    // cells the map reports Shadow
  long visible = 0;   // cells whose true surface the sensor sees (Visibility::Visible)
  long hidden = 0;    // cells in the field of view hidden by other terrain (Visibility::Hidden)
  long compared = 0;  // Known cells with a finite truth: the population of the error figures

  // Known ∩ visible / visible.
  double coverage = 0;
  // Over the `compared` cells, error = map − truth. Median and 95th percentile interpolate linearly
  // between order statistics (numpy's default), so the median is the exact one.
  double rms_error_m = 0;
  double median_abs_error_m = 0;
  double p95_abs_error_m = 0;
  double max_abs_error_m = 0;
  // Shadow ∩ hidden / shadow, and Shadow ∩ hidden / hidden.
  double shadow_precision = 0;
  double shadow_recall = 0;
  // Of the compared cells with a finite σ_z: the fraction with |error| ≤ σ_z, ≤ 2σ_z.
  double within_1sigma = 0;
  double within_2sigma = 0;
  // Truly hidden cells reported Known with |error| > 3σ_z: elevations made up across a gap.
  long known_in_shadow_above_3sigma = 0;
  // Per range band (kRangeBandEdgesM), only when mapMetrics was given the sensor's position.
  std::vector<BandMetrics> bands;
};

// `truth` (true elevation at each cell centre, NaN where no surface) and `visibility` must be on
// the map's grid. With `sensor_xyz` (the sensor's origin in the world) the figures are also
// broken down by range band into `bands`. Throws std::invalid_argument when the rasters' sizes
// differ from the map's.
MapMetrics mapMetrics(const perception::ElevationMap& map, const perception::ElevationMap& truth,
                      const perception::Raster<std::uint8_t>& visibility, const Eigen::Vector3d* sensor_xyz = nullptr);

// The "map" entry of metrics.json: view, cells, coverage, rms_error_m, median_abs_error_m,
// shadow_precision, shadow_recall, within_1sigma, within_2sigma, then known, max_abs_error_m,
// p95_abs_error_m, known_in_shadow_above_3sigma, shadow, visible, hidden, compared, and when
// there are bands "by_range": [{range_m: [lo, hi or null], visible, known, coverage,
// rms_error_m, median_abs_error_m, within_1sigma}, ...]. NaN → null.
nlohmann::ordered_json toJson(const MapMetrics& m, int view);

// The "map_cartesian" entry: view, coverage, rms_error_m, median_abs_error_m, then cells, known,
// max_abs_error_m, p95_abs_error_m, within_1sigma, within_2sigma, compared, then "by_range" as
// above when there are bands. NaN → null.
nlohmann::ordered_json cartesianJson(const MapMetrics& m, int view);

// The "composite" entry (merge stage): views, poses, cells, coverage, rms_error_m,
// median_abs_error_m, within_1sigma, within_2sigma, then known, shadow, compared,
// p95_abs_error_m, max_abs_error_m. NaN → null.
nlohmann::ordered_json compositeJson(const MapMetrics& m, int views, const char* poses);

}  // namespace ambler::eval
