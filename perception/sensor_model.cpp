#include "perception/sensor_model.hpp"

#include <numbers>
#include <stdexcept>
#include <string>

namespace ambler::perception {

void validate(const SensorModel& s) {
  const auto require = [](bool ok, const char* what) {
    if (!ok) throw std::invalid_argument(std::string("SensorModel: ") + what);
  };
  require(s.rows >= 1 && s.cols >= 1, "rows and cols must be positive");
  require(s.fov_v_rad > 0 && s.fov_v_rad < std::numbers::pi, "fov_v_rad out of (0, pi)");
  require(s.fov_h_rad > 0 && s.fov_h_rad < std::numbers::pi, "fov_h_rad out of (0, pi)");
  require(s.noise_k >= 0 && s.quantization_m >= 0 && s.ambiguity_m >= 0,
          "noise_k, quantization_m and ambiguity_m must be non-negative");
  require(s.max_range_m > 0, "max_range_m must be positive");
  require(s.beam_divergence_rad >= 0, "beam_divergence_rad must be non-negative");
  require(s.dropout >= 0 && s.dropout < 1, "dropout must be in [0, 1)");
}

}  // namespace ambler::perception
