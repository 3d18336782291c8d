#pragma once
// Rigid transforms as the matchers use them (paper §4): the six parameters ν of a pose, the error
// of an estimate against the truth, and the closed-form least-squares fit of a transform to paired
// points and paired directions (feature matching's "predict" step).
#include <Eigen/Geometry>
#include <optional>
#include <vector>

namespace ambler::perception {

// ν = (rx, ry, rz, tx, ty, tz): the rotation vector (axis · angle, radians) and the translation
// (metres), in the order of a registration's covariance.
using PoseVector = Eigen::Matrix<double, 6, 1>;

// T = (exp([r]×), t) and its inverse map (the rotation vector of angle in [0, π]).
Eigen::Isometry3d poseFromVector(const PoseVector& nu);
PoseVector vectorFromPose(const Eigen::Isometry3d& T);

// How far an estimate is from the truth: the translation (m) and the rotation angle (degrees) of
// T_true⁻¹·T_est.
struct PoseError {
  double translation_m = 0;
  double rotation_deg = 0;
};
PoseError poseError(const Eigen::Isometry3d& T_true, const Eigen::Isometry3d& T_est);

// The rigid T minimising Σ_i |T·a_i − b_i|² + w·Σ_j |R·d_j − e_j|² over paired points (a_i, b_i)
// and paired unit directions (d_j, e_j) (line features), in closed form: the cross-covariance
// H = Σ (a_i − ā)(b_i − b̄)ᵀ + w·Σ d_j e_jᵀ, its SVD H = U·S·Vᵀ, R = V·diag(1, 1, det(V·Uᵀ))·Uᵀ
// (a rotation, never a reflection), t = b̄ − R·ā (directions do not constrain t). Exact on
// noise-free pairs. nullopt when the rotation is not determined: fewer than one point, or H of
// rank below 2 (all points and directions on one line). Throws std::invalid_argument if the
// paired lists differ in length or w is negative.
std::optional<Eigen::Isometry3d> fitRigid(const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b,
                                          const std::vector<Eigen::Vector3d>& d = {},
                                          const std::vector<Eigen::Vector3d>& e = {}, double w = 1.0);

}  // namespace ambler::perception
