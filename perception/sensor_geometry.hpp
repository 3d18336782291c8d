#pragma once
// The ERIM's spherical-polar geometry (paper eq. 1 and its inverse) and sensor poses.
// Sensor frame S: x right, y forward (boresight), z up; φ is the vertical scan angle (row),
// θ the horizontal one (column).
#include <Eigen/Geometry>
#include <cmath>

namespace ambler::perception {

// Unit beam direction in S for scan angles (φ, θ): eq. 1 with ρ = 1.
inline Eigen::Vector3d beamDirection(double phi, double theta) {
  const double ct = std::cos(theta);
  return {std::sin(theta), std::cos(phi) * ct, std::sin(phi) * ct};
}

// Eq. 1: x = ρ sinθ, y = ρ cosφ cosθ, z = ρ sinφ cosθ.
inline Eigen::Vector3d sphericalToCartesian(double rho, double phi, double theta) {
  return rho * beamDirection(phi, theta);
}

struct Spherical {
  double rho, phi, theta;
};

// The inverse of eq. 1 for a point in S (ρ > 0): ρ = |p|, θ = asin(x/ρ), φ = atan2(z, y).
Spherical cartesianToSpherical(const Eigen::Vector3d& p);

// T_WS for a sensor at `xyz` with roll, pitch, yaw (radians): R = Rz(yaw)·Ry(roll)·Rx(pitch), so
// pitch tilts the boresight (+y) about the sensor's x axis and pitch < 0 looks down.
Eigen::Isometry3d sensorPose(const Eigen::Vector3d& xyz, const Eigen::Vector3d& rpy);

// Pixel-centre scan angles of an image with `n` samples across `fov` radians, centred on the
// boresight. Rows run from the top (largest φ) down; columns from the left (smallest θ).
double rowAngle(int row, int rows, double fov_v);
double colAngle(int col, int cols, double fov_h);

}  // namespace ambler::perception
