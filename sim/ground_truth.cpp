#include "sim/ground_truth.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

#include "perception/sensor_geometry.hpp"
#include "sim/erim_scanner.hpp"
#include "sim/ray_scene.hpp"

namespace ambler::sim {

GroundTruth::GroundTruth(const RayScene& scene)
    : scene_(scene), z_top_(scene.bounds().max().z() + 1.0) {}

std::optional<double> GroundTruth::elevation(double x, double y) const {
  const auto hit = scene_.intersect(Eigen::Vector3d(x, y, z_top_), -Eigen::Vector3d::UnitZ());
  if (!hit) return std::nullopt;
  return z_top_ - hit->t;
}

perception::ElevationMap GroundTruth::elevation(const perception::MapGrid& grid) const {
  if (!grid.gravityAligned()) throw std::invalid_argument("GroundTruth::elevation: the map frame is not gravity-aligned");
  // The cast starts at z_top_ in the world; a height of M is the world's minus M's origin height.
  const double z_origin = grid.T_WM.translation().z();
  std::vector<Eigen::Vector3d> origins, dirs(grid.cells(), -Eigen::Vector3d::UnitZ());
  origins.reserve(grid.cells());
  for (int r = 0; r < grid.rows; ++r)
    for (int c = 0; c < grid.cols; ++c) origins.push_back(grid.worldPoint(r, c, z_top_ - z_origin));
  std::vector<double> t;
  scene_.intersectMany(origins, dirs, t);
  perception::ElevationMap map(grid);
  for (int r = 0; r < grid.rows; ++r)
    for (int c = 0; c < grid.cols; ++c) {
      const double ti = t[std::size_t(r) * grid.cols + c];
      if (std::isfinite(ti)) map.setKnown(r, c, float(z_top_ - ti - z_origin), 0.0f);
    }
  return map;
}

perception::Raster<std::uint8_t> GroundTruth::visibility(const perception::ElevationMap& truth,
                                         const Eigen::Isometry3d& T_WS, const perception::SensorModel& sensor,
                                         double tolerance_m) const {
  const perception::MapGrid& grid = truth.grid();
  const Eigen::Vector3d o = T_WS.translation();
  const Eigen::Isometry3d T_SW = T_WS.inverse();
  // Field of view in scan angles, to the outer edges of the outermost pixels.
  const double phi_max = 0.5 * sensor.fov_v_rad, theta_max = 0.5 * sensor.fov_h_rad;
  perception::Raster<std::uint8_t> vis = perception::Raster<std::uint8_t>::Constant(grid.rows, grid.cols, std::uint8_t(Visibility::OutOfView));
  std::vector<long> index;
  std::vector<Eigen::Vector3d> origins, dirs;
  std::vector<double> dist;
  for (int r = 0; r < grid.rows; ++r)
    for (int c = 0; c < grid.cols; ++c) {
      const float z = truth.elevation()(r, c);
      if (!std::isfinite(z)) continue;
      const Eigen::Vector3d p = grid.worldPoint(r, c, z);
      const auto s = perception::cartesianToSpherical(T_SW * p);
      if (std::abs(s.phi) > phi_max || std::abs(s.theta) > theta_max || s.rho > sensor.max_range_m ||
          s.rho <= 0)
        continue;
      index.push_back(long(r) * grid.cols + c);
      origins.push_back(o);
      dirs.push_back((p - o) / s.rho);
      dist.push_back(s.rho);
    }
  std::vector<double> t;
  scene_.intersectMany(origins, dirs, t);
  for (std::size_t i = 0; i < index.size(); ++i) {
    const bool blocked = t[i] < dist[i] - tolerance_m;
    vis.data()[index[i]] = std::uint8_t(blocked ? Visibility::Hidden : Visibility::Visible);
  }
  return vis;
}

}  // namespace ambler::sim
