// Eq. 1 of the paper, its inverse, the pixel angles and the sensor-pose convention (docs/conventions.md).
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "perception/range_image.hpp"
#include "perception/sensor_geometry.hpp"

namespace ambler::perception {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

TEST(SensorGeometry, EquationOneComponents) {
  const double rho = 7.3, phi = 0.21, theta = -0.37;
  const Eigen::Vector3d p = sphericalToCartesian(rho, phi, theta);
  EXPECT_DOUBLE_EQ(p.x(), rho * std::sin(theta));
  EXPECT_DOUBLE_EQ(p.y(), rho * std::cos(phi) * std::cos(theta));
  EXPECT_DOUBLE_EQ(p.z(), rho * std::sin(phi) * std::cos(theta));
  EXPECT_NEAR(p.norm(), rho, 1e-12);  // eq. 1 is a spherical coordinate system: |p| = ρ
}

TEST(SensorGeometry, InverseRoundTrips) {
  for (double phi = -1.2; phi <= 1.2; phi += 0.3)
    for (double theta = -1.2; theta <= 1.2; theta += 0.3) {
      const auto s = cartesianToSpherical(sphericalToCartesian(4.0, phi, theta));
      EXPECT_NEAR(s.rho, 4.0, 1e-12);
      EXPECT_NEAR(s.phi, phi, 1e-12);
      EXPECT_NEAR(s.theta, theta, 1e-12);
    }
}

// rpy [0, -30, 0] looks 30° down along +y; yaw 90° turns the boresight to −x; R = Rz·Ry·Rx.
TEST(SensorGeometry, PoseConvention) {
  const auto T = sensorPose({1, 2, 3}, {0, -30 * kDeg, 0});
  const Eigen::Vector3d boresight = T.linear() * Eigen::Vector3d::UnitY();
  EXPECT_NEAR(boresight.y(), std::cos(30 * kDeg), 1e-12);
  EXPECT_NEAR(boresight.z(), -std::sin(30 * kDeg), 1e-12);
  EXPECT_NEAR(boresight.x(), 0, 1e-12);
  EXPECT_EQ(T.translation(), Eigen::Vector3d(1, 2, 3));
  const auto yawed = sensorPose({0, 0, 0}, {0, 0, 90 * kDeg});
  EXPECT_TRUE((yawed.linear() * Eigen::Vector3d::UnitY()).isApprox(-Eigen::Vector3d::UnitX(), 1e-12));
  const double r = 0.3, p = -0.4, y = 1.1;
  Eigen::Matrix3d Rx, Ry, Rz;
  Rx << 1, 0, 0, 0, std::cos(p), -std::sin(p), 0, std::sin(p), std::cos(p);
  Ry << std::cos(r), 0, std::sin(r), 0, 1, 0, -std::sin(r), 0, std::cos(r);
  Rz << std::cos(y), -std::sin(y), 0, std::sin(y), std::cos(y), 0, 0, 0, 1;
  EXPECT_TRUE(sensorPose({0, 0, 0}, {r, p, y}).linear().isApprox(Rz * Ry * Rx, 1e-12));
}

// Row 0 is the top scanline (largest φ), column 0 the leftmost (smallest θ); pixel centres are
// evenly spaced by fov/n and symmetric about the boresight.
TEST(SensorGeometry, PixelAngles) {
  const auto img = RangeImage::blank(64, 256, 30 * kDeg, 80 * kDeg);
  EXPECT_NEAR(img.phi.front(), 15 * kDeg - 0.5 * 30 * kDeg / 64, 1e-15);
  EXPECT_NEAR(img.phi.front(), -img.phi.back(), 1e-15);
  EXPECT_NEAR(img.theta.front(), -40 * kDeg + 0.5 * 80 * kDeg / 256, 1e-15);
  EXPECT_NEAR(img.theta.front(), -img.theta.back(), 1e-15);
  for (int r = 1; r < 64; ++r) EXPECT_NEAR(img.phi[r - 1] - img.phi[r], 30 * kDeg / 64, 1e-15);
  for (int c = 1; c < 256; ++c) EXPECT_NEAR(img.theta[c] - img.theta[c - 1], 80 * kDeg / 256, 1e-15);
  EXPECT_EQ(img.validCount(), 0);
}

}  // namespace
}  // namespace ambler::perception
