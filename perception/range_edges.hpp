#pragma once
// Occluding edges in a range image by Graduated Non-Convexity (Blake & Zisserman's weak membrane),
// and the unwrapping of ranges folded by the ambiguity interval. Onboard code: no simulator here.
#include <Eigen/Core>
#include <cstdint>

#include "perception/range_image.hpp"

namespace ambler::perception {

// 1 where a pixel touches a depth discontinuity (both pixels either side of it), else 0.
using EdgeMask = Eigen::Matrix<std::uint8_t, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

struct GncConfig {
  // Weak membrane energy E = Σ (f − d)² + Σ λ²·g(∇f) with the truncated quadratic g; a
  // discontinuity costs α = λ²·h0², so h0 is the smallest jump (in metres of range, scaled
  // by range: see the docs) that is worth a break.
  double lambda = 4.0;
  double h0 = 0.25;
  bool relative = true;   // measure jumps relative to range (a jump of h0·ρ at range ρ)
  int iterations_per_p = 20;  // SOR sweeps at each step of the p-sequence
  int p_steps = 8;        // p from 1 down to 1/(2λ) geometrically
};

// The edges of `image` (NaN pixels neither smooth nor break anything; a valid pixel next to an
// invalid one is not an edge by itself).
EdgeMask detectRangeEdges(const RangeImage& image, const GncConfig& config = {});

// Unwraps ranges folded by the ambiguity interval A: scanline by scanline from the near field
// (the bottom row, looking down), adds multiples of A where continuity with the pixel below (or
// beside) demands it. Pixels whose fold cannot be decided from a continuous neighbour become NaN.
// Returns the number of pixels unwrapped.
long unwrapRanges(RangeImage& image, double ambiguity_m);

}  // namespace ambler::perception
