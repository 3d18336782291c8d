// The sensor model's σ_ρ against its definition, the footprint's default, and validate() refusing
// each out-of-range field by name.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>

#include "perception/sensor_model.hpp"

namespace ambler::perception {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kPi = std::numbers::pi;

// rangeVariance = (k·ρ²)² + max(q, 1 mm)²/12, evaluated with the header's operations in the
// header's order, so the values must agree bit for bit.
TEST(SensorModel, RangeVarianceIsNoisePlusQuantisationExactly) {
  for (double k : {0.0, 3e-4, 1e-3, 0.02})
    for (double q : {0.0, 5e-4, 1e-3, 0.0762, 0.3})
      for (double rho : {0.0, 0.5, 3.0, 19.5, 40.0}) {
        SensorModel s;
        s.noise_k = k;
        s.quantization_m = q;
        const double n = k * rho * rho;
        const double q_used = std::max(q, 1e-3);
        const double expected = n * n + q_used * q_used / 12.0;
        EXPECT_EQ(s.noiseSigma(rho), n) << k << " " << q << " " << rho;
        EXPECT_EQ(s.quantizationVariance(), q_used * q_used / 12.0) << q;
        EXPECT_EQ(s.rangeVariance(rho), expected) << k << " " << q << " " << rho;
        EXPECT_EQ(s.rangeSigma(rho), std::sqrt(expected));
      }
  // The floor: a noise-free, unquantised sensor still has σ = 1 mm/√12 (to the last bits of the
  // square root).
  SensorModel exact;
  exact.noise_k = 0, exact.quantization_m = 0;
  EXPECT_EQ(SensorModel::kQuantizationFloor_m, 1e-3);
  EXPECT_NEAR(exact.rangeSigma(25.0), 1e-3 / std::sqrt(12.0), 1e-18);
  // The ERIM's defaults: k = 3e-4, one count of 7.62 cm; at 10 m σ² = 0.03² + 0.0762²/12.
  const SensorModel erim;
  EXPECT_EQ(erim.noise_k, 3e-4);
  EXPECT_EQ(erim.quantization_m, 0.0762);
  EXPECT_NEAR(erim.rangeVariance(10.0), 0.03 * 0.03 + 0.0762 * 0.0762 / 12, 1e-17);
}

TEST(SensorModel, BeamDivergenceDefaultsToTheLargerPixelSpacing) {
  SensorModel s;  // 30° over 64 rows, 80° over 256 columns: 0.469° and 0.3125°
  EXPECT_EQ(s.beam_divergence_rad, 0.0);
  EXPECT_EQ(s.beamDivergence(), s.fov_v_rad / 64);
  s.rows = 200;  // now the columns are wider apart: 0.15° < 0.3125°
  EXPECT_EQ(s.beamDivergence(), s.fov_h_rad / 256);
  s.beam_divergence_rad = 0.01;  // an explicit footprint is used as given
  EXPECT_EQ(s.beamDivergence(), 0.01);
}

// The message of the invalid_argument validate throws for `s`, or "" if it accepts it.
std::string rejection(const SensorModel& s) {
  try {
    validate(s);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

TEST(SensorModel, ValidateNamesEachFieldOutOfRange) {
  EXPECT_EQ(rejection(SensorModel{}), "");
  struct Case {
    const char* field;
    std::function<void(SensorModel&)> spoil;
  };
  const Case cases[] = {
      {"rows", [](SensorModel& s) { s.rows = 0; }},
      {"rows", [](SensorModel& s) { s.rows = -3; }},
      {"cols", [](SensorModel& s) { s.cols = 0; }},
      {"fov_v_rad", [](SensorModel& s) { s.fov_v_rad = 0; }},
      {"fov_v_rad", [](SensorModel& s) { s.fov_v_rad = kPi; }},
      {"fov_v_rad", [](SensorModel& s) { s.fov_v_rad = kNaN; }},
      {"fov_h_rad", [](SensorModel& s) { s.fov_h_rad = -0.1; }},
      {"fov_h_rad", [](SensorModel& s) { s.fov_h_rad = kPi; }},
      {"fov_h_rad", [](SensorModel& s) { s.fov_h_rad = kNaN; }},
      {"noise_k", [](SensorModel& s) { s.noise_k = -1e-9; }},
      {"noise_k", [](SensorModel& s) { s.noise_k = kNaN; }},
      {"quantization_m", [](SensorModel& s) { s.quantization_m = -0.01; }},
      {"quantization_m", [](SensorModel& s) { s.quantization_m = kNaN; }},
      {"ambiguity_m", [](SensorModel& s) { s.ambiguity_m = -19.5; }},
      {"ambiguity_m", [](SensorModel& s) { s.ambiguity_m = kNaN; }},
      {"max_range_m", [](SensorModel& s) { s.max_range_m = 0; }},
      {"max_range_m", [](SensorModel& s) { s.max_range_m = kNaN; }},
      {"beam_divergence_rad", [](SensorModel& s) { s.beam_divergence_rad = -1e-3; }},
      {"beam_divergence_rad", [](SensorModel& s) { s.beam_divergence_rad = kNaN; }},
      {"dropout", [](SensorModel& s) { s.dropout = -0.1; }},
      {"dropout", [](SensorModel& s) { s.dropout = 1.0; }},
      {"dropout", [](SensorModel& s) { s.dropout = kNaN; }},
  };
  for (const Case& c : cases) {
    SensorModel s;
    c.spoil(s);
    const std::string what = rejection(s);
    EXPECT_NE(what.find(c.field), std::string::npos) << c.field << ": \"" << what << "\"";
  }
  // The ends that are inside the ranges are accepted.
  SensorModel edge;
  edge.rows = edge.cols = 1;
  edge.noise_k = edge.quantization_m = edge.ambiguity_m = 0;
  edge.beam_divergence_rad = 0;
  edge.dropout = 0;
  edge.fov_v_rad = edge.fov_h_rad = std::nextafter(kPi, 0.0);
  edge.max_range_m = 1e-6;
  EXPECT_EQ(rejection(edge), "");
}

}  // namespace
}  // namespace ambler::perception
