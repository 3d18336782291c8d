#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <numbers>
#include <optional>
#include <stdexcept>

#include "terrains/craters.hpp"
#include "base/random.hpp"
#include "terrains/terrain.hpp"

namespace ambler::terrains {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

TerrainSpec spec(TerrainKind kind, Eigen::Vector2d size = {4.0, 3.0}, double cell = 0.05) {
  TerrainSpec s;
  s.kind = kind;
  s.size_m = size;
  s.cell_m = cell;
  return s;
}

// Kind Dem: the given heights are the base; tilt, steps, craters and rocks go on top as for Plane.
TEST(Terrain, DemKindIsBuiltOnItsBaseHeights) {
  TerrainSpec s = spec(TerrainKind::Dem, {3.0, 2.0}, 0.1);
  const Heightfield grid = terrainGrid(s);
  ASSERT_EQ(grid.rows(), 21);
  ASSERT_EQ(grid.cols(), 31);
  HeightMatrix base(grid.rows(), grid.cols());
  for (int r = 0; r < grid.rows(); ++r)
    for (int c = 0; c < grid.cols(); ++c) base(r, c) = 0.25 * std::sin(0.7 * c) + 0.01 * r;
  EXPECT_EQ(makeTerrain(s, 3, base).ground.heights(), base);
  s.slope_deg = {10.0, 0.0};
  s.steps = {StepSpec{0.5, 0.2}};
  const Terrain t = makeTerrain(s, 3, base);
  TerrainSpec p = s;
  p.kind = TerrainKind::Plane;
  const Terrain plane = makeTerrain(p, 3);
  // The same components as on a plane, added to the base.
  EXPECT_LT((t.ground.heights() - (plane.ground.heights() + base)).cwiseAbs().maxCoeff(), 1e-12);
  s.rocks = RockSpec{0.05, 0.1, 0.5};
  EXPECT_FALSE(makeTerrain(s, 3, base).rocks.empty());
  EXPECT_THROW(makeTerrain(s, 3), std::invalid_argument);                                // no base
  EXPECT_THROW(makeTerrain(p, 3, base), std::invalid_argument);                          // not kind Dem
  EXPECT_THROW(makeTerrain(s, 3, HeightMatrix::Zero(20, 31)), std::invalid_argument);    // wrong shape
  HeightMatrix hole = base;
  hole(3, 4) = std::nan("");
  EXPECT_THROW(makeTerrain(s, 3, hole), std::invalid_argument);                          // not finite
}

TEST(Terrain, GridIsCentredOnTheOrigin) {
  const Terrain t = makeTerrain(spec(TerrainKind::Plane, {3.0, 2.0}, 0.1), 0);
  EXPECT_EQ(t.ground.cols(), 31);
  EXPECT_EQ(t.ground.rows(), 21);
  EXPECT_DOUBLE_EQ(t.ground.xMin(), -1.5);
  EXPECT_DOUBLE_EQ(t.ground.yMin(), -1.0);
  EXPECT_NEAR(t.ground.xMax(), 1.5, 1e-12);
  EXPECT_NEAR(t.ground.yMax(), 1.0, 1e-12);
  // A size that is not a multiple of the cell rounds to the nearest count of cells.
  const Terrain r = makeTerrain(spec(TerrainKind::Plane, {3.04, 2.94}, 0.1), 0);
  EXPECT_EQ(r.ground.cols(), 31);
  EXPECT_EQ(r.ground.rows(), 30);
  EXPECT_NEAR(r.ground.xMin(), -1.5, 1e-12);
  EXPECT_NEAR(r.ground.yMin(), -1.45, 1e-12);
}

TEST(Terrain, PlaneTiltMatchesTheClosedForm) {
  for (const Eigen::Vector2d& slope :
       {Eigen::Vector2d(10.0, 0.0), Eigen::Vector2d(0.0, -25.0), Eigen::Vector2d(15.0, 30.0)}) {
    TerrainSpec s = spec(TerrainKind::Plane);
    s.slope_deg = slope;
    const Terrain t = makeTerrain(s, 3);
    for (int r = 0; r < t.ground.rows(); ++r)
      for (int c = 0; c < t.ground.cols(); ++c) {
        const Eigen::Vector2d p = t.ground.position(r, c);
        ASSERT_NEAR(t.ground.at(r, c),
                    p.y() * std::tan(slope.x() * kDeg) - p.x() * std::tan(slope.y() * kDeg), 1e-12);
      }
  }
  // Right-handed: turning the plane by +α about x lifts +y, by +β about y lowers +x.
  TerrainSpec s = spec(TerrainKind::Plane);
  s.slope_deg = {10.0, 0.0};
  const Eigen::Vector3d rotated_y =
      Eigen::AngleAxisd(10.0 * kDeg, Eigen::Vector3d::UnitX()) * Eigen::Vector3d::UnitY();
  EXPECT_NEAR(*makeTerrain(s, 0).ground.height(0.0, 1.0), rotated_y.z() / rotated_y.y(), 1e-12);
  s.slope_deg = {0.0, 10.0};
  const Eigen::Vector3d rotated_x =
      Eigen::AngleAxisd(10.0 * kDeg, Eigen::Vector3d::UnitY()) * Eigen::Vector3d::UnitX();
  EXPECT_NEAR(*makeTerrain(s, 0).ground.height(1.0, 0.0), rotated_x.z() / rotated_x.x(), 1e-12);
}

// surfaceAt on a tilted plane is the plane's closed form z = y·tan(α) − x·tan(β) anywhere inside
// the grid, off its nodes too (a triangulated plane is the plane; the heights and the barycentric
// sums round by a few ε of z ≤ 1.5 m, so 1e-12); nullopt outside. A square pyramid of half-width
// w and height h standing on it at (cx, cy) lifts the surface to its faces, base + h·(1 −
// max(|x − cx|, |y − cy|)/w); a rock sunk below the ground leaves the ground.
TEST(Terrain, SurfaceAtIsThePlaneAndTheHighestRockFaceAboveIt) {
  TerrainSpec s = spec(TerrainKind::Plane);  // 4 m × 3 m
  s.slope_deg = {12.0, -7.0};
  Terrain t = makeTerrain(s, 0);
  const auto plane = [&](double x, double y) { return y * std::tan(12.0 * kDeg) - x * std::tan(-7.0 * kDeg); };
  for (const Eigen::Vector2d& p : {Eigen::Vector2d(0.013, -0.27), Eigen::Vector2d(-1.99, 1.49),
                                   Eigen::Vector2d(1.234, 0.777), Eigen::Vector2d(1.999, -1.499)}) {
    const std::optional<double> z = surfaceAt(t, p.x(), p.y());
    ASSERT_TRUE(z.has_value()) << p.transpose();
    EXPECT_NEAR(*z, plane(p.x(), p.y()), 1e-12) << p.transpose();
  }
  EXPECT_FALSE(surfaceAt(t, 2.01, 0.0).has_value());
  EXPECT_FALSE(surfaceAt(t, 0.0, -1.51).has_value());

  // The pyramid: apex h above the centre of its square base (on the plane at the centre, so the
  // base's corners are within w·(tan 12° + tan 7°) = 0.08 m of the plane), four faces and the
  // base's two triangles (horizontal: below the faces, never the top).
  const double w = 0.3, h = 0.5, cx = 0.4, cy = -0.2;
  Rock pyramid;
  pyramid.center = {cx, cy, plane(cx, cy)};
  pyramid.vertices = {{-w, -w, 0}, {w, -w, 0}, {w, w, 0}, {-w, w, 0}, {0, 0, h}};
  pyramid.faces = {{0, 1, 4}, {1, 2, 4}, {2, 3, 4}, {3, 0, 4}, {0, 2, 1}, {0, 3, 2}};
  t.rocks.push_back(pyramid);
  for (const Eigen::Vector2d& d : {Eigen::Vector2d(0, 0), Eigen::Vector2d(0.1, 0.05), Eigen::Vector2d(-0.12, 0.2),
                                   Eigen::Vector2d(0.05, -0.25)}) {
    const double x = cx + d.x(), y = cy + d.y();
    const double face = plane(cx, cy) + h * (1 - d.cwiseAbs().maxCoeff() / w);
    ASSERT_GT(face, plane(x, y));  // the face is the top there
    EXPECT_NEAR(*surfaceAt(t, x, y), face, 1e-12) << d.transpose();
  }
  EXPECT_NEAR(*surfaceAt(t, cx + 0.5, cy), plane(cx + 0.5, cy), 1e-12);  // beside it: the ground
  // Sunk 1 m: every face is below the ground, which stays the top.
  t.rocks.back().center.z() -= 1.0;
  EXPECT_NEAR(*surfaceAt(t, cx + 0.1, cy + 0.05), plane(cx + 0.1, cy + 0.05), 1e-12);
}

TEST(Terrain, SinusoidIsAnEggCrate) {
  for (const bool explicit_spec : {false, true}) {
    TerrainSpec s = spec(TerrainKind::Sinusoid);
    const SinusoidSpec wave = explicit_spec ? SinusoidSpec{0.2, 1.3} : SinusoidSpec{};
    if (explicit_spec) s.sinusoid = wave;
    const Terrain t = makeTerrain(s, 0);
    const double k = 2.0 * std::numbers::pi / wave.wavelength_m;
    for (int r = 0; r < t.ground.rows(); ++r)
      for (int c = 0; c < t.ground.cols(); ++c) {
        const Eigen::Vector2d p = t.ground.position(r, c);
        ASSERT_NEAR(t.ground.at(r, c), wave.amplitude_m * std::sin(k * p.x()) * std::sin(k * p.y()),
                    1e-12);
      }
  }
}

TEST(Terrain, StepsAreLedgesOneCellWide) {
  TerrainSpec s = spec(TerrainKind::Steps, {6.0, 2.0}, 0.05);
  s.steps = {{-1.0, 0.3}, {1.02, -0.1}};
  const Terrain t = makeTerrain(s, 0);
  for (int r = 0; r < t.ground.rows(); ++r)
    for (int c = 0; c < t.ground.cols(); ++c) {
      const double x = t.ground.position(r, c).x();
      ASSERT_DOUBLE_EQ(t.ground.at(r, c), (x > -1.0 ? 0.3 : 0.0) + (x > 1.02 ? -0.1 : 0.0));
    }
  // The surface rises by the full height between the sample at the ledge (x = −1, column 40)
  // and the next one; positions round-trip through height() to a few ulp.
  const Eigen::Vector2d ledge = t.ground.position(20, 40), next = t.ground.position(20, 41);
  EXPECT_NEAR(ledge.x(), -1.0, 1e-12);
  EXPECT_NEAR(*t.ground.height(ledge.x(), ledge.y()), 0.0, 1e-12);
  EXPECT_NEAR(*t.ground.height(next.x(), next.y()), 0.3, 1e-12);
  EXPECT_NEAR(*t.ground.height(0.5 * (ledge.x() + next.x()), ledge.y()), 0.15, 1e-12);

  // Kind steps without steps: one default StepSpec.
  const Terrain d = makeTerrain(spec(TerrainKind::Steps, {6.0, 2.0}, 0.05), 0);
  EXPECT_DOUBLE_EQ(*d.ground.height(1.9, 0.0), 0.0);
  EXPECT_DOUBLE_EQ(*d.ground.height(2.1, 0.0), StepSpec{}.height_m);
}

TEST(Terrain, SameSeedSameTerrainBitForBit) {
  const TerrainSpec s = spec(TerrainKind::Mars, {12.0, 10.0}, 0.05);
  const Terrain a = makeTerrain(s, 77), b = makeTerrain(s, 77), c = makeTerrain(s, 78);
  EXPECT_TRUE(a.ground.heights() == b.ground.heights());
  ASSERT_EQ(a.rocks.size(), b.rocks.size());
  ASSERT_FALSE(a.rocks.empty());
  for (std::size_t i = 0; i < a.rocks.size(); ++i) {
    EXPECT_EQ(a.rocks[i].center, b.rocks[i].center);
    EXPECT_EQ(a.rocks[i].vertices, b.rocks[i].vertices);
    EXPECT_EQ(a.rocks[i].faces, b.rocks[i].faces);
  }
  EXPECT_FALSE(a.ground.heights() == c.ground.heights());
  EXPECT_NE(a.rocks.front().center, c.rocks.front().center);
}

TEST(Terrain, ComponentsHaveIndependentStreams) {
  TerrainSpec fractal = spec(TerrainKind::Fractal, {8.0, 8.0});
  TerrainSpec with_rocks = fractal;
  with_rocks.rocks = RockSpec{};
  // Rocks sit on the ground; they do not change it, nor does asking for them change the fractal.
  EXPECT_TRUE(makeTerrain(fractal, 5).ground.heights() ==
              makeTerrain(with_rocks, 5).ground.heights());

  // Mars is fractal + default craters + default rocks, with the same streams.
  TerrainSpec explicit_mars = fractal;
  explicit_mars.craters = CraterSpec{};
  explicit_mars.rocks = RockSpec{};
  const Terrain mars = makeTerrain(spec(TerrainKind::Mars, {8.0, 8.0}), 5);
  const Terrain same = makeTerrain(explicit_mars, 5);
  EXPECT_TRUE(mars.ground.heights() == same.ground.heights());
  ASSERT_EQ(mars.rocks.size(), same.rocks.size());
  EXPECT_EQ(mars.rocks.back().vertices, same.rocks.back().vertices);

  // Craters add on top of the fractal: the difference is exactly the craters' relief.
  const HeightMatrix craters = mars.ground.heights() - makeTerrain(fractal, 5).ground.heights();
  EXPECT_LT(craters.minCoeff(), -kCraterDepthRatio * CraterSpec{}.min_diameter_m * 0.5);
  EXPECT_GE(craters.minCoeff(),
            -kCraterDepthRatio * CraterSpec{}.max_diameter_m * CraterSpec{}.count);
}

TEST(Terrain, ExplicitComponentsApplyToAnyKind) {
  TerrainSpec s = spec(TerrainKind::Plane);
  s.sinusoid = SinusoidSpec{0.1, 0.8};
  s.steps = {{0.0, 0.2}};
  const Terrain t = makeTerrain(s, 0);
  const double k = 2.0 * std::numbers::pi / 0.8;
  const Eigen::Vector2d p = t.ground.position(10, 50);
  EXPECT_NEAR(t.ground.at(10, 50),
              0.1 * std::sin(k * p.x()) * std::sin(k * p.y()) + (p.x() > 0 ? 0.2 : 0.0), 1e-12);
  EXPECT_TRUE(makeTerrain(spec(TerrainKind::Plane), 0).rocks.empty());
}

TEST(Terrain, RejectsBadSpecs) {
  auto throws = [](auto edit) {
    TerrainSpec s = spec(TerrainKind::Fractal);
    edit(s);
    EXPECT_THROW(makeTerrain(s, 0), std::invalid_argument);
  };
  throws([](TerrainSpec& s) { s.kind = TerrainKind::Mjcf; });
  throws([](TerrainSpec& s) { s.size_m.x() = 0.0; });
  throws([](TerrainSpec& s) { s.size_m.y() = -1.0; });
  throws([](TerrainSpec& s) { s.size_m.x() = NAN; });
  throws([](TerrainSpec& s) { s.cell_m = 0.0; });
  throws([](TerrainSpec& s) { s.cell_m = 10.0; });
  throws([](TerrainSpec& s) { s.size_m = {1000.0, 1000.0}, s.cell_m = 0.1; });  // 100M samples
  throws([](TerrainSpec& s) { s.hurst = 0.0; });
  throws([](TerrainSpec& s) { s.hurst = 1.0; });
  throws([](TerrainSpec& s) { s.hurst = 1.5; });
  throws([](TerrainSpec& s) { s.relief_m = -0.1; });
  throws([](TerrainSpec& s) { s.slope_deg.x() = 90.0; });
  throws([](TerrainSpec& s) { s.sinusoid = SinusoidSpec{0.1, 0.0}; });
  throws([](TerrainSpec& s) { s.steps = {{NAN, 0.1}}; });
  throws([](TerrainSpec& s) { s.craters = CraterSpec{4, 5.0, 1.0, 2.0}; });
  throws([](TerrainSpec& s) { s.rocks = RockSpec{0.1, 1.0, 0.5}; });
  throws([](TerrainSpec& s) { s.rocks = RockSpec{0.0, 0.1, 1.0}; });
  throws([](TerrainSpec& s) { s.kind = TerrainKind::Mars, s.size_m = {1.5, 8.0}; });  // 1 m rocks
  // Just under the sample limit is accepted (checked without building it: 4999 x 5001).
  TerrainSpec big = spec(TerrainKind::Plane, {499.8, 500.0}, 0.1);
  big.hurst = 2.0;  // fails after the size check, so the size itself passed
  try {
    makeTerrain(big, 0);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("hurst"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace ambler::terrains
