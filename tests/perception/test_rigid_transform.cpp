// Rigid transforms for matching: ν ↔ T round trips, the pose error of T_true⁻¹·T_est, and the
// closed-form least-squares fit to paired points and directions — exact on noise-free pairs, a
// rotation never a reflection, refused when the rotation is not determined, and on noisy pairs no
// worse than the true transform (it is the minimiser).
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "perception/rigid_transform.hpp"

namespace ambler::perception {
namespace {

using Eigen::Vector3d;
constexpr double kDeg = std::numbers::pi / 180.0;

Eigen::Isometry3d someTransform(double angle, const Vector3d& axis, const Vector3d& t) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
  T.translation() = t;
  return T;
}

// Residual Σ|T·a − b|² + w·Σ|R·d − e|², the quantity fitRigid minimises.
double cost(const Eigen::Isometry3d& T, const std::vector<Vector3d>& a, const std::vector<Vector3d>& b,
            const std::vector<Vector3d>& d, const std::vector<Vector3d>& e, double w) {
  double c = 0;
  for (std::size_t i = 0; i < a.size(); ++i) c += (T * a[i] - b[i]).squaredNorm();
  for (std::size_t j = 0; j < d.size(); ++j) c += w * (T.linear() * d[j] - e[j]).squaredNorm();
  return c;
}

TEST(PoseVector, RoundTripsAndMatchesAngleAxis) {
  for (const double angle : {0.0, 1e-9, 0.3, 2.0, std::numbers::pi - 1e-6}) {
    const Eigen::Isometry3d T = someTransform(angle, {0.2, -0.5, 0.8}, {1.5, -2.0, 0.25});
    const PoseVector nu = vectorFromPose(T);
    EXPECT_NEAR(nu.head<3>().norm(), angle, 1e-9);
    const Eigen::Isometry3d back = poseFromVector(nu);
    EXPECT_LT((back.matrix() - T.matrix()).cwiseAbs().maxCoeff(), 1e-12) << angle;
  }
  EXPECT_TRUE(poseFromVector(PoseVector::Zero()).isApprox(Eigen::Isometry3d::Identity()));
}

// The error of T_true⁻¹·T_est: a pure yaw of 3° and a shift of (0.3, 0.4, 0) m give exactly those.
TEST(PoseError, IsTheRelativeTransformsAngleAndShift) {
  const Eigen::Isometry3d T_true = someTransform(0.4, {1, 2, 3}, {5, -1, 2});
  const Eigen::Isometry3d D = someTransform(3 * kDeg, {0, 0, 1}, {0.3, 0.4, 0});
  const PoseError e = poseError(T_true, T_true * D);
  EXPECT_NEAR(e.translation_m, 0.5, 1e-12);
  EXPECT_NEAR(e.rotation_deg, 3.0, 1e-9);
  const PoseError zero = poseError(T_true, T_true);
  EXPECT_NEAR(zero.translation_m, 0.0, 1e-12);
  EXPECT_NEAR(zero.rotation_deg, 0.0, 1e-6);  // acos near 1: √(2·1e-16) rad at worst
}

// Noise-free pairs give the transform back to rounding: points alone (three or more, not on one
// line), one point and two directions, two points and one direction across them; the paper's
// feature-matching case of about 30° and 2 m among them.
TEST(FitRigid, ExactOnNoiseFreePairs) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> U(-5, 5);
  const Eigen::Isometry3d T = someTransform(30 * kDeg, {0.1, -0.2, 1.0}, {2.0, 0.5, -0.1});
  auto moved = [&](const std::vector<Vector3d>& p) {
    std::vector<Vector3d> q;
    for (const auto& x : p) q.push_back(T * x);
    return q;
  };
  auto turned = [&](const std::vector<Vector3d>& p) {
    std::vector<Vector3d> q;
    for (const auto& x : p) q.push_back(T.linear() * x);
    return q;
  };
  std::vector<Vector3d> pts;
  for (int i = 0; i < 12; ++i) pts.push_back({U(rng), U(rng), 0.3 * U(rng)});
  const std::vector<Vector3d> three(pts.begin(), pts.begin() + 3);
  const std::vector<Vector3d> dirs{Vector3d(1, 0.2, 0).normalized(), Vector3d(-0.3, 1, 0.1).normalized()};
  struct Case {
    std::vector<Vector3d> a, d;
  };
  for (const Case& c : {Case{pts, {}}, Case{three, {}}, Case{{pts[0]}, dirs}, Case{{pts[0], pts[1]}, {dirs[1]}},
                        Case{pts, dirs}}) {
    const auto fit = fitRigid(c.a, moved(c.a), c.d, turned(c.d));
    ASSERT_TRUE(fit.has_value()) << c.a.size() << " points, " << c.d.size() << " directions";
    // Rounding only: coordinates up to ~7 m through an SVD and a few products; 100 ulp of 7 m
    // (one ulp is 8.9e-16 m).
    EXPECT_LT((fit->matrix() - T.matrix()).cwiseAbs().maxCoeff(), 100 * 8.9e-16)
        << c.a.size() << " points, " << c.d.size() << " directions";
  }
}

// Points in a plane mirrored through it would be fitted best by a reflection; the fit stays a
// rotation (det R = +1).
TEST(FitRigid, NeverAReflection) {
  const std::vector<Vector3d> a{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0.5}};
  std::vector<Vector3d> b;
  for (const auto& p : a) b.push_back({p.x(), p.y(), -p.z()});  // mirrored in z
  const auto fit = fitRigid(a, b);
  ASSERT_TRUE(fit.has_value());
  EXPECT_NEAR(fit->linear().determinant(), 1.0, 1e-12);
}

// The rotation about a line is free when every pair lies along it: refused. So is an empty set.
TEST(FitRigid, RefusesWhatDoesNotDetermineTheRotation) {
  const std::vector<Vector3d> line{{0, 0, 0}, {1, 1, 0}, {2, 2, 0}, {-3, -3, 0}};
  EXPECT_FALSE(fitRigid(line, line).has_value());
  const Vector3d along = Vector3d(1, 1, 0).normalized();
  EXPECT_FALSE(fitRigid(line, line, {along}, {along}).has_value());  // the direction is the line's
  EXPECT_FALSE(fitRigid({}, {}).has_value());
  EXPECT_THROW(fitRigid(line, {line[0]}), std::invalid_argument);
  EXPECT_THROW(fitRigid(line, line, {along}, {}), std::invalid_argument);
  EXPECT_THROW(fitRigid(line, line, {}, {}, -1.0), std::invalid_argument);
}

// With noise the fit is the least-squares minimiser: its cost is no larger than the true
// transform's, nor than any small perturbation of the fit (the closed form is the optimum).
TEST(FitRigid, IsTheLeastSquaresMinimiserOnNoisyPairs) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> U(-4, 4);
  std::normal_distribution<double> N(0, 0.02);
  const Eigen::Isometry3d T = someTransform(-12 * kDeg, {0.3, 0.1, 1.0}, {-1.0, 2.0, 0.2});
  std::vector<Vector3d> a, b, d, e;
  for (int i = 0; i < 20; ++i) {
    a.push_back({U(rng), U(rng), 0.5 * U(rng)});
    b.push_back(T * a.back() + Vector3d(N(rng), N(rng), N(rng)));
  }
  for (int j = 0; j < 4; ++j) {
    d.push_back(Vector3d(U(rng), U(rng), U(rng)).normalized());
    e.push_back((T.linear() * d.back() + Vector3d(N(rng), N(rng), N(rng))).normalized());
  }
  const double w = 2.0;
  const auto fit = fitRigid(a, b, d, e, w);
  ASSERT_TRUE(fit.has_value());
  const double best = cost(*fit, a, b, d, e, w);
  EXPECT_LE(best, cost(T, a, b, d, e, w));
  for (int k = 0; k < 6; ++k)
    for (const double h : {-1e-4, 1e-4}) {
      PoseVector nu = PoseVector::Zero();
      nu(k) = h;
      EXPECT_LE(best, cost(poseFromVector(nu) * *fit, a, b, d, e, w)) << "parameter " << k << " step " << h;
    }
  const PoseError err = poseError(T, *fit);
  // 20 points at σ = 2 cm spread over ~±4 m: the centroid errs by σ/√20 ≈ 0.45 cm and the
  // rotation by about σ/(√20·2.3 m) ≈ 0.002 rad = 0.11°, which moves points ~4 m from the
  // centroid by ~0.8 cm; the bounds are five times those.
  EXPECT_LT(err.translation_m, 5 * (0.0045 + 0.008));
  EXPECT_LT(err.rotation_deg, 5 * 0.11);
}

}  // namespace
}  // namespace ambler::perception
