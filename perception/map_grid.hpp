#pragma once
// Where a map's cells are: a grid in a gravity-aligned map frame M, placed in the world by T_WM
// (an origin and a yaw about z; M's z axis is the world's). Rasters are north-up like a GeoTIFF:
// row r, column c is the cell centred at x = x_min + (c + 0.5)·cell, y = y_max − (r + 0.5)·cell in
// M, and a map's elevations are heights along M's z (docs/conventions.md, "Maps and frames").
#include <Eigen/Geometry>
#include <cmath>
#include <optional>

namespace ambler::perception {

// T_WM for a gravity-aligned frame with its origin at `origin` (world) turned by `yaw` about z.
inline Eigen::Isometry3d mapFrame(const Eigen::Vector3d& origin, double yaw) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = origin;
  return T;
}

// Whether T_WM is exactly the identity (M is the world: no coordinate needs transforming).
inline bool isWorldFrame(const Eigen::Isometry3d& T_WM) { return T_WM.matrix() == Eigen::Matrix4d::Identity(); }
// Whether M is gravity-aligned (its z axis the world's), as every map frame must be.
inline bool isGravityAligned(const Eigen::Isometry3d& T_WM) {
  const Eigen::Matrix3d R = T_WM.linear();
  return std::abs(R(2, 2) - 1.0) < 1e-12 && std::abs(R(0, 2)) < 1e-12 && std::abs(R(1, 2)) < 1e-12;
}

struct MapGrid {
  double x_min = 0.0;  // in M
  double y_max = 0.0;
  double cell = 0.1;
  int rows = 0;
  int cols = 0;
  Eigen::Isometry3d T_WM = Eigen::Isometry3d::Identity();  // the map frame in the world

  // The grid of `cell` covering [x0, x1] × [y0, y1] of frame T_WM (rounded outwards to whole cells).
  static MapGrid covering(double x0, double x1, double y0, double y1, double cell,
                          const Eigen::Isometry3d& T_WM = Eigen::Isometry3d::Identity()) {
    MapGrid g;
    g.T_WM = T_WM;
    g.cell = cell;
    g.cols = std::max(1, int(std::ceil((x1 - x0) / cell - 1e-9)));
    g.rows = std::max(1, int(std::ceil((y1 - y0) / cell - 1e-9)));
    g.x_min = x0;
    g.y_max = y1;
    return g;
  }

  bool inWorldFrame() const { return isWorldFrame(T_WM); }
  bool gravityAligned() const { return isGravityAligned(T_WM); }

  // Cell (r, c)'s centre in M.
  Eigen::Vector2d center(int r, int c) const {
    return {x_min + (c + 0.5) * cell, y_max - (r + 0.5) * cell};
  }
  // The point of M at cell (r, c)'s centre and height z (of M), in the world.
  Eigen::Vector3d worldPoint(int r, int c, double z) const {
    const Eigen::Vector2d m = center(r, c);
    return inWorldFrame() ? Eigen::Vector3d(m.x(), m.y(), z) : Eigen::Vector3d(T_WM * Eigen::Vector3d(m.x(), m.y(), z));
  }
  // The cell containing (x, y) of M, if inside.
  std::optional<Eigen::Vector2i> cellOf(double x, double y) const {
    const int c = int(std::floor((x - x_min) / cell));
    const int r = int(std::floor((y_max - y) / cell));
    if (r < 0 || r >= rows || c < 0 || c >= cols) return std::nullopt;
    return Eigen::Vector2i(r, c);
  }
  long cells() const { return long(rows) * cols; }
  // Same frame, placement and size.
  bool sameAs(const MapGrid& o) const {
    return T_WM.matrix() == o.T_WM.matrix() && x_min == o.x_min && y_max == o.y_max && cell == o.cell &&
           rows == o.rows && cols == o.cols;
  }
};

}  // namespace ambler::perception
