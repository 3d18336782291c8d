#include "perception/sensor_model.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

namespace ambler::perception {

double SensorModel::mixedRange(double near_fraction, double rho_near, double rho_far) {
  const double a = near_fraction, wn = a / rho_near, wf = (1 - a) / rho_far;
  return (wn + wf) / (wn / rho_near + wf / rho_far);
}

double SensorModel::nearFraction(double rho_mixed, double rho_near, double rho_far) {
  // ρ_m·(A·a² + (1 − A)·b²) = A·a + (1 − A)·b with a = 1/ρ_n, b = 1/ρ_f, solved for A.
  const double a = 1 / rho_near, b = 1 / rho_far;
  return b * (1 - rho_mixed * b) / ((a - b) * (rho_mixed * (a + b) - 1));
}

double SensorModel::diskEdgeOffset(double near_fraction) {
  const double A = std::clamp(near_fraction, 0.0, 1.0);
  // F is increasing on [−1, 1]: bisection to below 1e-12.
  double lo = -1, hi = 1;
  for (int i = 0; i < 42; ++i) {
    const double s = 0.5 * (lo + hi);
    const double F = 0.5 + (s * std::sqrt(1 - s * s) + std::asin(s)) / std::numbers::pi;
    (F < A ? lo : hi) = s;
  }
  return 0.5 * (lo + hi);
}

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
