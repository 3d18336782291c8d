#pragma once
// Occluding edges in a range image by Graduated Non-Convexity (Blake & Zisserman's weak membrane),
// and the unwrapping of ranges folded by the ambiguity interval. Onboard code: no simulator here.
// Design and its reasons: docs/range_edges.md.
#include <Eigen/Core>
#include <cstdint>

#include "perception/raster.hpp"
#include "perception/range_image.hpp"
#include "perception/sensor_model.hpp"

namespace ambler::perception {

// The detector's own parameters; the sensor whose σ_ρ (SensorModel::rangeSigma) sets the
// membrane's noise is an argument of detectRangeEdges.
struct GncConfig {
  // The weak membrane runs on inverse range u = 1/ρ, in units of its noise σ_u = σ(ρ)/ρ², with
  // each link's local trend removed: E = Σ (f − u)²/σ_u² + Σ g(k·(f_j − f_i − s_ij)), k = 1/σ_u,
  // g the truncated quadratic λ²t² capped at α = λh0²/2 (Blake & Zisserman's notation).
  double lambda = 1.0;  // membrane scale, pixels
  double h0 = 6.0;      // contrast threshold (σ units): the smallest jump beyond the trend to break
  int sweeps = 3;       // red-black SOR sweeps at each step of the p-sequence 1, 1/2, … 1/(2λ)
  // The surface's own departure from the local trend between neighbouring pixels (rough ground
  // is not linear in 1/ρ from pixel to pixel), m: added to σ_ρ in quadrature, so that a
  // noise-free sensor does not break links at every pebble (docs/range_edges.md).
  double surface_sigma_m = 0.02;
  // Occlusions too shallow to matter (docs/range_edges.md, "Shallow occlusions"): a broken link
  // stays broken only where the depth it can hide, J·sin β (J its jump beyond the trend of the
  // links along its line, over the link alone or with a neighbour, as a mixed pixel splits a jump;
  // β the angle at which that trend meets the rays), exceeds occlusion_depth_k times the ground's
  // own departure from a straight line over the gap, surface_sigma_m·(L/surface_scale_m)^
  // surface_hurst (fBm), L the ground visible ground would span there. 0: off (every link the
  // membrane breaks stays broken).
  double occlusion_depth_k = 0.0;
  double surface_scale_m = 0.1;
  double surface_hurst = 0.7;
  // The edge continued along its line from the links the membrane broke (docs/range_edges.md,
  // "Continuing an edge"), on a link's raw excess beyond the trend in the same σ units as h0,
  // of the broken link's sign; 0 switches a rule off.
  double bridge_h = 3.0;  // a gap of up to bridge_span links with broken links on both sides
  int bridge_span = 2;
  double grow_h = 4.5;    // beside a broken link, repeatedly
};

// The edge mask's bits. A pixel that touches a depth discontinuity (both pixels either side of it)
// has kEdgePixel, and which way its broken links run: across scanlines (to the pixel above or
// below) and across columns (to the pixel left or right). A mask made elsewhere may set
// kEdgePixel alone, "direction unknown": readers then take both directions.
constexpr std::uint8_t kEdgePixel = 1, kEdgeAcrossRows = 2, kEdgeAcrossCols = 4;
// Whether a mask value is an edge pixel with a break across `direction` (kEdgeAcrossRows or
// kEdgeAcrossCols), a direction-unknown edge pixel counting for both.
constexpr bool edgeBreaksAcross(std::uint8_t bits, std::uint8_t direction) {
  return (bits & direction) || (bits && !(bits & (kEdgeAcrossRows | kEdgeAcrossCols)));
}

// The edges of `image`: non-zero where a pixel touches a depth discontinuity (kEdgePixel and its
// direction bits), else 0. NaN or non-positive pixels carry no data: their links neither smooth
// nor break, so a valid pixel next to an invalid one is not an edge by itself. `sensor` is the one
// that took the image (its σ_ρ is the membrane's noise). Throws std::invalid_argument for a config
// or sensor out of range.
Raster<std::uint8_t> detectRangeEdges(const RangeImage& image, const SensorModel& sensor, const GncConfig& config = {});

// The broken links behind detectRangeEdges: right(r, c) = 1 where the link joining (r, c) and
// (r, c + 1) is broken, down(r, c) = 1 where the link joining (r, c) and (r + 1, c) is (the last
// column's right links and the last row's down links do not exist and are 0).
struct RangeLinks {
  Raster<std::uint8_t> right, down;
};
RangeLinks detectBrokenLinks(const RangeImage& image, const SensorModel& sensor, const GncConfig& config = {});

// Unwraps ranges folded by the ambiguity interval A, in place. The seed is the longest continuous
// stretch of the lowest row that has one (at least three pixels, each continuous with the linear
// prediction from the two before it), taken as unfolded (ρ < A): the near field. From it, each
// pixel takes the multiple of A continuous with a linear prediction from the two decided pixels
// before it in its column (rows upwards from the seed row, downwards below it), or else from two
// decided pixels beside it in its row; failing that, across a depth discontinuity, the one multiple
// that changes the predicted range by at most a factor 1.5. A pixel no neighbour decides becomes
// NaN, never a wrapped range. Returns the number of pixels that received a non-zero multiple of A.
// The interval and the noise come from `sensor`. Throws std::invalid_argument if
// sensor.ambiguity_m is not positive.
long unwrapRanges(RangeImage& image, const SensorModel& sensor);

}  // namespace ambler::perception
