#pragma once
// Internal to the locus mapper (perception/locus_mapper.cpp, perception/locus_tables.cpp): one
// evaluation of Δ, and the constants of the per-image tables.
#include <cstdint>
#include <limits>

namespace ambler::perception {

// One evaluation of Δ = ρ_l − I at a scan angle: where it looked and with what weights.
struct LocusSample {
  bool valid = false;   // the line is in front of the sensor, inside the image, all pixels returned
  unsigned edges = 0;   // bit k: pixel k (of the 2×2 cell, weighted) is an occluding-edge pixel
  int r0, c0;           // the top-left pixel of the 2×2 cell
  double delta, s, rho;
  double column;        // the fractional column coordinate (θ − θ0)/Δθ
  double fr, fc;        // the fractions of a pixel past (r0, c0): bilinear weights (1−fr)(1−fc), (1−fr)fc, …
  // (The numbers are set wherever `valid` is; left uninitialised, as they are written in the hot
  // loop of every search.)
};

namespace locus {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr std::uint8_t kAllReturned = 16;
constexpr int kRoughnessSteps = 1024;  // intervals of the tabulated fBm interpolation factor
// 1/n! factors of sinCosNear's Taylor series (multiplications: a division costs several).
constexpr double kInv6 = 1.0 / 6, kInv12 = 1.0 / 12, kInv20 = 1.0 / 20, kInv30 = 1.0 / 30;
// Scanlines the search walks from a neighbouring cell's bracket (the hint) before it walks down the
// line from its top instead.
constexpr int kHintSteps = 3;

}  // namespace locus

}  // namespace ambler::perception
