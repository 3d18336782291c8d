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
  int r0 = 0, c0 = 0;   // the top-left pixel of the 2×2 cell
  double delta = 0, s = 0, rho = 0;
  double cf = 0;          // the column coordinate (θ − θ0)/Δθ
  double fr = 0, fc = 0;  // the position inside the cell: bilinear weights (1−fr)(1−fc), (1−fr)fc, …
};

namespace locus {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr std::uint8_t kAllReturned = 16;

}  // namespace locus

}  // namespace ambler::perception
