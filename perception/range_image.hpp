#pragma once
// A range image as the ERIM delivers it: ρ per pixel (NaN where nothing returned), the scan
// angles φ of each row and θ of each column, and the sensor pose it was taken from.
#include <Eigen/Geometry>
#include <cmath>
#include <vector>

#include "perception/raster.hpp"

namespace ambler::perception {

struct RangeImage {
  Raster<float> range;                 // rows × cols, metres; NaN = no return
  std::vector<double> phi;           // per row, radians; row 0 is the top (largest φ)
  std::vector<double> theta;         // per column, radians; column 0 is the leftmost
  Eigen::Isometry3d T_WS = Eigen::Isometry3d::Identity();  // sensor → world

  // A blank image (all NaN) with the ERIM's evenly spaced pixel-centre angles.
  static RangeImage blank(int rows, int cols, double fov_v, double fov_h);

  int rows() const { return int(range.rows()); }
  int cols() const { return int(range.cols()); }
  bool valid(int r, int c) const { return std::isfinite(range(r, c)); }
  int validCount() const;
  // The return of pixel (r, c) in the sensor frame (eq. 1); only for valid pixels.
  Eigen::Vector3d pointSensor(int r, int c) const;
  Eigen::Vector3d pointWorld(int r, int c) const { return T_WS * pointSensor(r, c); }
};

}  // namespace ambler::perception
