#include "eval/score/metrics.hpp"

#include <cmath>

namespace ambler::eval {

ScanMetrics scanMetrics(const sim::Scan& scan, const perception::SensorModel& config) {
  ScanMetrics m;
  const auto& img = scan.image;
  m.rays = long(img.rows()) * img.cols();
  long valid = 0, truth = 0, both = 0, wrapped = 0;
  double sum2 = 0;
  for (int r = 0; r < img.rows(); ++r)
    for (int c = 0; c < img.cols(); ++c) {
      const float t = scan.true_range(r, c);
      truth += std::isfinite(t);
      if (!img.valid(r, c)) continue;
      ++valid;
      if (!std::isfinite(t)) continue;
      ++both;
      double e = double(img.range(r, c)) - t;
      if (config.ambiguity_m > 0) {
        wrapped += t >= config.ambiguity_m;
        e -= config.ambiguity_m * std::nearbyint(e / config.ambiguity_m);
      }
      sum2 += e * e;
      m.range_error_max_abs_m = std::max(m.range_error_max_abs_m, std::abs(e));
    }
  if (m.rays) {
    m.valid_fraction = double(valid) / m.rays;
    m.true_hit_fraction = double(truth) / m.rays;
  }
  if (both) {
    m.range_error_rms_m = std::sqrt(sum2 / both);
    m.wrapped_fraction = double(wrapped) / both;
  }
  return m;
}

nlohmann::ordered_json toJson(const ScanMetrics& m, int view) {
  nlohmann::ordered_json j;
  j["view"] = view;
  j["rays"] = m.rays;
  j["valid_fraction"] = m.valid_fraction;
  j["range_error_rms_m"] = m.range_error_rms_m;
  j["range_error_max_abs_m"] = m.range_error_max_abs_m;
  j["true_hit_fraction"] = m.true_hit_fraction;
  j["wrapped_fraction"] = m.wrapped_fraction;
  return j;
}

}  // namespace ambler::eval
