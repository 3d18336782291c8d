#include "sim/ground_truth.hpp"

#include <cmath>
#include <limits>
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

ElevationRaster GroundTruth::elevation(const perception::MapGrid& grid) const {
  std::vector<Eigen::Vector3d> origins, dirs(grid.cells(), -Eigen::Vector3d::UnitZ());
  origins.reserve(grid.cells());
  for (int r = 0; r < grid.rows; ++r)
    for (int c = 0; c < grid.cols; ++c) {
      const Eigen::Vector2d p = grid.center(r, c);
      origins.emplace_back(p.x(), p.y(), z_top_);
    }
  std::vector<double> t;
  scene_.intersectMany(origins, dirs, t);
  ElevationRaster z(grid.rows, grid.cols);
  for (long i = 0; i < grid.cells(); ++i)
    z.data()[i] = std::isfinite(t[i]) ? float(z_top_ - t[i]) : std::numeric_limits<float>::quiet_NaN();
  return z;
}

VisibilityRaster GroundTruth::visibility(const perception::MapGrid& grid, const ElevationRaster& truth,
                                         const Eigen::Isometry3d& T_WS, const ErimConfig& sensor,
                                         double tolerance_m) const {
  const Eigen::Vector3d o = T_WS.translation();
  const Eigen::Isometry3d T_SW = T_WS.inverse();
  // Field of view in scan angles, to the outer edges of the outermost pixels.
  const double phi_max = 0.5 * sensor.fov_v_rad, theta_max = 0.5 * sensor.fov_h_rad;
  VisibilityRaster vis = VisibilityRaster::Constant(grid.rows, grid.cols, std::uint8_t(Visibility::OutOfView));
  std::vector<long> index;
  std::vector<Eigen::Vector3d> origins, dirs;
  std::vector<double> dist;
  for (int r = 0; r < grid.rows; ++r)
    for (int c = 0; c < grid.cols; ++c) {
      const float z = truth(r, c);
      if (!std::isfinite(z)) continue;
      const Eigen::Vector2d xy = grid.center(r, c);
      const Eigen::Vector3d p(xy.x(), xy.y(), z);
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
