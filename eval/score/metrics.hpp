#pragma once
// Figures of merit of each stage against ground truth (docs/scenario.md, "metrics.json").
#include <nlohmann/json.hpp>

#include "sim/erim_scanner.hpp"

namespace ambler::eval {

struct ScanMetrics {
  long rays = 0;
  double valid_fraction = 0;      // pixels with a return
  double true_hit_fraction = 0;   // pixels whose central ray meets a surface
  // RMS of (returned − true range) over pixels with both, the difference taken modulo the
  // ambiguity interval when wrapping is on (the sensor's accuracy, not its ambiguity).
  double range_error_rms_m = 0;
  double range_error_max_abs_m = 0;
  double wrapped_fraction = 0;    // returns whose true range is beyond the ambiguity interval
};

ScanMetrics scanMetrics(const sim::Scan& scan, const perception::SensorModel& sensor);
nlohmann::ordered_json toJson(const ScanMetrics& m, int view);

}  // namespace ambler::eval
