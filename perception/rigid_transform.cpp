#include "perception/rigid_transform.hpp"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

namespace ambler::perception {

Eigen::Isometry3d poseFromVector(const PoseVector& nu) {
  const Eigen::Vector3d r = nu.head<3>();
  const double angle = r.norm();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  if (angle > 0) T.linear() = Eigen::AngleAxisd(angle, r / angle).toRotationMatrix();
  T.translation() = nu.tail<3>();
  return T;
}

PoseVector vectorFromPose(const Eigen::Isometry3d& T) {
  const Eigen::AngleAxisd aa(T.linear());
  PoseVector nu;
  nu.head<3>() = aa.angle() * aa.axis();
  nu.tail<3>() = T.translation();
  return nu;
}

PoseError poseError(const Eigen::Isometry3d& T_true, const Eigen::Isometry3d& T_est) {
  const Eigen::Isometry3d D = T_true.inverse() * T_est;
  // The angle from the trace, clamped against rounding: cos θ = (tr R − 1)/2.
  const double c = std::clamp((D.linear().trace() - 1.0) / 2.0, -1.0, 1.0);
  return {D.translation().norm(), std::acos(c) * 180.0 / std::numbers::pi};
}

std::optional<Eigen::Isometry3d> fitRigid(const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b,
                                          const std::vector<Eigen::Vector3d>& d, const std::vector<Eigen::Vector3d>& e,
                                          double w) {
  if (a.size() != b.size() || d.size() != e.size())
    throw std::invalid_argument("fitRigid: the paired lists differ in length");
  if (!(w >= 0)) throw std::invalid_argument("fitRigid: the direction weight must be non-negative");
  if (a.empty()) return std::nullopt;
  Eigen::Vector3d ca = Eigen::Vector3d::Zero(), cb = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < a.size(); ++i) ca += a[i], cb += b[i];
  ca /= double(a.size()), cb /= double(b.size());
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < a.size(); ++i) H += (a[i] - ca) * (b[i] - cb).transpose();
  for (std::size_t j = 0; j < d.size(); ++j) H += w * d[j] * e[j].transpose();
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Vector3d s = svd.singularValues();
  // Rank below 2: every pair lies along one line, and the rotation about it is free.
  if (!(s(1) > 1e-12 * std::max(s(0), 1e-300))) return std::nullopt;
  const Eigen::Matrix3d U = svd.matrixU(), V = svd.matrixV();
  Eigen::Matrix3d S = Eigen::Matrix3d::Identity();
  S(2, 2) = (V * U.transpose()).determinant() < 0 ? -1.0 : 1.0;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = V * S * U.transpose();
  T.translation() = cb - T.linear() * ca;
  return T;
}

}  // namespace ambler::perception
