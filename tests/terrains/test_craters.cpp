#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "terrains/craters.hpp"
#include "terrains/terrain.hpp"

namespace ambler::terrains {
namespace {

TEST(CraterProfile, MatchesDepthRimAndEjecta) {
  const double D = 3.0, R = 1.5, d = 0.2 * D, h = 0.04 * D;
  EXPECT_DOUBLE_EQ(craterProfile(0.0, D), -d);
  EXPECT_DOUBLE_EQ(craterProfile(R, D), h);
  // Continuous at the rim: 1e-9·R inside, the bowl's slope 2(d+h)/R allows 2(d+h)·1e-9.
  EXPECT_NEAR(craterProfile(R * (1 - 1e-9), D), h, 2.0 * (d + h) * 1e-9);
  EXPECT_NEAR(craterProfile(0.5 * R, D), (d + h) * 0.25 - d, 1e-15);
  // Ejecta h·(R/r)³, tapered by the cut-off value at 8R.
  const double tail = 1.0 / 512.0;
  EXPECT_NEAR(craterProfile(2.0 * R, D), h * (0.125 - tail) / (1.0 - tail), 1e-15);
  EXPECT_NEAR(craterProfile(2.0 * R, D), h * 0.125, h / 511.0);
  EXPECT_NEAR(craterProfile(8.0 * R * (1 - 1e-12), D), 0.0, 1e-12);
  EXPECT_EQ(craterProfile(8.0 * R, D), 0.0);
  EXPECT_EQ(craterProfile(100.0, D), 0.0);
}

TEST(CraterProfile, AddsAtKnownCentre) {
  // A crater centred on a sample, with the rim passing through samples along the axes.
  Heightfield ground(401, 401, 0.05, {-10.0, -10.0});
  const double D = 2.0;
  addCraters(ground, {{{0.0, 0.0}, D}});
  EXPECT_NEAR(ground.at(200, 200), -0.2 * D, 1e-15);
  EXPECT_NEAR(ground.at(200, 220), 0.04 * D, 1e-15);  // r = 1.0 m = R
  EXPECT_NEAR(ground.at(180, 200), 0.04 * D, 1e-15);
  EXPECT_NEAR(ground.at(200, 210), (0.2 + 0.04) * D * 0.25 - 0.2 * D, 1e-15);
  EXPECT_EQ(ground.at(0, 0), 0.0);      // r = 14 m, beyond the cut-off at 8 m
  EXPECT_GT(ground.at(200, 350), 0.0);  // r = 7.5 m, inside it
}

// On a flat plane a lone crater's deepest sample is within a cell's half-diagonal δ of its
// centre, and its highest within δ of the rim; the profile bounds both.
TEST(Craters, IsolatedCraterOnAPlaneHasTheProfilesDepthAndRim) {
  for (std::uint64_t seed : {1, 2, 3, 4}) {
    TerrainSpec spec;
    spec.kind = TerrainKind::Plane;
    spec.size_m = {10.0, 10.0};
    spec.cell_m = 0.02;
    spec.craters = CraterSpec{1, 2.0, 2.0, 2.0};
    const Terrain t = makeTerrain(spec, seed);
    const double D = 2.0, R = 1.0, d = 0.2 * D, h = 0.04 * D;
    const double delta = spec.cell_m / std::sqrt(2.0);
    EXPECT_GE(t.ground.minHeight(), -d - 1e-15);
    EXPECT_LE(t.ground.minHeight(), -d + (d + h) * std::pow(delta / R, 2));
    EXPECT_LE(t.ground.maxHeight(), h + 1e-15);
    EXPECT_GE(t.ground.maxHeight(),
              std::min(craterProfile(R - delta, D), craterProfile(R + delta, D)));
  }
}

TEST(Craters, DiametersFollowTheTruncatedPowerLaw) {
  const CraterSpec spec{20000, 1.0, 5.0, 2.0};
  Heightfield grid(11, 21, 1.0, {-10.0, -5.0});
  const auto craters = sampleCraters(spec, grid, 99);
  ASSERT_EQ(craters.size(), 20000u);
  for (const auto& c : craters) {
    ASSERT_GE(c.diameter_m, 1.0);
    ASSERT_LE(c.diameter_m, 5.0);
    ASSERT_TRUE(grid.contains(c.center.x(), c.center.y()));
  }
  // P(≥D) = (D^−b − Dmax^−b)/(Dmin^−b − Dmax^−b); the count above D is binomial, and 4σ makes
  // a false alarm a ~1e-4 event per threshold.
  for (double d0 : {1.2, 1.5, 2.0, 3.0, 4.0}) {
    const double p = (std::pow(d0, -2.0) - std::pow(5.0, -2.0)) / (1.0 - std::pow(5.0, -2.0));
    int above = 0;
    for (const auto& c : craters) above += c.diameter_m >= d0;
    const double n = double(craters.size());
    EXPECT_NEAR(above / n, p, 4.0 * std::sqrt(p * (1 - p) / n)) << "D0 = " << d0;
  }
}

TEST(Craters, QuantileCoversTheRange) {
  const CraterSpec spec{4, 1.0, 5.0, 2.5};
  EXPECT_DOUBLE_EQ(craterDiameterQuantile(spec, 0.0), 1.0);
  EXPECT_DOUBLE_EQ(craterDiameterQuantile(spec, 1.0), 5.0);
  double previous = 0.0;
  for (double u = 0.0; u <= 1.0; u += 0.01) {
    EXPECT_GT(craterDiameterQuantile(spec, u), previous);
    previous = craterDiameterQuantile(spec, u);
  }
  EXPECT_DOUBLE_EQ(craterDiameterQuantile({4, 2.0, 2.0, 2.0}, 0.3), 2.0);
}

TEST(Craters, RejectsBadSpecs) {
  EXPECT_THROW(checkCraterSpec({-1, 1.0, 5.0, 2.0}), std::invalid_argument);
  EXPECT_THROW(checkCraterSpec({4, 0.0, 5.0, 2.0}), std::invalid_argument);
  EXPECT_THROW(checkCraterSpec({4, 6.0, 5.0, 2.0}), std::invalid_argument);
  EXPECT_THROW(checkCraterSpec({4, 1.0, 5.0, 0.0}), std::invalid_argument);
  EXPECT_THROW(checkCraterSpec({4, 1.0, INFINITY, 2.0}), std::invalid_argument);
  EXPECT_NO_THROW(checkCraterSpec({0, 1.0, 1.0, 2.0}));
}

}  // namespace
}  // namespace ambler::terrains
