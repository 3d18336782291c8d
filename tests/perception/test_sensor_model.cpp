// The sensor model's σ_ρ against its definition, the footprint's default, a mixed pixel's range
// and its inverse, and validate() refusing each out-of-range field by name.
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

// A mixed pixel's range is the power-weighted mean of its two surfaces' (power ∝ 1/ρ²):
// mixedRange against that mean written out, nearFraction its inverse, both ends exact.
TEST(SensorModel, MixedRangeAndItsInverse) {
  for (double rho_n : {2.0, 5.6, 12.0})
    for (double jump : {0.05, 0.4, 3.0})
      for (double A : {0.0, 0.125, 0.25, 0.5, 0.75, 0.875, 1.0}) {
        const double rho_f = rho_n + jump;
        const double power = A / (rho_n * rho_n) + (1 - A) / (rho_f * rho_f);
        const double mean = (A / rho_n + (1 - A) / rho_f) / power;
        const double rho_m = SensorModel::mixedRange(A, rho_n, rho_f);
        EXPECT_NEAR(rho_m, mean, 1e-12 * rho_f);
        EXPECT_GE(rho_m, rho_n - 1e-12);
        EXPECT_LE(rho_m, rho_f + 1e-12);
        // dA/dρ_m ≈ 1/jump: a relative error of 1e-12 in ρ_m moves A by about 1e-12·ρ/jump.
        EXPECT_NEAR(SensorModel::nearFraction(rho_m, rho_n, rho_f), A, 1e-9 * rho_f / jump);
      }
  EXPECT_DOUBLE_EQ(SensorModel::nearFraction(5.0, 5.0, 6.0), 1.0);
  EXPECT_DOUBLE_EQ(SensorModel::nearFraction(6.0, 5.0, 6.0), 0.0);
}

// The edge's offset in a uniform disk: the inverse of the segment's area fraction
// F(s) = 1/2 + (s·√(1 − s²) + asin s)/π, and the chord's closed forms at s = 0 and s = ±1/2
// (a chord at half the radius cuts off (π/3 − √3/4)/π of the disk).
TEST(SensorModel, DiskEdgeOffsetInvertsTheSegmentArea) {
  for (double s = -1.0; s <= 1.0; s += 0.0625) {
    const double F = 0.5 + (s * std::sqrt(1 - s * s) + std::asin(s)) / kPi;
    EXPECT_NEAR(SensorModel::diskEdgeOffset(F), s, 1e-9) << s;
  }
  EXPECT_NEAR(SensorModel::diskEdgeOffset(0.5), 0.0, 1e-12);
  const double cap = (kPi / 3 - std::sqrt(3.0) / 4) / kPi;
  EXPECT_NEAR(SensorModel::diskEdgeOffset(cap), -0.5, 1e-9);
  EXPECT_NEAR(SensorModel::diskEdgeOffset(1 - cap), 0.5, 1e-9);
  // Clamped. F is flat at ±1 (1 − F(1 − ε) ≈ 0.6·ε^1.5, below a double's resolution for
  // ε < 1e-10), so the ends are found to that.
  EXPECT_NEAR(SensorModel::diskEdgeOffset(-0.3), -1.0, 1e-9);
  EXPECT_NEAR(SensorModel::diskEdgeOffset(1.7), 1.0, 1e-9);
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
