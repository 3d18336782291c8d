// The composite's placements (perception/placement.hpp): views chained through accepted links
// only, forward (view 0 → 1 → 2), in reverse (I = P_J·T_IJ⁻¹) and past a rejected link, each
// against the pose composed by hand from the links and against the true poses when every link's ν
// is the exact correction; and the σ a link's covariance adds: the registrationSigma closed form
// for a forward step from the reference, and a Monte-Carlo of the placement itself for a reverse
// step in a composite frame other than the registration's (where registrationSigma with the
// link's ν is wrong: the negative control).
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

// Three views along a traverse: where they are (S_k), where the rover believes views 1 and 2 are
// (decimetres and degrees off), and two corrections that are not the exact ones (so a link's
// relative pose is not the truth's and a wrong composition shows).
struct Traverse {
  Eigen::Isometry3d S[3] = {sensorPose({0, -6, 3}, {0, -30 * kDeg, 0}),
                            sensorPose({0.8, -4.5, 3.1}, {0.02, -28 * kDeg, 9 * kDeg}),
                            sensorPose({1.9, -3.2, 2.9}, {-0.01, -31 * kDeg, 21 * kDeg})};
  Eigen::Isometry3d B[3] = {
      S[0], Eigen::Translation3d(0.3, -0.2, 0.05) * S[1] * Eigen::AngleAxisd(4 * kDeg, Eigen::Vector3d::UnitZ()),
      Eigen::Translation3d(-0.25, 0.35, -0.04) * S[2] * Eigen::AngleAxisd(-6 * kDeg, Eigen::Vector3d::UnitX())};
  // ν for link (i, j) registered with view I at S_i: exact, exp(ν)⁻¹·B_j = S_j; or that and a
  // deliberate error.
  PoseVector exact(int j) const { return vectorFromPose(B[j] * S[j].inverse()); }
  PoseVector off(int j) const {
    PoseVector e;
    e << 0.004 * j, -0.003, 0.02 * j, 0.07, -0.05 * j, 0.02;
    return exact(j) + e;
  }
};

// Link (i, j)'s relative pose composed by hand: T_IJ = S_i⁻¹·exp(ν)⁻¹·B_j (view I where map I was
// registered from; sensor J corrected in that frame).
Eigen::Isometry3d handRelative(const Traverse& t, int i, int j, const PoseVector& nu) {
  return t.S[i].inverse() * poseFromVector(nu).inverse() * t.B[j];
}

// Every tolerance below is 1e-12 on the 4×4 matrices: entries are rotations (≤ 1) and translations
// of ≤ 7 m, each composed of at most six isometry products and one exp/log round trip, each
// rounding by a few ε = 2.2e-16 of its operands' size: 7 m·6·4ε ≈ 4e-14, with room.
constexpr double kPoseTol = 1e-12;

TEST(Placement, ChainedForwardEachViewIsThePreviousTimesItsLink) {
  const Traverse t;
  // Link (1, 2) listed before (0, 1): view 2 is placed in the second pass, once view 1 is.
  const std::vector<PlacementLink> links{link(1, 2, t.S[1], t.B[2], t.off(2)), link(0, 1, t.S[0], t.B[1], t.off(1))};
  const std::vector<ViewPlacement> p = placeViews(3, 0, t.S[0], links);
  const Eigen::Isometry3d T01 = handRelative(t, 0, 1, t.off(1)), T12 = handRelative(t, 1, 2, t.off(2));
  ASSERT_EQ(p[1].how, PlacementHow::Matched);
  ASSERT_EQ(p[2].how, PlacementHow::Matched);
  EXPECT_TRUE(p[0].T_WS.matrix() == t.S[0].matrix());  // the reference where it was put
  EXPECT_TRUE(near(p[1].T_WS, t.S[0] * T01, kPoseTol));
  EXPECT_TRUE(near(p[2].T_WS, t.S[0] * T01 * T12, kPoseTol));
  // View 2's chain: (0, 1) then (1, 2), both forward, each from where the view it starts at is.
  ASSERT_EQ(p[2].chain.size(), 2u);
  EXPECT_EQ(p[2].chain[0].link, &links[1]);
  EXPECT_EQ(p[2].chain[1].link, &links[0]);
  EXPECT_FALSE(p[2].chain[0].reverse);
  EXPECT_FALSE(p[2].chain[1].reverse);
  EXPECT_TRUE(p[2].chain[0].from_WS.matrix() == t.S[0].matrix());
  EXPECT_TRUE(near(p[2].chain[1].from_WS, t.S[0] * T01, kPoseTol));
  // Exact corrections chain to the true poses: P_1 = S_0·S_0⁻¹·S_1, P_2 = S_1·S_1⁻¹·S_2.
  const std::vector<PlacementLink> exact{link(0, 1, t.S[0], t.B[1], t.exact(1)),
                                         link(1, 2, t.S[1], t.B[2], t.exact(2))};
  const std::vector<ViewPlacement> q = placeViews(3, 0, t.S[0], exact);
  EXPECT_TRUE(near(q[1].T_WS, t.S[1], kPoseTol));
  EXPECT_TRUE(near(q[2].T_WS, t.S[2], kPoseTol));
}

TEST(Placement, ChainedInReverseViewIIsViewJTimesTheInverseLink) {
  const Traverse t;
  // View 2 the reference: link (1, 2) places view 1 as P_1 = P_2·T_12⁻¹, then (0, 1) view 0 as
  // P_0 = P_1·T_01⁻¹.
  const std::vector<PlacementLink> links{link(0, 1, t.S[0], t.B[1], t.off(1)), link(1, 2, t.S[1], t.B[2], t.off(2))};
  const std::vector<ViewPlacement> p = placeViews(3, 2, t.S[2], links);
  const Eigen::Isometry3d T01 = handRelative(t, 0, 1, t.off(1)), T12 = handRelative(t, 1, 2, t.off(2));
  EXPECT_EQ(p[2].how, PlacementHow::Reference);
  ASSERT_EQ(p[1].how, PlacementHow::Matched);
  ASSERT_EQ(p[0].how, PlacementHow::Matched);
  EXPECT_TRUE(near(p[1].T_WS, t.S[2] * T12.inverse(), kPoseTol));
  EXPECT_TRUE(near(p[0].T_WS, t.S[2] * T12.inverse() * T01.inverse(), kPoseTol));
  ASSERT_EQ(p[0].chain.size(), 2u);
  EXPECT_EQ(p[0].chain[0].link, &links[1]);
  EXPECT_EQ(p[0].chain[1].link, &links[0]);
  EXPECT_TRUE(p[0].chain[0].reverse);
  EXPECT_TRUE(p[0].chain[1].reverse);
  EXPECT_TRUE(near(p[0].chain[1].from_WS, t.S[2] * T12.inverse(), kPoseTol));
  // Exact corrections: P_1 = S_2·(S_1⁻¹·S_2)⁻¹ = S_1, P_0 = S_1·(S_0⁻¹·S_1)⁻¹ = S_0.
  const std::vector<PlacementLink> exact{link(0, 1, t.S[0], t.B[1], t.exact(1)),
                                         link(1, 2, t.S[1], t.B[2], t.exact(2))};
  const std::vector<ViewPlacement> q = placeViews(3, 2, t.S[2], exact);
  EXPECT_TRUE(near(q[1].T_WS, t.S[1], kPoseTol));
  EXPECT_TRUE(near(q[0].T_WS, t.S[0], kPoseTol));
}

TEST(Placement, ARejectedLinkPlacesNothingAndAnotherAcceptedLinkPlacesItsView) {
  const Traverse t;
  // (0, 1) accepted, (1, 2) rejected: view 2 is reached by no accepted link, so it is left out.
  std::vector<PlacementLink> links{link(1, 2, t.S[1], t.B[2], t.off(2), false), link(0, 1, t.S[0], t.B[1], t.off(1))};
  const std::vector<ViewPlacement> p = placeViews(3, 0, t.S[0], links);
  EXPECT_EQ(p[1].how, PlacementHow::Matched);
  EXPECT_EQ(p[2].how, PlacementHow::LeftOut);
  EXPECT_TRUE(p[2].chain.empty());
  // Add (2, 1), accepted: view 2 is placed through it in reverse from view 1, P_2 = P_1·T_21⁻¹,
  // and not where the rejected (1, 2) would have put it, P_1·T_12.
  links.push_back(link(2, 1, t.S[2], t.B[1], t.off(1)));
  const std::vector<ViewPlacement> q = placeViews(3, 0, t.S[0], links);
  const Eigen::Isometry3d T01 = handRelative(t, 0, 1, t.off(1));
  const Eigen::Isometry3d T21 = handRelative(t, 2, 1, t.off(1));
  const Eigen::Isometry3d T12 = handRelative(t, 1, 2, t.off(2));
  ASSERT_EQ(q[2].how, PlacementHow::Matched);
  EXPECT_TRUE(near(q[2].T_WS, t.S[0] * T01 * T21.inverse(), kPoseTol));
  EXPECT_FALSE(near(q[2].T_WS, t.S[0] * T01 * T12, 1e-3));
  ASSERT_EQ(q[2].chain.size(), 2u);
  EXPECT_EQ(q[2].chain[0].link, &links[1]);
  EXPECT_FALSE(q[2].chain[0].reverse);
  EXPECT_EQ(q[2].chain[1].link, &links[2]);
  EXPECT_TRUE(q[2].chain[1].reverse);
  // Nothing accepted reaches a view: everything but the reference is left out.
  for (PlacementLink& l : links) l.accepted = false;
  const std::vector<ViewPlacement> none = placeViews(3, 0, t.S[0], links);
  EXPECT_EQ(none[0].how, PlacementHow::Reference);
  EXPECT_EQ(none[1].how, PlacementHow::LeftOut);
  EXPECT_EQ(none[2].how, PlacementHow::LeftOut);
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
