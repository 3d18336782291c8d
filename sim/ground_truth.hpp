#pragma once
// Ground truth from the ray scene, so rocks and every geom count: the true elevation at any
// (x, y), and which surface points a sensor can see (the rest of its field of view is range
// shadow).
#include <Eigen/Geometry>
#include <cstdint>
#include <optional>

#include "perception/raster.hpp"
#include "perception/elevation_map.hpp"
#include "perception/map_grid.hpp"
#include "perception/range_image.hpp"
#include "perception/sensor_model.hpp"

namespace ambler::sim {

class RayScene;

enum class Visibility : std::uint8_t {
  OutOfView = 0,  // no surface, outside the field of view, or beyond the maximum range
  Visible = 1,    // the surface point is the first thing the sensor's ray meets
  Hidden = 2,     // inside the field of view but occluded by other terrain: a range shadow
};

class GroundTruth {
 public:
  explicit GroundTruth(const RayScene& scene);

  // The highest surface point above (x, y), found by casting straight down; nullopt if the
  // vertical line meets nothing.
  std::optional<double> elevation(double x, double y) const;

  // The true map on `grid` (in its frame): every cell centre's vertical line cast from above, the
  // highest surface point Known with σ_z = 0, Unseen where the line meets nothing. In parallel.
  perception::ElevationMap elevation(const perception::MapGrid& grid) const;

  // Visibility of the true surface (`truth`, from elevation()) at each cell centre of its grid
  // from a sensor at T_WS with the given field of view and maximum range. A point counts as
  // visible when the sensor's ray to it meets nothing more than `tolerance_m` before it.
  perception::Raster<std::uint8_t> visibility(const perception::ElevationMap& truth,
                              const Eigen::Isometry3d& T_WS, const perception::SensorModel& sensor,
                              double tolerance_m = 2e-3) const;

 private:
  const RayScene& scene_;
  double z_top_;
};

}  // namespace ambler::sim
