#include "perception/odometry.hpp"

#include <cmath>
#include <numbers>

namespace ambler::perception {

namespace {

// An angle in (−π, π]. std::remainder is exact, so an angle already in range comes back bit for bit.
double wrapAngle(double a) {
  const double r = std::remainder(a, 2.0 * std::numbers::pi);
  return r <= -std::numbers::pi ? r + 2.0 * std::numbers::pi : r;
}

Eigen::Matrix3d rotZ(double psi) {
  const double c = std::cos(psi), s = std::sin(psi);
  Eigen::Matrix3d R;
  R << c, -s, 0, s, c, 0, 0, 0, 1;
  return R;
}

}  // namespace

Eigen::Isometry3d sensorOnBody(const Eigen::Isometry3d& T_WB, const Mount& mount) {
  // R_BS = Rz(−90°)·Rx(pitch), written out: S's x (right) is B's −y, S's y (forward) is B's x, and
  // the pitch turns S's y and z about S's x. The quarter turn is exact, not cos(π/2) ≈ 6e-17.
  const double c = std::cos(mount.pitch_rad), s = std::sin(mount.pitch_rad);
  Eigen::Matrix3d R_BS;
  R_BS << 0, c, -s,   //
      -1, 0, 0,       //
      0, s, c;
  Eigen::Isometry3d T_BS = Eigen::Isometry3d::Identity();
  T_BS.linear() = R_BS;
  T_BS.translation() = Eigen::Vector3d(0, 0, mount.height_m);
  return T_WB * T_BS;
}

double headingOf(const Eigen::Matrix3d& R_WB) {
  const double psi = std::atan2(R_WB(1, 0), R_WB(0, 0));
  return psi == -std::numbers::pi ? std::numbers::pi : psi;  // atan2(−0, −1) = −π
}

Eigen::Matrix3d tiltOf(const Eigen::Matrix3d& R_WB) { return rotZ(headingOf(R_WB)).transpose() * R_WB; }

OdometryStep stepBetween(const Eigen::Isometry3d& from, const Eigen::Isometry3d& to) {
  const double psi_from = headingOf(from.linear());
  const Eigen::Vector3d d = to.translation() - from.translation();
  const double c = std::cos(psi_from), s = std::sin(psi_from);
  OdometryStep step;
  step.dx_m = c * d.x() + s * d.y();
  step.dy_m = -s * d.x() + c * d.y();
  step.dz_m = d.z();
  step.dheading_rad = wrapAngle(headingOf(to.linear()) - psi_from);
  return step;
}

Eigen::Isometry3d integrate(const Eigen::Isometry3d& from, const OdometryStep& step, const Eigen::Matrix3d& tilt) {
  const double psi_from = headingOf(from.linear());
  const double c = std::cos(psi_from), s = std::sin(psi_from);
  Eigen::Isometry3d to = Eigen::Isometry3d::Identity();
  to.translation() =
      from.translation() + Eigen::Vector3d(c * step.dx_m - s * step.dy_m, s * step.dx_m + c * step.dy_m, step.dz_m);
  to.linear() = rotZ(wrapAngle(psi_from + step.dheading_rad)) * tilt;
  return to;
}

}  // namespace ambler::perception
