// The composite's placements (perception/placement.hpp): views chained through accepted links
// only, forward and reverse poses by their closed form, and the σ a link's covariance adds: the
// registrationSigma closed form for a forward step from the reference, and a Monte-Carlo of the
// placement itself for a reverse step in a composite frame other than the registration's (where
// registrationSigma with the link's ν is wrong: the negative control).
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include "perception/composite.hpp"
#include "perception/placement.hpp"
#include "perception/sensor_geometry.hpp"
#include "synthetic.hpp"

namespace ambler::perception {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

PlacementLink link(int i, int j, const Eigen::Isometry3d& T_WS_i, const Eigen::Isometry3d& believed_WS_j,
                   const PoseVector& nu, bool accepted = true) {
  PlacementLink l;
  l.i = i, l.j = j, l.T_WS_i = T_WS_i, l.believed_WS_j = believed_WS_j, l.nu = nu, l.accepted = accepted;
  return l;
}

PoseVector someNu() {
  PoseVector nu;
  nu << 0.01, -0.02, 20 * kDeg, 3.0, -1.5, 0.1;  // a large correction: where the two forms differ
  return nu;
}

bool near(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b, double tol) {
  return (a.matrix() - b.matrix()).cwiseAbs().maxCoeff() < tol;
}

TEST(Placement, ChainsThroughAcceptedLinksAndLeavesTheRestOut) {
  const Eigen::Isometry3d P0 = sensorPose({0, -6, 3}, {0, -30 * kDeg, 0});
  const Eigen::Isometry3d B1 = sensorPose({0.2, -5, 3}, {0, -30 * kDeg, 4 * kDeg});
  const Eigen::Isometry3d B2 = sensorPose({0.4, -4, 3}, {0, -30 * kDeg, -2 * kDeg});
  const Eigen::Isometry3d P3 = sensorPose({1, -3, 3}, {0, -30 * kDeg, 10 * kDeg});
  // 0→1 accepted; 1→2 rejected; 2 is not reached. 3→0 accepted: 3 placed in reverse? No: link
  // (3, 0) places 3 from 0 as I = P_0·T⁻¹.
  const std::vector<PlacementLink> links{link(0, 1, P0, B1, someNu()), link(1, 2, B1, B2, PoseVector::Zero(), false),
                                         link(3, 0, P3, P0 * Eigen::Translation3d(0.1, 0, 0), someNu() * 0.1)};
  const std::vector<ViewPlacement> p = placeViews(4, 0, P0, links);
  EXPECT_EQ(p[0].how, PlacementHow::Reference);
  EXPECT_EQ(p[1].how, PlacementHow::Matched);
  EXPECT_EQ(p[2].how, PlacementHow::LeftOut);
  EXPECT_EQ(p[3].how, PlacementHow::Matched);
  // Forward: P_1 = P_0·T_01; reverse: P_3 = P_0·T_30⁻¹.
  EXPECT_TRUE(near(p[1].T_WS, P0 * links[0].relative(), 1e-12));
  EXPECT_TRUE(near(p[3].T_WS, P0 * links[2].relative().inverse(), 1e-12));
  ASSERT_EQ(p[3].chain.size(), 1u);
  EXPECT_TRUE(p[3].chain[0].reverse);
  EXPECT_FALSE(p[1].chain[0].reverse);
  // With view 0 at its registered pose, P_1 is exp(ν)⁻¹·believed (registerViews' convention).
  EXPECT_TRUE(near(p[1].T_WS, poseFromVector(someNu()).inverse() * B1, 1e-12));
  EXPECT_STREQ(placementHowName(p[2].how), "left_out");
}

// A map with slopes in both directions (the dome), its σ from P = diag of a few mm and mrad.
Matrix6d someCovariance() {
  PoseVector d;
  d << 1e-3, 2e-3, 3e-3, 0.01, 0.02, 0.005;
  Matrix6d P = Matrix6d(d.cwiseProduct(d).asDiagonal());
  P(2, 3) = P(3, 2) = 0.3 * d(2) * d(3);  // a correlation, so off-diagonal terms count
  return P;
}

TEST(Placement, AForwardStepFromTheReferenceIsRegistrationSigma) {
  const ElevationMap map = test::domeMap(test::Dome{});
  const Eigen::Isometry3d P0 = sensorPose({0, -6, 3}, {0, -30 * kDeg, 0});
  PlacementLink l = link(0, 1, P0, sensorPose({0.2, -5, 3}, {0, -30 * kDeg, 4 * kDeg}), someNu());
  l.covariance = someCovariance();
  const std::vector<PlacementLink> links{l};
  const std::vector<ViewPlacement> p = placeViews(2, 0, P0, links);
  const Raster<float> a = placementSigma(map, p[1].chain);
  const Raster<float> b = registrationSigma(map, l.nu, *l.covariance);
  // Central differences of G with h = 1e-6: relative error about h² and rounding ε·|p|/h ≈ 1e-9.
  double worst = 0;
  for (int r = 0; r < map.grid().rows; ++r)
    for (int c = 0; c < map.grid().cols; ++c) worst = std::max(worst, double(std::abs(a(r, c) - b(r, c)) / b(r, c)));
  EXPECT_LT(worst, 1e-5);
}

TEST(Placement, AReverseStepsSigmaIsThePlacementsSpread) {
  const ElevationMap map = test::domeMap(test::Dome{});
  // View 1 is the reference here (at P1); view 0 is placed from it by link (0, 1) in reverse.
  const Eigen::Isometry3d T_WS_0 = sensorPose({-4, -9, 3}, {0, -30 * kDeg, -25 * kDeg});
  const Eigen::Isometry3d B1 = sensorPose({0.2, -5, 3}, {0, -30 * kDeg, 4 * kDeg});
  PlacementLink l = link(0, 1, T_WS_0, B1, someNu());
  l.covariance = someCovariance();
  const std::vector<PlacementLink> links{l};
  // The composite's frame is not the one link (0, 1) was registered in: view 1 placed 60° and
  // 2 m from where the registration put it. (With P1 = exp(ν)⁻¹·B1 the reverse step's motion is
  // the inverse of registrationSigma's, the same σ to first order; here the two differ.)
  const Eigen::Isometry3d frame = Eigen::Translation3d(2.0, -1.0, 0.0) * Eigen::AngleAxisd(60 * kDeg, Eigen::Vector3d::UnitZ());
  const Eigen::Isometry3d P1 = frame * poseFromVector(someNu()).inverse() * B1;
  const std::vector<ViewPlacement> p = placeViews(2, 1, P1, links);
  ASSERT_EQ(p[0].how, PlacementHow::Matched);
  const Raster<float> predicted = placementSigma(map, p[0].chain);
  // σ in the frame the link was registered in (view J's ν): not this composite's, the negative control.
  const Raster<float> wrong = registrationSigma(map, l.nu, *l.covariance);
  // Monte Carlo of the placement itself: P_0(δ) = P_1·T_01(ν + δ)⁻¹ moves each map point p to
  // P_0(δ)·P_0⁻¹·p; the surface moves vertically by n·Δp/n_z. 20 000 draws: the sample σ errs by
  // 1/√(2·20 000) = 0.5 % (1σ), so 2.5 % is five σ, and the first order's own error is ~|δ|.
  const std::vector<Eigen::Vector3d> normals = referenceNormals(map);
  const Eigen::LLT<Matrix6d> llt(*l.covariance);
  const Matrix6d L = llt.matrixL();
  std::mt19937 rng(5);
  std::normal_distribution<double> n01;
  const int draws = 20000;
  const MapGrid& g = map.grid();
  std::vector<int> cells{0, g.cols - 1, (g.rows / 2) * g.cols + g.cols / 2, (g.rows - 1) * g.cols + 3, int(g.cells()) - 1};
  std::vector<double> sum2(cells.size(), 0.0);
  const Eigen::Isometry3d P0 = p[0].T_WS;
  for (int k = 0; k < draws; ++k) {
    PoseVector z;
    for (int i = 0; i < 6; ++i) z(i) = n01(rng);
    const Eigen::Isometry3d moved = P1 * l.relative(L * z).inverse() * P0.inverse();
    for (std::size_t q = 0; q < cells.size(); ++q) {
      const int r = cells[q] / g.cols, c = cells[q] % g.cols;
      Eigen::Vector3d n = normals[std::size_t(cells[q])];
      if (!n.allFinite()) n = Eigen::Vector3d::UnitZ();
      const Eigen::Vector3d pt(g.center(r, c).x(), g.center(r, c).y(), map.elevation()(r, c));
      const double dz = n.dot(moved * pt - pt) / n.z();
      sum2[q] += dz * dz;
    }
  }
  int wrong_differs = 0;
  for (std::size_t q = 0; q < cells.size(); ++q) {
    const int r = cells[q] / g.cols, c = cells[q] % g.cols;
    const double mc = std::sqrt(sum2[q] / draws);
    EXPECT_NEAR(predicted(r, c), mc, 0.025 * mc) << "cell " << r << ", " << c;
    wrong_differs += std::abs(wrong(r, c) - mc) > 0.1 * mc;
  }
  EXPECT_GE(wrong_differs, 3) << "the registration frame's σ should be far off somewhere (the negative control)";
}

}  // namespace
}  // namespace ambler::perception
