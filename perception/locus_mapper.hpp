#pragma once
// The generalized locus algorithm (paper §3.1 and footnote 2): the intersection of any line in
// space with the surface seen in a range image, found in image space — no Cartesian resampling,
// any resolution, any sensor orientation. Range shadows (§3.2) come from an edge mask of the
// image; each result carries σ along the line from the sensor's noise model (§3.3, docs/locus.md).
#include <Eigen/Geometry>
#include <limits>
#include <vector>

#include "perception/elevation_map.hpp"
#include "perception/range_edges.hpp"
#include "perception/range_image.hpp"

namespace ambler::perception {

struct LocusConfig {
  double epsilon_rad = 1e-5;  // the search stops when the bracket in φ is narrower than this
  bool bisection = false;     // true: plain bisection as in the paper; false: Illinois steps
                              // (the same bracket and stopping rule, fewer evaluations)
  double noise_k = 3e-4;      // σ_ρ = k·ρ² of the sensor, for σ along the line
  double quantization_m = 0.0762;  // adds q²/12 to the range variance; 0 = none
  double z_margin_m = 1.0;    // lines are searched within the returns' bounds ± this margin
  bool roughness = true;      // σ includes the surface's roughness between pixels (docs/locus.md)
  double roughness_hurst = 0.7;  // H of the fBm assumed between pixels (0.5: Brownian)
};

struct LocusHit {
  CellState state = CellState::Unseen;
  Eigen::Vector3d point = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  double s = std::numeric_limits<double>::quiet_NaN();      // position along the line
  double sigma = std::numeric_limits<double>::quiet_NaN();  // σ of s (σ_z for vertical lines)
  double phi = 0, theta = 0, rho = 0;                       // where the line met the image
  int evaluations = 0;                                      // Δ evaluations spent
};

class LocusMapper {
 public:
  // `image` (and `edges`, if given: same size) must outlive the mapper. Throws
  // std::invalid_argument if the image's scan angles are not evenly spaced or sizes differ.
  LocusMapper(const RangeImage& image, const EdgeMask* edges, const LocusConfig& config = {});

  // f(u, v): where the line u + s·v (world frame, v unit, pointing away from the ground: the
  // search runs from +v towards −v) meets the surface the sensor saw. Thread-safe.
  LocusHit intersect(const Eigen::Vector3d& u, const Eigen::Vector3d& v) const;

  // The elevation at any (x, y): the vertical line through it.
  LocusHit elevationAt(double x, double y) const {
    return intersect({x, y, 0.0}, Eigen::Vector3d::UnitZ());
  }

  // A map on `grid`: vertical lines through the cell centres, in parallel over rows.
  ElevationMap map(const MapGrid& grid) const;

  // The map at resolution `cell_m` inside a polygon (x, y vertices, world frame): the grid covers
  // the polygon's bounding box; cells whose centre is outside the polygon stay Unseen.
  ElevationMap mapPolygon(const std::vector<Eigen::Vector2d>& polygon, double cell_m) const;

 private:
  // The same, starting the scanline search at *hint (a neighbouring line's crossing) and
  // updating it; hint may be null.
  LocusHit intersect(const Eigen::Vector3d& u, const Eigen::Vector3d& v, int* hint) const;
  double sigmaAlongLine(int r0, int c0, const double* w, double rho, const Eigen::Vector3d& p,
                        const Eigen::Vector3d& b) const;

  const RangeImage& image_;
  const EdgeMask* edges_;
  LocusConfig config_;
  Eigen::Isometry3d T_SW_;
  Eigen::Vector3d up_;  // world z in the sensor frame
  std::vector<double> roughness_g_;  // the fBm interpolation factor, tabulated over f
  double phi0_, dphi_, theta0_, dtheta_;
  std::vector<double> sin_phi_, cos_phi_, sin_theta_, cos_theta_;
  Eigen::AlignedBox3d bounds_;  // world bounds of the returns, ± margin
};

}  // namespace ambler::perception
