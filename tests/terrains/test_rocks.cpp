#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <map>
#include <numbers>
#include <stdexcept>

#include "base/random.hpp"
#include "terrains/rocks.hpp"
#include "terrains/terrain.hpp"

namespace ambler::terrains {
namespace {

constexpr double kPi = std::numbers::pi;

TerrainSpec rockField(double k, Eigen::Vector2d size, double d_min = 0.1, double d_max = 1.0) {
  TerrainSpec spec;
  spec.kind = TerrainKind::Plane;
  spec.size_m = size;
  spec.cell_m = 0.1;
  spec.rocks = RockSpec{k, d_min, d_max};
  return spec;
}

// Independent of the library's helpers: each face's plane from its vertices, every vertex on or
// behind it; each directed edge once and its reverse once; positive enclosed volume.
void expectClosedConvexOutward(const Rock& rock) {
  std::map<std::pair<int, int>, int> edges;
  double volume = 0.0;
  for (const auto& f : rock.faces) {
    const Eigen::Vector3d &a = rock.vertices[f[0]], &b = rock.vertices[f[1]],
                          &c = rock.vertices[f[2]];
    const Eigen::Vector3d n = (b - a).cross(c - a);
    ASSERT_GT(n.norm(), 1e-12 * rock.diameter_m * rock.diameter_m) << "degenerate face";
    for (const auto& v : rock.vertices) ASSERT_LE(n.normalized().dot(v - a), 1e-9);
    for (int e = 0; e < 3; ++e) ++edges[{f[e], f[(e + 1) % 3]}];
    volume += a.dot(b.cross(c)) / 6.0;
  }
  for (const auto& [e, count] : edges) {
    ASSERT_EQ(count, 1);
    ASSERT_EQ(edges.count({e.second, e.first}), 1u);
  }
  EXPECT_GT(volume, 0.0);
}

TEST(RockModel, GolombekRappClosedForms) {
  EXPECT_DOUBLE_EQ(rockDecay(0.1), 1.79 + 1.52);
  const RockSpec spec{0.1, 0.1, 1.0};
  const double q = 3.31;
  EXPECT_NEAR(rockCumulativeFraction(spec, 0.1), 0.1 * (std::exp(-0.1 * q) - std::exp(-q)), 1e-15);
  EXPECT_NEAR(rockCumulativeFraction(spec, 0.4), 0.1 * (std::exp(-0.4 * q) - std::exp(-q)), 1e-15);
  EXPECT_EQ(rockCumulativeFraction(spec, 1.0), 0.0);
  EXPECT_EQ(rockCumulativeFraction(spec, 2.0), 0.0);
  EXPECT_EQ(rockCumulativeFraction(spec, 0.01), rockCumulativeFraction(spec, 0.1));
}

TEST(RockModel, NumberDensityMatchesDirectQuadrature) {
  for (double k : {0.05, 0.1, 0.2}) {
    const RockSpec spec{k, 0.1, 1.0};
    const double q = rockDecay(k);
    // Midpoint rule directly in D; its error is below 1e-7 relative with 1e6 steps.
    const int n = 1000000;
    const double dd = 0.9 / n;
    double sum = 0.0;
    for (int i = 0; i < n; ++i) {
      const double d = 0.1 + (i + 0.5) * dd;
      sum += k * q * std::exp(-q * d) / (kPi * d * d / 4.0) * dd;
    }
    EXPECT_NEAR(rockNumberDensity(spec), sum, 1e-7 * sum) << "k = " << k;
  }
}

TEST(RockModel, StratifiedDiametersAreSortedAndInRange) {
  const RockSpec spec{0.1, 0.1, 1.0};
  base::Rng rng(3);
  const auto d = sampleRockDiameters(spec, 100.0, rng);
  EXPECT_EQ(long(d.size()), std::lround(100.0 * rockNumberDensity(spec)));
  for (std::size_t i = 0; i < d.size(); ++i) {
    ASSERT_GE(d[i], 0.1);
    ASSERT_LE(d[i], 1.0);
    if (i) {
      ASSERT_LE(d[i], d[i - 1]);
    }
  }
  EXPECT_TRUE(sampleRockDiameters({0.1, 0.5, 0.5}, 100.0, rng).empty());
}

TEST(RockShape, ConvexClosedOutwardWithExactFootprint) {
  base::Rng rng(11);
  for (int i = 0; i < 500; ++i) {
    const double d = rng.uniform(0.05, 2.0);
    const Rock rock = makeRockShape(d, rng);
    expectClosedConvexOutward(rock);
    EXPECT_TRUE(isConvex(rock));
    EXPECT_TRUE(isClosed(rock));
    EXPECT_NEAR(planViewArea(rock), kPi * d * d / 4.0, 1e-9 * kPi * d * d / 4.0);
    EXPECT_EQ(rock.diameter_m, d);
    EXPECT_LE(rock.vertices.size(), 60u);
    EXPECT_GE(rock.vertices.size(), 8u);
    // Height semi-axis c in [0.25, 0.5]·D, points pulled in by at most 15 %.
    double top = 0.0;
    for (const auto& v : rock.vertices) top = std::max(top, v.z());
    EXPECT_LE(top, 0.5 * d + 1e-12);
    EXPECT_GE(top, 0.5 * 0.25 * d);
  }
}

// Golombek & Rapp: the fraction of the area covered by rocks of diameter >= D0 is
// k·(exp(−q·D0) − exp(−q·Dmax)) for the generated range; checked to 10 %. Stratified sizes also
// bound the error in area: each rock's area lies in its stratum's range, those ranges telescope
// to a(Dmax) − a(Dmin), the stratum cut by D0 adds at most a(Dmax) and rounding the count at
// most a(Dmax)/2, so |error| <= 2.5·a(Dmax) with a(D) = πD²/4.
TEST(Rocks, CoverageMatchesGolombekRapp) {
  const double side = 40.0;
  for (double k : {0.05, 0.1, 0.2}) {
    const TerrainSpec spec = rockField(k, {side, side});
    const Terrain t = makeTerrain(spec, 2024);
    for (double d0 : {0.1, 0.2, 0.4}) {
      double area = 0.0;
      for (const auto& rock : t.rocks)
        if (rock.diameter_m >= d0) area += planViewArea(rock);
      const double measured = area / (side * side), model = rockCumulativeFraction(*spec.rocks, d0);
      EXPECT_NEAR(measured / model, 1.0, 0.10) << "k = " << k << ", D0 = " << d0;
      EXPECT_NEAR(area, model * side * side, 2.5 * kPi / 4.0) << "k = " << k << ", D0 = " << d0;
      std::printf("k = %.2f, D0 = %.1f: coverage %.5f, model %.5f, ratio %.4f (%zu rocks)\n", k, d0,
                  measured, model, measured / model, t.rocks.size());
    }
  }
}

TEST(Rocks, PlacedInsideWithoutOverlapAndPartlyBuried) {
  const TerrainSpec spec = rockField(0.2, {20.0, 15.0});
  TerrainSpec tilted = spec;
  tilted.slope_deg = {5.0, -3.0};
  const Terrain t = makeTerrain(tilted, 5);
  ASSERT_GT(t.rocks.size(), 100u);
  for (std::size_t i = 0; i < t.rocks.size(); ++i) {
    const Rock& a = t.rocks[i];
    if (i) {
      ASSERT_LE(a.diameter_m, t.rocks[i - 1].diameter_m) << "largest first";
    }
    for (const auto& v : a.vertices) {
      ASSERT_TRUE(t.ground.contains(a.center.x() + v.x(), a.center.y() + v.y()));
    }
    for (std::size_t j = 0; j < i; ++j) {
      const Rock& b = t.rocks[j];
      ASSERT_GE((a.center - b.center).head<2>().norm(), boundingRadius(a) + boundingRadius(b));
    }
    double top = 0.0;
    for (const auto& v : a.vertices) top = std::max(top, v.z());
    const double ground = *t.ground.height(a.center.x(), a.center.y());
    ASSERT_GE(ground - a.center.z(), 0.0);
    ASSERT_LE(ground - a.center.z(), 0.3 * top + 1e-12);
  }
}

TEST(Rocks, SameSeedSameRocks) {
  const TerrainSpec spec = rockField(0.1, {8.0, 8.0});
  const Terrain a = makeTerrain(spec, 9), b = makeTerrain(spec, 9), c = makeTerrain(spec, 10);
  ASSERT_EQ(a.rocks.size(), b.rocks.size());
  for (std::size_t i = 0; i < a.rocks.size(); ++i) {
    EXPECT_EQ(a.rocks[i].center, b.rocks[i].center);
    EXPECT_EQ(a.rocks[i].vertices, b.rocks[i].vertices);
    EXPECT_EQ(a.rocks[i].faces, b.rocks[i].faces);
    EXPECT_EQ(a.rocks[i].diameter_m, b.rocks[i].diameter_m);
  }
  EXPECT_NE(a.rocks.front().center, c.rocks.front().center);
}

TEST(Rocks, RejectsImpossibleRequests) {
  EXPECT_THROW(makeTerrain(rockField(0.0, {5, 5}), 1), std::invalid_argument);
  EXPECT_THROW(makeTerrain(rockField(-0.1, {5, 5}), 1), std::invalid_argument);
  EXPECT_THROW(makeTerrain(rockField(1.0, {5, 5}), 1), std::invalid_argument);
  EXPECT_THROW(makeTerrain(rockField(0.1, {5, 5}, 0.5, 0.2), 1), std::invalid_argument);
  EXPECT_THROW(makeTerrain(rockField(0.1, {5, 5}, 0.0, 0.2), 1), std::invalid_argument);
  EXPECT_THROW(makeTerrain(rockField(0.1, {1.0, 1.0}, 0.1, 0.6), 1), std::invalid_argument);
  // So crowded that no free place remains for the last rocks.
  EXPECT_THROW(makeTerrain(rockField(0.99, {10.0, 10.0}), 1), std::invalid_argument);
}

}  // namespace
}  // namespace ambler::terrains
