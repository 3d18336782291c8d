#include "perception/sensor_geometry.hpp"

#include <algorithm>
#include <cmath>

namespace ambler::perception {

Spherical cartesianToSpherical(const Eigen::Vector3d& p) {
  const double rho = p.norm();
  const double theta = std::asin(std::clamp(p.x() / rho, -1.0, 1.0));
  return {rho, std::atan2(p.z(), p.y()), theta};
}

Eigen::Isometry3d sensorPose(const Eigen::Vector3d& xyz, const Eigen::Vector3d& rpy) {
  const Eigen::Matrix3d R = (Eigen::AngleAxisd(rpy.z(), Eigen::Vector3d::UnitZ()) *
                             Eigen::AngleAxisd(rpy.x(), Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(rpy.y(), Eigen::Vector3d::UnitX()))
                                .toRotationMatrix();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R;
  T.translation() = xyz;
  return T;
}

double rowAngle(int row, int rows, double fov_v) {
  return 0.5 * fov_v * (1.0 - (2.0 * row + 1.0) / rows);
}

double colAngle(int col, int cols, double fov_h) {
  return 0.5 * fov_h * ((2.0 * col + 1.0) / cols - 1.0);
}

}  // namespace ambler::perception
