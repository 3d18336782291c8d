// Composite maps (paper §4.3): eq. 9 and its σ on two maps of a plane against the closed form,
// the state rules cell by cell, a map merged with itself halving the variance; the σ a pose's
// covariance adds to a tilted plane against its closed form (ν = 0) and against finite
// differences of the moved plane (ν ≠ 0).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "perception/composite.hpp"

namespace ambler::perception {
namespace {

constexpr double kDeg = M_PI / 180;

// z = a·x + b·y + c on a 0.1 m grid over [−2, 2]², every cell Known with σ `s` and an offset.
ElevationMap planeMap(double a, double b, double c, double s, double offset = 0) {
  ElevationMap m(MapGrid::covering(-2, 2, -2, 2, 0.1));
  for (int r = 0; r < m.grid().rows; ++r)
    for (int col = 0; col < m.grid().cols; ++col) {
      const Eigen::Vector2d p = m.grid().center(r, col);
      m.setKnown(r, col, float(a * p.x() + b * p.y() + c + offset), float(s));
    }
  return m;
}

TEST(Composite, TwoMeasurementsMergeToTheMaximumLikelihoodEstimate) {
  // z₁ = plane + 1 cm (σ₁ = 1 cm), z₂ = plane − 2 cm (σ₂ = 2 cm): eq. 9 gives
  // plane + (4·1 − 1·2)/5 cm = plane + 0.4 cm, σ = 1·2/√5 cm.
  ElevationMap composite = planeMap(0.2, -0.1, 0.5, 0.01, 0.01);
  const ElevationMap other = planeMap(0.2, -0.1, 0.5, 0.02, -0.02);
  mergeInto(composite, other);
  const MapGrid& g = composite.grid();
  for (int r = 0; r < g.rows; r += 7)
    for (int c = 0; c < g.cols; c += 5) {
      const Eigen::Vector2d p = g.center(r, c);
      ASSERT_EQ(composite.stateAt(r, c), CellState::Known);
      EXPECT_NEAR(composite.elevation()(r, c), 0.2 * p.x() - 0.1 * p.y() + 0.5 + 0.004, 1e-6);
      EXPECT_NEAR(composite.sigma()(r, c), 0.02 / std::sqrt(5.0), 1e-8);
    }
}

TEST(Composite, AMapMergedWithItselfHalvesItsVariance) {
  ElevationMap composite = planeMap(0.3, 0, 0, 0.015);
  const ElevationMap same = composite;
  mergeInto(composite, same);
  for (int r = 0; r < composite.grid().rows; ++r)
    for (int c = 0; c < composite.grid().cols; ++c) {
      EXPECT_FLOAT_EQ(composite.elevation()(r, c), same.elevation()(r, c));
      EXPECT_NEAR(double(composite.sigma()(r, c)) * composite.sigma()(r, c), 0.5 * 0.015 * 0.015, 1e-9);
    }
}

// Part of each σ shared by both views (an error they both make): the weighted mean w₁z₁ + w₂z₂ of
// eq. 9 has σ² = w₁²(σ₁² − s₁²) + w₂²(σ₂² − s₂²) + (w₁s₁ + w₂s₂)². A map wholly shared merged with
// itself keeps its variance (the same error twice is no better than once); shared parts of 0 give
// eq. 9's σ; and the composite's shared part carries on to the next merge.
TEST(Composite, SharedPartsOfSigmaMergeAsCorrelatedErrors) {
  const int n = planeMap(0, 0, 0, 0.01).grid().rows;  // the maps are n × n
  ASSERT_EQ(planeMap(0, 0, 0, 0.01).grid().cols, n);
  const Raster<float> none = Raster<float>::Zero(n, n);
  {
    ElevationMap composite = planeMap(0.3, 0, 0, 0.015);
    Raster<float> shared = Raster<float>::Constant(n, n, 0.015f);
    const ElevationMap same = composite;
    mergeInto(composite, shared, same, shared);
    EXPECT_NEAR(composite.sigma()(3, 4), 0.015, 1e-9);
    EXPECT_NEAR(shared(3, 4), 0.015, 1e-9);
  }
  {
    ElevationMap a = planeMap(0.2, -0.1, 0.5, 0.01, 0.01), b = a;
    Raster<float> sa = none;
    mergeInto(a, sa, planeMap(0.2, -0.1, 0.5, 0.02, -0.02), none);
    mergeInto(b, planeMap(0.2, -0.1, 0.5, 0.02, -0.02));
    EXPECT_NEAR(a.sigma()(5, 6), b.sigma()(5, 6), 1e-9);
    EXPECT_EQ(a.elevation()(5, 6), b.elevation()(5, 6));
  }
  // σ₁ = 1 cm (0.6 shared), σ₂ = 2 cm (1.2 shared): w = (0.8, 0.2).
  ElevationMap composite = planeMap(0.2, -0.1, 0.5, 0.01);
  Raster<float> shared = Raster<float>::Constant(n, n, 0.006f);
  mergeInto(composite, shared, planeMap(0.2, -0.1, 0.5, 0.02), Raster<float>::Constant(n, n, 0.012f));
  const double w1 = 0.8, w2 = 0.2, s1 = 0.006, s2 = 0.012;
  const double s = w1 * s1 + w2 * s2;
  const double var = w1 * w1 * (1e-4 - s1 * s1) + w2 * w2 * (4e-4 - s2 * s2) + s * s;
  EXPECT_NEAR(composite.sigma()(7, 8), std::sqrt(var), 1e-7);
  EXPECT_NEAR(shared(7, 8), s, 1e-7);
  EXPECT_GT(composite.sigma()(7, 8), 0.02 / std::sqrt(5.0));  // more than eq. 9's independent σ
  EXPECT_THROW(mergeInto(composite, shared, planeMap(0, 0, 0, 0.01), Raster<float>::Zero(3, 3)),
               std::invalid_argument);
}

TEST(Composite, StatesCombineAsStated) {
  // Cell k of a 3×3 grid pairs state k / 3 of the composite with state k % 3 of the map
  // (0 Unseen, 1 Known, 2 Shadow); Known cells z = 1 + row, σ 0.1; shadows have ceilings 2 and 3.
  const MapGrid g = MapGrid::covering(0, 3, 0, 3, 1);
  ElevationMap a(g), b(g);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const auto set = [&](ElevationMap& m, int r, int c, int state, float ceiling) {
    if (state == 1) m.setKnown(r, c, 1.f + r, 0.1f);
    if (state == 2) m.setShadow(r, c, ceiling);
  };
  for (int k = 0; k < 9; ++k) {
    set(a, k / 3, k % 3, k / 3, 3.f);
    set(b, k / 3, k % 3, k % 3, 2.f);
  }
  mergeInto(a, b);
  const CellState U = CellState::Unseen, K = CellState::Known, S = CellState::Shadow;
  const CellState expected[9] = {U, K, S,   // composite unseen: the map's state
                                 K, K, K,   // composite known: known (merged with a known)
                                 S, K, S};  // composite shadow: the map's known beats it
  for (int k = 0; k < 9; ++k) EXPECT_EQ(a.stateAt(k / 3, k % 3), expected[k]) << k;
  EXPECT_FLOAT_EQ(a.shadowCeiling()(2, 2), 2.f);  // two shadows: the lower ceiling
  EXPECT_FLOAT_EQ(a.shadowCeiling()(2, 0), 3.f);  // shadow and unseen: the shadow's
  EXPECT_FLOAT_EQ(a.shadowCeiling()(0, 2), 2.f);
  EXPECT_NEAR(a.sigma()(1, 1), 0.1 / std::sqrt(2.0), 1e-7);  // two knowns merged
  // A ceiling that says nothing (NaN) does not replace one that does.
  ElevationMap c(g), d(g);
  c.setShadow(0, 0, 1.5f);
  d.setShadow(0, 0, nan);
  mergeInto(c, d);
  EXPECT_FLOAT_EQ(c.shadowCeiling()(0, 0), 1.5f);
  EXPECT_THROW(mergeInto(c, planeMap(0, 0, 0, 0.1)), std::invalid_argument);
}

TEST(Composite, PoseCovarianceGivesTheTiltedPlanesClosedForm) {
  // ν = 0: A(p) = [p × e_k, −I], so with n = (−a, 0, 1) (n_z = 1) and P = diag(σ_r², σ_t²),
  // σ² = σ_r²·Σ_k (n·(p × e_k))² + σ_t²·|n|² = σ_r²·|n × p|² + σ_t²·(1 + a²).
  const double a = 0.4, c = 0.3, sr = 0.2 * kDeg, st = 0.01;
  const ElevationMap map = planeMap(a, 0, c, 0.01);
  Matrix6d P = Matrix6d::Zero();
  P.diagonal() << sr * sr, sr * sr, sr * sr, st * st, st * st, st * st;
  const Raster<float> s = registrationSigma(map, PoseVector::Zero(), P);
  const MapGrid& g = map.grid();
  const Eigen::Vector3d n(-a, 0, 1);
  for (int r = 2; r < g.rows - 2; r += 6)  // away from the border, where the slope is one-sided
    for (int col = 2; col < g.cols - 2; col += 6) {
      const Eigen::Vector2d xy = g.center(r, col);
      const Eigen::Vector3d p(xy.x(), xy.y(), map.elevation()(r, col));
      const double expected = std::sqrt(sr * sr * n.cross(p).squaredNorm() + st * st * n.squaredNorm());
      EXPECT_NEAR(s(r, col), expected, 1e-6 * expected + 1e-9) << r << " " << col;
    }
}

TEST(Composite, PoseCovarianceMatchesTheMovedPlaneAtAnyPose) {
  // ν ≠ 0 (20° of yaw, a tilt, a shift). The world surface the view gives is exp(ν)⁻¹ applied to
  // what it saw, q = exp(ν̂)·(plane), so under ν̂ + δ the plane is M = exp(ν̂ + δ)⁻¹·exp(ν̂) of
  // the true one; its height at (x, y) differentiated centrally per component gives J, σ² = J·P·Jᵀ.
  const double a = 0.25, b = -0.15, c = 0.2;
  const ElevationMap map = planeMap(a, b, c, 0.01);
  PoseVector nu;
  nu << 0.02, -0.03, 20 * kDeg, 1.0, -0.5, 0.05;
  Matrix6d L = Matrix6d::Zero();
  L.diagonal() << 0.002, 0.003, 0.004, 0.01, 0.02, 0.005;
  L(5, 0) = 0.001, L(3, 2) = -0.002;
  const Matrix6d P = L * L.transpose();
  const Raster<float> s = registrationSigma(map, nu, P);
  const Eigen::Vector3d n0 = Eigen::Vector3d(-a, -b, 1);  // the plane n0·p = c
  const auto height = [&](const PoseVector& v, double x, double y) {
    const Eigen::Isometry3d M = poseFromVector(v).inverse() * poseFromVector(nu);
    const Eigen::Vector3d n = M.linear() * n0;
    const double d = c + n.dot(M.translation());
    return (d - n.x() * x - n.y() * y) / n.z();
  };
  const MapGrid& g = map.grid();
  for (int r = 3; r < g.rows - 3; r += 9)
    for (int col = 3; col < g.cols - 3; col += 9) {
      const Eigen::Vector2d xy = g.center(r, col);
      Eigen::Matrix<double, 1, 6> J;
      for (int k = 0; k < 6; ++k) {
        const double h = 1e-6;
        PoseVector up = nu, down = nu;
        up(k) += h, down(k) -= h;
        J(k) = (height(up, xy.x(), xy.y()) - height(down, xy.x(), xy.y())) / (2 * h);
      }
      const double expected = std::sqrt(double(J * P * J.transpose()));
      EXPECT_NEAR(s(r, col), expected, 1e-4 * expected) << r << " " << col;
    }
}

TEST(Composite, AddSigmaIsInQuadrature) {
  ElevationMap m = planeMap(0, 0, 0, 0.03);
  Raster<float> extra = Raster<float>::Constant(m.grid().rows, m.grid().cols, 0.04f);
  extra(0, 0) = std::numeric_limits<float>::quiet_NaN();
  addSigma(m, extra);
  EXPECT_NEAR(m.sigma()(1, 1), 0.05, 1e-7);
  EXPECT_FLOAT_EQ(m.sigma()(0, 0), 0.03f);
  EXPECT_THROW(addSigma(m, Raster<float>::Zero(2, 2)), std::invalid_argument);
}

}  // namespace
}  // namespace ambler::perception
