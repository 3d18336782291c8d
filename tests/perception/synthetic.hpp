#pragma once
// Synthetic range images with exact ranges, for perception tests that need no simulator.
#include <cmath>
#include <limits>

#include "perception/range_image.hpp"
#include "perception/sensor_geometry.hpp"

namespace ambler::test {

// The plane z = a·x + b·y + c.
struct Plane {
  double a = 0, b = 0, c = 0;
  double z(double x, double y) const { return a * x + b * y + c; }
  Eigen::Vector3d normal() const { return Eigen::Vector3d(-a, -b, 1).normalized(); }
};

// Exact range of the ray from the sensor along `d` (world) to the plane, NaN if it never meets it
// in front.
inline double rangeToPlane(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const Plane& p) {
  const double den = d.z() - p.a * d.x() - p.b * d.y();
  const double t = (p.z(o.x(), o.y()) - o.z()) / den;
  return t > 0 ? t : std::numeric_limits<double>::quiet_NaN();
}

inline perception::RangeImage planeImage(const Plane& plane, const Eigen::Isometry3d& T_WS, int rows = 64,
                                         int cols = 256, double fov_v = 30 * M_PI / 180,
                                         double fov_h = 80 * M_PI / 180, double max_range = 40) {
  auto img = perception::RangeImage::blank(rows, cols, fov_v, fov_h);
  img.T_WS = T_WS;
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) {
      const Eigen::Vector3d d = T_WS.linear() * perception::beamDirection(img.phi[r], img.theta[c]);
      const double t = rangeToPlane(T_WS.translation(), d, plane);
      img.range(r, c) = t <= max_range ? float(t) : std::numeric_limits<float>::quiet_NaN();
    }
  return img;
}

}  // namespace ambler::test
