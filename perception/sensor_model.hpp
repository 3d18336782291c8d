#pragma once
// The one model of the range sensor: its geometry (eq. 1's pixel grid), what it measures (range
// noise σ = k·ρ², 8-bit counts, the ambiguity interval, a maximum range) and what the emulator
// reproduces of its beam (mixed pixels, dropouts). The emulator, the scenario reader, the locus
// mapper, the edge detector and the unwrapper all take this type; σ_ρ is defined here and nowhere
// else (docs/conventions.md, "The sensor model").
#include <cmath>
#include <numbers>

namespace ambler::perception {

struct SensorModel {
  // Geometry: rows × cols pixel centres spread evenly over the field of view, centred on the
  // boresight (rowAngle, colAngle in sensor_geometry.hpp).
  int rows = 64;
  int cols = 256;
  double fov_v_rad = 30.0 * std::numbers::pi / 180.0;
  double fov_h_rad = 80.0 * std::numbers::pi / 180.0;

  // The measurement: ρ_reported = wrap(quantise(ρ + N(0, (k·ρ²)²))).
  double noise_k = 0.0003;         // σ of the Gaussian range noise = noise_k·ρ² (ρ in m); 0 = off
  double quantization_m = 0.0762;  // one range count; 0 = off
  double ambiguity_m = 19.5;       // ranges wrap modulo this; 0 = off
  double max_range_m = 40.0;       // no return beyond

  // The beam, as the emulator reproduces it (the onboard code does not rely on these).
  bool mixed_pixels = true;          // the footprint straddles surfaces at depth discontinuities
  double beam_divergence_rad = 0.0;  // the footprint's full angle; 0 = the larger pixel spacing
  double dropout = 0.0;              // probability that a pixel returns nothing

  // The noise model's floor: a count of at least 1 mm, so that a noise-free, unquantised sensor
  // still has a σ (its ranges pass through float rounding and the emulator's ray casts) and every
  // test in σ units stays finite.
  static constexpr double kQuantizationFloor_m = 1e-3;

  // σ of the Gaussian range noise at range ρ: k·ρ².
  double noiseSigma(double rho) const { return noise_k * rho * rho; }
  // The variance of one count's rounding error, uniform over a count: q²/12 with q at least the
  // floor.
  double quantizationVariance() const {
    const double q = quantization_m > kQuantizationFloor_m ? quantization_m : kQuantizationFloor_m;
    return q * q / 12.0;
  }
  // The variance of a reported range about the true one: the two independent terms added,
  // (k·ρ²)² + q²/12. Every σ_ρ in the project comes from here.
  double rangeVariance(double rho) const {
    const double n = noiseSigma(rho);
    return n * n + quantizationVariance();
  }
  double rangeSigma(double rho) const { return std::sqrt(rangeVariance(rho)); }

  // A mixed pixel (docs/erim.md, "Footprint"): a fraction A of the footprint on a near surface at
  // range ρ_n, the rest on a far one at ρ_f, reports the power-weighted mean (power ∝ 1/ρ²)
  //   ρ_m = (A/ρ_n + (1 − A)/ρ_f) / (A/ρ_n² + (1 − A)/ρ_f²).
  static double mixedRange(double near_fraction, double rho_near, double rho_far);
  // Its inverse, the A that gives ρ_m (not clamped: noise may put it outside [0, 1]).
  static double nearFraction(double rho_mixed, double rho_near, double rho_far);
  // The footprint taken as a uniform disk: the offset s ∈ [−1, 1], in footprint radii from its
  // centre towards the far side, of a straight edge that leaves the fraction A of the disk's area
  // on the near side — the inverse of F(s) = 1/2 + (s·√(1 − s²) + asin s)/π (A clamped to [0, 1]).
  static double diskEdgeOffset(double near_fraction);
  // The emulator samples the disk by a 7-point cubature (centre 1/4, six on a ring 1/8 each), whose
  // near fraction for a straight edge departs from the disk's F(s) by at most 1/4: an edge along
  // the ring's diameter through two of its points switches the centre and those two together (A
  // jumps from 1/4 to 3/4 where F passes 1/2). docs/locus.md, "Range shadows".
  static constexpr double kCubatureFractionError = 0.25;

  // The footprint's full angle actually used (resolves the 0 default).
  double beamDivergence() const {
    if (beam_divergence_rad > 0) return beam_divergence_rad;
    const double v = fov_v_rad / rows, h = fov_h_rad / cols;
    return v > h ? v : h;
  }
};

// Throws std::invalid_argument naming the field of the first value out of range: rows and cols
// positive, fields of view in (0, π), noise_k, quantization_m and ambiguity_m non-negative,
// max_range_m positive, beam_divergence_rad non-negative, dropout in [0, 1).
void validate(const SensorModel& sensor);

}  // namespace ambler::perception
