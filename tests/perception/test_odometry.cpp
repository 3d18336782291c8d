// The body frame and odometry (perception/odometry.hpp): the mount against sensorPose's convention,
// heading and tilt of composed rotations, a step and its integration as inverses (also across the
// ±π wrap of the heading), and a closed square path.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "base/random.hpp"
#include "perception/odometry.hpp"
#include "perception/sensor_geometry.hpp"

namespace ambler::perception {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;
constexpr double kPi = std::numbers::pi;
constexpr double kDeg = kPi / 180.0;

Matrix3d rz(double a) { return Eigen::AngleAxisd(a, Vector3d::UnitZ()).toRotationMatrix(); }
Matrix3d ry(double a) { return Eigen::AngleAxisd(a, Vector3d::UnitY()).toRotationMatrix(); }
Matrix3d rx(double a) { return Eigen::AngleAxisd(a, Vector3d::UnitX()).toRotationMatrix(); }

Eigen::Isometry3d pose(const Vector3d& t, const Matrix3d& R) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R;
  T.translation() = t;
  return T;
}

// A body pose with heading psi, pitch and roll up to 0.6 rad (a rover's slopes and more), anywhere
// within 50 m.
Eigen::Isometry3d randomBody(base::Rng& rng, double psi) {
  const Vector3d t(rng.uniform(-50, 50), rng.uniform(-50, 50), rng.uniform(-5, 5));
  return pose(t, rz(psi) * ry(rng.uniform(-0.6, 0.6)) * rx(rng.uniform(-0.6, 0.6)));
}

void expectPoseNear(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b, double tol) {
  EXPECT_LE((a.translation() - b.translation()).cwiseAbs().maxCoeff(), tol);
  EXPECT_LE((a.linear() - b.linear()).cwiseAbs().maxCoeff(), tol);
}

// Level body at heading ψ: the sensor is sensorPose(origin + h·z, {0, pitch, ψ − 90°}) (the header's contract).
TEST(Odometry, SensorOnALevelBodyIsSensorPoseTurnedAQuarter) {
  base::Rng rng(11);
  for (const double psi : {0.0, 0.3, kPi / 2, -2.0, kPi, -kPi + 1e-9, 2.9})
    for (const double pitch : {-30 * kDeg, 0.0, 12 * kDeg}) {
      const Vector3d origin(rng.uniform(-10, 10), rng.uniform(-10, 10), rng.uniform(-2, 2));
      const Mount mount{rng.uniform(0.5, 4.0), pitch};
      const Eigen::Isometry3d got = sensorOnBody(pose(origin, rz(psi)), mount);
      const Eigen::Isometry3d want =
          sensorPose(origin + mount.height_m * Vector3d::UnitZ(), {0, pitch, psi - 90 * kDeg});
      expectPoseNear(got, want, 1e-12);
    }
}

// On a tilted body the mount follows the body: the boresight is B's x pitched about B's y (down for a
// negative pitch), the sensor's x is B's −y (right), and the sensor sits height_m along B's z.
TEST(Odometry, SensorFollowsATiltedBody) {
  const Eigen::Isometry3d T_WB = pose({1, -2, 0.5}, rz(0.7) * ry(0.2) * rx(-0.15));
  const Mount mount{2.5, -30 * kDeg};
  const Eigen::Isometry3d T_WS = sensorOnBody(T_WB, mount);
  const Matrix3d& R = T_WB.linear();
  const Vector3d boresight = R * Vector3d(std::cos(30 * kDeg), 0, -std::sin(30 * kDeg));
  EXPECT_LE((T_WS.linear().col(1) - boresight).norm(), 1e-15);
  EXPECT_LE((T_WS.linear().col(0) + R.col(1)).norm(), 1e-15);
  EXPECT_LE((T_WS.translation() - (T_WB.translation() + 2.5 * R.col(2))).norm(), 1e-15);
}

// R = Rz(ψ)·Ry(θ)·Rx(φ): the heading is ψ (B's x projected on the horizontal), the tilt Ry(θ)·Rx(φ),
// whose own heading is zero, and Rz(ψ)·tilt gives R back.
TEST(Odometry, HeadingAndTiltOfComposedRotations) {
  base::Rng rng(12);
  for (int i = 0; i < 500; ++i) {
    const double psi = rng.uniform(-kPi, kPi), pitch = rng.uniform(-1.2, 1.2), roll = rng.uniform(-1.2, 1.2);
    const Matrix3d tilt = ry(pitch) * rx(roll), R = rz(psi) * tilt;
    EXPECT_NEAR(headingOf(R), psi, 1e-12);
    EXPECT_LE((tiltOf(R) - tilt).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_NEAR(headingOf(tiltOf(R)), 0.0, 1e-12);
    EXPECT_LE((rz(headingOf(R)) * tiltOf(R) - R).cwiseAbs().maxCoeff(), 1e-12);
  }
}

// Facing −x the heading is +π, whichever sign the zero of B's x axis has in y: the range is (−π, π].
TEST(Odometry, HeadingFacingBackwardsIsPlusPi) {
  Matrix3d R;
  R << -1, 0, 0, 0, -1, 0, 0, 0, 1;
  EXPECT_EQ(headingOf(R), kPi);
  R(1, 0) = -0.0;
  EXPECT_EQ(headingOf(R), kPi);
}

// The step is measured in the previous stop's heading frame: x forward, y left, dz and the turn.
TEST(Odometry, StepIsInThePreviousHeadingFrame) {
  const Eigen::Isometry3d from = pose({1, 2, 3}, rz(kPi / 2));
  const OdometryStep ahead = stepBetween(from, pose({1, 4, 3.5}, rz(kPi)));
  EXPECT_NEAR(ahead.dx_m, 2.0, 1e-15);
  EXPECT_NEAR(ahead.dy_m, 0.0, 1e-15);
  EXPECT_EQ(ahead.dz_m, 0.5);
  EXPECT_NEAR(ahead.dheading_rad, kPi / 2, 1e-15);
  const OdometryStep left = stepBetween(from, pose({0, 2, 3}, rz(kPi / 2 - 0.1)));
  EXPECT_NEAR(left.dx_m, 0.0, 1e-15);
  EXPECT_NEAR(left.dy_m, 1.0, 1e-15);
  EXPECT_NEAR(left.dheading_rad, -0.1, 1e-15);
}

// Across the ±π wrap the turn is the short way round, and wrapped to (−π, π].
TEST(Odometry, TurnAcrossTheWrapIsShort) {
  const OdometryStep step = stepBetween(pose({0, 0, 0}, rz(kPi - 0.01)), pose({0, 0, 0}, rz(-kPi + 0.02)));
  EXPECT_NEAR(step.dheading_rad, 0.03, 1e-12);
  const OdometryStep back = stepBetween(pose({0, 0, 0}, rz(-kPi + 0.02)), pose({0, 0, 0}, rz(kPi - 0.01)));
  EXPECT_NEAR(back.dheading_rad, -0.03, 1e-12);
  const OdometryStep half = stepBetween(pose({0, 0, 0}, rz(0.5)), pose({0, 0, 0}, rz(0.5 - kPi)));
  EXPECT_GT(half.dheading_rad, -kPi);
  EXPECT_LE(half.dheading_rad, kPi);
  EXPECT_NEAR(std::abs(half.dheading_rad), kPi, 1e-12);
}

// integrate(from, stepBetween(from, to), tiltOf(to)) is `to`: random tilted poses, and pairs whose
// headings straddle ±π.
TEST(Odometry, IntegrateUndoesStepBetween) {
  base::Rng rng(13);
  for (int i = 0; i < 2000; ++i) {
    const bool straddle = i % 2 == 1;
    const double psi_from = straddle ? kPi - rng.uniform(0, 0.2) : rng.uniform(-kPi, kPi);
    const double psi_to = straddle ? -kPi + rng.uniform(0, 0.2) : rng.uniform(-kPi, kPi);
    const Eigen::Isometry3d from = randomBody(rng, i % 4 == 1 ? psi_to : psi_from);
    const Eigen::Isometry3d to = randomBody(rng, i % 4 == 1 ? psi_from : psi_to);
    const OdometryStep step = stepBetween(from, to);
    EXPECT_GT(step.dheading_rad, -kPi);
    EXPECT_LE(step.dheading_rad, kPi);
    if (straddle) {
      EXPECT_LT(std::abs(step.dheading_rad), 0.4);
    }
    expectPoseNear(integrate(from, step, tiltOf(to.linear())), to, 1e-12);
  }
}

// Four 1 m steps, each followed by a 90° left turn, walk a unit square back to the start.
TEST(Odometry, SquarePathCloses) {
  const OdometryStep step{1.0, 0.0, 0.0, kPi / 2};
  const Vector3d corners[] = {{1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 0}};
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  for (const Vector3d& corner : corners) {
    T = integrate(T, step, Matrix3d::Identity());
    EXPECT_LE((T.translation() - corner).norm(), 1e-15);
  }
  expectPoseNear(T, Eigen::Isometry3d::Identity(), 1e-15);
}

}  // namespace
}  // namespace ambler::perception
