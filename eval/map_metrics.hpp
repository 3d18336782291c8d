#pragma once
// Figures of merit of an elevation map against ground truth (the "map" and "map_cartesian" keys of
// SCENARIO.md's metrics.json). A figure whose population is empty is NaN, written as JSON null.
#include <nlohmann/json.hpp>

#include "perception/elevation_map.hpp"
#include "sim/ground_truth.hpp"

namespace ambler::eval {

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
};

// `truth` (true elevation at each cell centre, NaN where no surface) and `visibility` must be on
// the map's grid. Throws std::invalid_argument when their sizes differ from the map's.
MapMetrics mapMetrics(const perception::ElevationMap& map, const sim::ElevationRaster& truth,
                      const sim::VisibilityRaster& visibility);

// The "map" entry of metrics.json: view, cells, coverage, rms_error_m, median_abs_error_m,
// shadow_precision, shadow_recall, within_1sigma, within_2sigma, then known, max_abs_error_m,
// p95_abs_error_m, known_in_shadow_above_3sigma, shadow, visible, hidden, compared. NaN → null.
nlohmann::ordered_json toJson(const MapMetrics& m, int view);

// The "map_cartesian" entry: view, coverage, rms_error_m, median_abs_error_m, then cells, known,
// max_abs_error_m, p95_abs_error_m, within_1sigma, within_2sigma, compared. NaN → null.
nlohmann::ordered_json cartesianJson(const MapMetrics& m, int view);

}  // namespace ambler::eval
