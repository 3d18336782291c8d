// Composite maps (paper §4.3): eq. 9 and its σ on two maps of a plane against the closed form,
// the state rules cell by cell, a map merged with itself halving the variance; the σ a pose's
// covariance adds to a tilted plane against its closed form (ν = 0) and against finite
// differences of the moved plane (ν ≠ 0); buildComposite on two scans of a plane: eq. 9 of the
// single views' composites, the shared σ_rough counted once for a view merged with itself, a
// placement's σ added in quadrature, a left-out view contributing nothing.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "perception/composite.hpp"
#include "perception/placement.hpp"
#include "perception/scan_to_map.hpp"
#include "perception/sensor_geometry.hpp"
#include "synthetic.hpp"

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

// A shared part of 0.03 (or none, NaN) grown by 0.04 is 0.05 (0.04), held at the cell's σ; NaN extra
// leaves it as it was.
TEST(Composite, AddSharedIsInQuadratureAndAtMostTheCellsSigma) {
  ElevationMap m = planeMap(0, 0, 0, 0.06);
  const int R = m.grid().rows, C = m.grid().cols;
  Raster<float> shared = Raster<float>::Constant(R, C, 0.03f);
  shared(1, 2) = std::numeric_limits<float>::quiet_NaN();
  Raster<float> extra = Raster<float>::Constant(R, C, 0.04f);
  extra(0, 0) = std::numeric_limits<float>::quiet_NaN();
  extra(2, 1) = 0.08f;  // √(0.03² + 0.08²) = 0.085 > σ = 0.06
  addShared(shared, m, extra);
  EXPECT_NEAR(shared(1, 1), 0.05, 1e-7);
  EXPECT_NEAR(shared(1, 2), 0.04, 1e-7);
  EXPECT_FLOAT_EQ(shared(2, 1), 0.06f);
  EXPECT_FLOAT_EQ(shared(0, 0), 0.03f);
  EXPECT_THROW(addShared(shared, m, Raster<float>::Zero(2, 2)), std::invalid_argument);
}

// ---- buildComposite on scans of a plane.

constexpr double kU = 0x1p-24;  // unit round-off of float32: the maps' stored elevations and σ

const test::Plane kPlane{0.05, -0.03, 0.1};

// Range noise k·ρ² with k = 2e-5 (σ_ρ ≈ 1 mm at 7 m) so that σ's noise part and its roughness
// part (about 1 mm here) are of one size; no quantisation or wrap (the synthetic image is exact
// and unfolded); mixed pixels on, so the footprint's term is part of σ_rough where the composite
// asks for it.
SensorModel planeSensor() {
  SensorModel s;
  s.noise_k = 2e-5;
  s.quantization_m = 0;
  s.ambiguity_m = 0;
  return s;
}

// The composite's grid, 10 m × 4 m at 10 cm, 5–11 m in front of both sensors, which stand 3 m up:
// each sees a few hundred cells at the sides that the other does not.
MapGrid compositeGrid() { return MapGrid::covering(-5, 5, -1, 3, 0.1); }
const Eigen::Isometry3d kS1 = sensorPose({-0.5, -6, 3}, Eigen::Vector3d(0, -25, 5) * kDeg);
const Eigen::Isometry3d kS2 = sensorPose({1.0, -5, 3.2}, Eigen::Vector3d(0, -28, -10) * kDeg);

// The plane's exact image from T_WS, as the rover maps it (no edges: a plane has none).
ScanMap planeScan(const Eigen::Isometry3d& T_WS) {
  ScanToMapConfig c;
  c.shadows = ShadowMethod::None;
  return scanToMap(test::planeImage(kPlane, T_WS), planeSensor(), T_WS, compositeGrid(), c);
}

LocusConfig compositeLocus(bool roughness) {
  LocusConfig c;
  c.roughness = roughness;
  return c;
}

ViewPlacement at(const Eigen::Isometry3d& T_WS, PlacementHow how = PlacementHow::True) { return {how, T_WS, {}}; }
// Left out, though its pose is one the view maps well from: the pose must not be used.
ViewPlacement leftOut(const Eigen::Isometry3d& T_WS) { return {PlacementHow::LeftOut, T_WS, {}}; }

using test::sameBits;

// With σ's roughness part off nothing is shared (σ_rough = 0), so two views merge by eq. 9 itself:
// each cell both know is (σ₂²·z₁ + σ₁²·z₂)/(σ₁² + σ₂²) with σ² = σ₁²σ₂²/(σ₁² + σ₂²), z_k and σ_k
// the single views' composites (each with the other view left out); a cell one knows is that one's.
// Both stored as float from a double computation of the same float inputs: within half an ulp,
// u·|value| (u = 2⁻²⁴), and the double's own rounding (≈ 1e-16 relative) below that; 2u. The
// elevation is the plane's within 2 mm (bilinear interpolation of ρ between pixels at ≥ 10° of
// grazing and ρ ≤ 15 m, test_scan_to_map.cpp; here ρ ≤ 11 m and the beams meet the plane at
// ≥ 14°), as a weighted mean of two such values.
TEST(Composite, BuildCompositeMergesTwoScansOfAPlaneByEquationNine) {
  const ScanMap v1 = planeScan(kS1), v2 = planeScan(kS2);
  const MapGrid grid = compositeGrid();
  const LocusConfig locus = compositeLocus(false);
  const ElevationMap c1 = buildComposite({&v1, &v2}, {at(kS1, PlacementHow::Reference), leftOut(kS2)}, grid, locus);
  const ElevationMap c2 = buildComposite({nullptr, &v2}, {leftOut(kS1), at(kS2)}, grid, locus);
  const ElevationMap both = buildComposite({&v1, &v2}, {at(kS1, PlacementHow::Reference), at(kS2)}, grid, locus);
  // A left-out view contributes nothing: the composite is view 1's alone, bit for bit.
  EXPECT_TRUE(sameBits(c1, buildComposite({&v1}, {at(kS1, PlacementHow::Reference)}, grid, locus)));
  int merged = 0, single = 0;
  for (int r = 0; r < grid.rows; ++r)
    for (int c = 0; c < grid.cols; ++c) {
      const bool k1 = c1.stateAt(r, c) == CellState::Known, k2 = c2.stateAt(r, c) == CellState::Known;
      ASSERT_EQ(both.stateAt(r, c), k1 || k2 ? CellState::Known : CellState::Unseen) << r << " " << c;
      if (k1 != k2) {
        const ElevationMap& one = k1 ? c1 : c2;
        EXPECT_EQ(both.elevation()(r, c), one.elevation()(r, c));
        EXPECT_EQ(both.sigma()(r, c), one.sigma()(r, c));
        ++single;
      }
      if (!k1 || !k2) continue;
      ++merged;
      const double z1 = c1.elevation()(r, c), z2 = c2.elevation()(r, c);
      const double v1s = double(c1.sigma()(r, c)) * c1.sigma()(r, c), v2s = double(c2.sigma()(r, c)) * c2.sigma()(r, c);
      const double z = (v2s * z1 + v1s * z2) / (v1s + v2s), sigma = std::sqrt(v1s * v2s / (v1s + v2s));
      EXPECT_NEAR(both.elevation()(r, c), z, 2 * kU * std::abs(z)) << r << " " << c;
      EXPECT_NEAR(both.sigma()(r, c), sigma, 2 * kU * sigma) << r << " " << c;
      const Eigen::Vector2d p = grid.center(r, c);
      EXPECT_NEAR(both.elevation()(r, c), kPlane.z(p.x(), p.y()), 2e-3) << r << " " << c;
    }
  // Both views cover most of the grid, each some cells the other misses.
  EXPECT_GT(merged, grid.rows * grid.cols / 2);
  EXPECT_GT(single, 0);
}

// σ_rough (the terrain's part, the footprint's term in it: LocusConfig::footprint_sigma, which the
// composite turns on) is shared by every view of a cell, the rest independent (docs/composite.md,
// "What the views share"). The same scan placed twice at the same pose merges with w = ½ each:
// z its own, σ_s = s, σ² = ¼(σ² − s²)·2 + s² = σ² − σ_n²/2 with s² = σ² − σ_n² (σ the single
// composite's, σ_n the same without roughness): eq. 9's σ²/2 for the independent part only.
// Float rounding: σ, σ_n stored (u relative each), s² formed in float from them (cancellation
// leaves an absolute error ≲ 2u·σ²), σ² halved and stored: |Δσ| ≲ (2u·σ²)/(2σ_m) + u·σ_m ≤ 3u·σ
// (σ_m ≥ σ/√2); 4u·σ.
TEST(Composite, BuildCompositeCountsTheSharedRoughnessOnce) {
  const ScanMap v1 = planeScan(kS1);
  const MapGrid grid = compositeGrid();
  const LocusConfig rough = compositeLocus(true);
  const ElevationMap single = buildComposite({&v1}, {at(kS1, PlacementHow::Reference)}, grid, rough);
  const ElevationMap noise = buildComposite({&v1}, {at(kS1, PlacementHow::Reference)}, grid, compositeLocus(false));
  const ElevationMap twice = buildComposite({&v1, &v1}, {at(kS1, PlacementHow::Reference), at(kS1)}, grid, rough);
  // The footprint's term is the composite's whatever the caller's config says (`rough` has it off).
  ASSERT_FALSE(rough.footprint_sigma);
  LocusConfig with_footprint = rough;
  with_footprint.footprint_sigma = true;
  EXPECT_TRUE(sameBits(single, buildComposite({&v1}, {at(kS1, PlacementHow::Reference)}, grid, with_footprint)));
  int known = 0, shared_counts = 0;
  for (int r = 0; r < grid.rows; ++r)
    for (int c = 0; c < grid.cols; ++c) {
      if (single.stateAt(r, c) != CellState::Known) continue;
      ASSERT_EQ(noise.stateAt(r, c), CellState::Known);
      ASSERT_EQ(twice.stateAt(r, c), CellState::Known);
      ++known;
      const double s = single.sigma()(r, c), n = noise.sigma()(r, c);
      const double expected = std::sqrt(s * s - 0.5 * n * n);
      EXPECT_EQ(twice.elevation()(r, c), single.elevation()(r, c));
      EXPECT_NEAR(twice.sigma()(r, c), expected, 4 * kU * s) << r << " " << c;
      // Where the shared part is not negligible, eq. 9's independent σ/√2 is well off.
      shared_counts += std::abs(expected - s / std::sqrt(2.0)) > 0.05 * expected;
    }
  EXPECT_GT(known, grid.rows * grid.cols / 2);
  EXPECT_GT(shared_counts, known / 2) << "σ_rough should be a material part of σ on most cells";
}

// A view placed through a link with a covariance: its cells' σ grow by the placement's σ in
// quadrature, σ² = σ_map² + placementSigma², the map and its σ_map being the same view's at the
// same pose placed with no covariance (its composite alone). √(σ² + e²) in float from stored
// floats: within ≈ 2u·σ.
TEST(Composite, BuildCompositeAddsThePlacementsSigmaInQuadrature) {
  const ScanMap v1 = planeScan(kS1), v2 = planeScan(kS2);
  const MapGrid grid = compositeGrid();
  const LocusConfig locus = compositeLocus(true);
  // Link (0, 1) registered from view 0 at kS1, view 1 believed 0.2 m off and corrected to kS2.
  const Eigen::Isometry3d believed = Eigen::Translation3d(0.2, -0.1, 0) * kS2;
  PlacementLink l;
  l.i = 0, l.j = 1, l.T_WS_i = kS1, l.believed_WS_j = believed, l.nu = vectorFromPose(believed * kS2.inverse());
  PoseVector sd;  // σ of ν: a milliradian or two, a centimetre
  sd << 1e-3, 1e-3, 2e-3, 0.01, 0.01, 0.005;
  l.covariance = Matrix6d(sd.cwiseAbs2().asDiagonal());
  const std::vector<PlacementLink> links{l};
  const std::vector<ViewPlacement> p = placeViews(2, 0, kS1, links);
  ASSERT_EQ(p[1].how, PlacementHow::Matched);
  const ElevationMap placed = buildComposite({nullptr, &v2}, {leftOut(kS1), p[1]}, grid, locus);
  const ElevationMap plain = buildComposite({nullptr, &v2}, {leftOut(kS1), at(p[1].T_WS)}, grid, locus);
  const Raster<float> extra = placementSigma(plain, p[1].chain);
  int known = 0;
  for (int r = 0; r < grid.rows; ++r)
    for (int c = 0; c < grid.cols; ++c) {
      if (plain.stateAt(r, c) != CellState::Known) continue;
      ++known;
      const double s = plain.sigma()(r, c), e = extra(r, c);
      ASSERT_GT(e, 1e-3) << "the link's covariance should add millimetres";
      EXPECT_EQ(placed.elevation()(r, c), plain.elevation()(r, c));
      EXPECT_NEAR(placed.sigma()(r, c), std::sqrt(s * s + e * e), 2 * kU * std::sqrt(s * s + e * e)) << r << " " << c;
    }
  EXPECT_GT(known, grid.rows * grid.cols / 2);
  EXPECT_THROW(buildComposite({&v1}, {at(kS1), at(kS2)}, grid, locus), std::invalid_argument);  // sizes differ
  EXPECT_THROW(buildComposite({nullptr}, {at(kS1)}, grid, locus), std::invalid_argument);       // placed, no scan
}

}  // namespace
}  // namespace ambler::perception
