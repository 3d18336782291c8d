// Features of an elevation map (paper §4.1) on analytic surfaces: a Gaussian bump gives one point
// feature at its centre, a ridge one line of its direction and length, a step one line along its
// lip, a tilted plane none.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <numbers>

#include "perception/features.hpp"

namespace ambler::perception {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

// A map of z(x, y) sampled at the cell centres of a 5 cm grid over [−half, half]², every cell
// known with σ_z = 1 mm (the sensor model's floor).
ElevationMap analyticMap(const std::function<double(double, double)>& z, double half = 2.0, double cell = 0.05) {
  ElevationMap m(MapGrid::covering(-half, half, -half, half, cell));
  for (int r = 0; r < m.grid().rows; ++r)
    for (int c = 0; c < m.grid().cols; ++c) {
      const Eigen::Vector2d p = m.grid().center(r, c);
      m.setKnown(r, c, float(z(p.x(), p.y())), 1e-3f);
    }
  return m;
}

// z = A·exp(−r²/2s²), A = 0.2 m, s = 0.4 m: the most convex curvature is −(A/s²)·exp(−r²/2s²)
// (across the radius, to first order in the slope), −1.25 /m at the centre, so with the default
// threshold of 1 /m the feature cells lie within r = s·√(2·ln 1.25) = 0.27 m: a point (extent
// ≤ 0.4 m). The concave ring beyond r = s is not a convex feature.
TEST(Features, GaussianBumpIsOnePointAtItsCentre) {
  const double A = 0.2, s = 0.4, x0 = 0.3, y0 = -0.2;
  const ElevationMap map = analyticMap([&](double x, double y) {
    return A * std::exp(-((x - x0) * (x - x0) + (y - y0) * (y - y0)) / (2 * s * s));
  });
  const auto features = extractFeatures(map);
  ASSERT_EQ(features.size(), 1u);
  const Feature& f = features[0];
  EXPECT_EQ(f.type, FeatureType::Point);
  // The centre is the curvature-weighted mean of a set symmetric about the peak, to within the
  // grid's offset from it: half a cell.
  EXPECT_NEAR(f.position.x(), x0, 0.025);
  EXPECT_NEAR(f.position.y(), y0, 0.025);
  EXPECT_NEAR(f.extent_m, s * std::sqrt(2 * std::log(1.25)), 0.05 + 0.025);  // one cell and a half
  // Strength: the set's mean |κ| lies between the threshold and the peak's 1.25 /m.
  EXPECT_GT(f.strength, 1.0);
  EXPECT_LT(f.strength, 1.25);
  // The quadratic fit at the peak: 5 × 5 cells (σ_κ ≈ 0.16 /m below 1/3 /m), whose bias is of
  // order (h·cell/s)² = (0.1/0.4)² ≈ 6 %.
  const CurvatureField k = principalCurvatures(map);
  const auto cell = map.grid().cellOf(x0, y0);
  ASSERT_TRUE(cell.has_value());
  EXPECT_NEAR(k.k_convex((*cell)(0), (*cell)(1)), -A / (s * s), 0.06 * A / (s * s));
  EXPECT_EQ(k.half_width((*cell)(0), (*cell)(1)), 2);
}

// A ridge of height A = 0.2 m and width s = 0.4 m along a 2 m crest at 30° to x, with round ends
// (the bump's profile beyond them). Across the crest the most convex curvature is −1.25 /m, so
// the feature strip is |d| ≤ 0.146 m wide ((1 − u)·e^{−u/2} = 0.8 at u = d²/s² = 0.134); past each
// end it reaches 0.27 m further (the bump's radius). One line, along the crest, of length
// 2 + 2·0.27 m plus one cell (the set's ends are cells), ± a cell at each end.
TEST(Features, RidgeIsOneLineOfItsDirectionAndLength) {
  const double A = 0.2, s = 0.4, L = 2.0, angle = 30 * kDeg;
  const Eigen::Vector2d axis(std::cos(angle), std::sin(angle)), normal(-axis.y(), axis.x());
  const ElevationMap map = analyticMap(
      [&](double x, double y) {
        const Eigen::Vector2d p(x, y);
        const double t = p.dot(axis), d = p.dot(normal), past = std::max(0.0, std::abs(t) - L / 2);
        return A * std::exp(-(d * d + past * past) / (2 * s * s));
      },
      3.0);
  const auto features = extractFeatures(map);
  ASSERT_EQ(features.size(), 1u);
  const Feature& f = features[0];
  EXPECT_EQ(f.type, FeatureType::Line);
  // Direction: the PCA axis of a strip of cells, off by at most about atan(cell / length).
  const double off = std::acos(std::min(1.0, std::abs(f.direction.dot(Eigen::Vector3d(axis.x(), axis.y(), 0)))));
  EXPECT_LT(off, std::atan(0.05 / 2.0) + 1e-9);
  EXPECT_NEAR(f.length_m, L + 2 * s * std::sqrt(2 * std::log(1.25)) + 0.05, 2 * 0.05);
  EXPECT_NEAR(f.position.x(), 0.0, 0.05);
  EXPECT_NEAR(f.position.y(), 0.0, 0.05);
}

// A 0.3 m step along y at x = 0 (high side x > 0): the fits that straddle it bend down on the
// high side (the lip, convex) and up on the low side (the foot, concave, not a feature). One line
// along y, on the high side within the window's reach (2 cells), as long as the map (4 m).
TEST(Features, StepIsOneLineAlongItsLip) {
  const ElevationMap map = analyticMap([](double x, double) { return x > 0 ? 0.3 : 0.0; });
  const auto features = extractFeatures(map);
  ASSERT_EQ(features.size(), 1u);
  const Feature& f = features[0];
  EXPECT_EQ(f.type, FeatureType::Line);
  EXPECT_NEAR(std::abs(f.direction.y()), 1.0, 1e-9);  // exactly along the cell columns
  EXPECT_GT(f.position.x(), 0.0);
  EXPECT_LT(f.position.x(), 2 * 0.05 + 1e-9);
  EXPECT_NEAR(f.length_m, 4.0, 1e-9);
}

// A tilted plane has no curvature: no features, whatever its slope.
TEST(Features, TiltedPlaneHasNone) {
  const ElevationMap map = analyticMap([](double x, double y) { return 0.4 * x - 0.7 * y + 1.0; });
  EXPECT_TRUE(extractFeatures(map).empty());
  const CurvatureField k = principalCurvatures(map);
  // Only the float heights' rounding: at most half an ulp of 3.2 m, 1.2e-7 m, through a fit whose
  // second derivative has σ ≈ 0.16 /m per mm of σ_z (5 × 5 cells), i.e. a gain of 160 /m² in RMS
  // and at most √25 times that on a worst-case pattern: 1.2e-7 · 160 · 5 ≈ 1e-4 /m.
  EXPECT_LT(k.k_convex.cwiseAbs().maxCoeff(), 1.2e-7 * 160 * 5);
}

TEST(Features, RefusesBadConfig) {
  const ElevationMap map = analyticMap([](double, double) { return 0.0; }, 0.5);
  FeatureConfig bad;
  bad.curvature_min = 0;
  EXPECT_THROW(extractFeatures(map, bad), std::invalid_argument);
  bad = {};
  bad.window_max = 0;
  EXPECT_THROW(extractFeatures(map, bad), std::invalid_argument);
  bad = {};
  bad.line_elongation = 0.5;
  EXPECT_THROW(extractFeatures(map, bad), std::invalid_argument);
}

}  // namespace
}  // namespace ambler::perception
