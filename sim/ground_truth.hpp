#pragma once
// Ground truth from the ray scene, so rocks and every geom count: the true elevation at any
// (x, y), and which surface points a sensor can see (the rest of its field of view is range
// shadow).
#include <Eigen/Geometry>
#include <cstdint>
#include <optional>

#include "perception/map_grid.hpp"
#include "perception/range_image.hpp"

namespace ambler::sim {

class RayScene;
struct ErimConfig;

enum class Visibility : std::uint8_t {
  OutOfView = 0,  // no surface, outside the field of view, or beyond the maximum range
  Visible = 1,    // the surface point is the first thing the sensor's ray meets
  Hidden = 2,     // inside the field of view but occluded by other terrain: a range shadow
};

using ElevationRaster = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
using VisibilityRaster = Eigen::Matrix<std::uint8_t, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

class GroundTruth {
 public:
  explicit GroundTruth(const RayScene& scene);

  // The highest surface point above (x, y), found by casting straight down; nullopt if the
  // vertical line meets nothing.
  std::optional<double> elevation(double x, double y) const;

  // Elevation at every cell centre of `grid` (NaN where nothing is below), in parallel.
  ElevationRaster elevation(const perception::MapGrid& grid) const;

  // Visibility of the true surface at each cell centre of `grid` from a sensor at T_WS with the
  // given field of view and maximum range. A point counts as visible when the sensor's ray to it
  // meets nothing more than `tolerance_m` before it.
  VisibilityRaster visibility(const perception::MapGrid& grid, const ElevationRaster& truth,
                              const Eigen::Isometry3d& T_WS, const ErimConfig& sensor,
                              double tolerance_m = 2e-3) const;

 private:
  const RayScene& scene_;
  double z_top_;
};

}  // namespace ambler::sim
