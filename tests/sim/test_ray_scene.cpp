// The Embree ray scene against MuJoCo's own mj_ray, the heightfield query and ground truth.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "fixtures.hpp"
#include "perception/sensor_geometry.hpp"
#include "sim/erim_scanner.hpp"
#include "sim/ground_truth.hpp"
#include "base/random.hpp"

namespace ambler::sim {
namespace {

using test::MjcfWorld;
using test::TerrainWorld;

constexpr double kDeg = std::numbers::pi / 180.0;

terrains::Terrain randomHeightfield(std::uint64_t seed) {
  terrains::Terrain t{terrains::Heightfield(81, 101, 0.1, {-5.0, -4.0}), {}};
  base::Rng rng(seed);
  for (int r = 0; r < t.ground.rows(); ++r)
    for (int c = 0; c < t.ground.cols(); ++c) t.ground.at(r, c) = rng.uniform(-0.5, 0.5);
  return t;
}

// The exact heightfield query, the ground truth (cast down through Embree) and a vertical mj_ray
// agree to 1e-5 m: MuJoCo keeps heights as float32 normalised data (relative error 6e-8).
TEST(GroundTruth, HeightfieldQueryEqualsVerticalMjRay) {
  const terrains::Terrain terrain = randomHeightfield(3);
  const TerrainWorld w(terrain);
  const GroundTruth truth(*w.scene);
  base::Rng rng(11);
  const double z_top = 5.0;
  for (int i = 0; i < 5000; ++i) {
    const double x = rng.uniform(-4.99, 4.99), y = rng.uniform(-3.99, 3.99);
    const auto t = w.world->ray({x, y, z_top}, {0, 0, -1});
    ASSERT_TRUE(t.has_value());
    const double z_mj = z_top - *t;
    EXPECT_NEAR(*terrain.ground.height(x, y), z_mj, 1e-5) << x << ", " << y;
    EXPECT_NEAR(*truth.elevation(x, y), z_mj, 1e-5) << x << ", " << y;
  }
}

// Vertical rays exactly through the terrain grid's vertices and edges (map cell centres on a
// 10 cm grid over a 5 cm hfield) must not slip through the cracks between triangles: the ground
// truth of a tilted plane is the plane everywhere, and a plane hides nothing from the sensor.
TEST(GroundTruth, WatertightOnGridAlignedRays) {
  const double a = 0.0, b = std::tan(15 * kDeg);
  const TerrainWorld w(test::planeTerrain(a, b, 0.0, 10.0, 0.05));
  const GroundTruth truth(*w.scene);
  const auto grid = perception::MapGrid::covering(-5, 5, -3, 8, 0.1);
  const perception::ElevationMap truth_map = truth.elevation(grid);
  const auto& z = truth_map.elevation();
  for (int r = 0; r < grid.rows; ++r)
    for (int c = 0; c < grid.cols; ++c) {
      const Eigen::Vector2d p = grid.center(r, c);
      ASSERT_NEAR(z(r, c), a * p.x() + b * p.y(), 1e-5) << p.transpose();
    }
  perception::SensorModel cfg;
  const auto vis = truth.visibility(truth_map, perception::sensorPose({0, -6, 3}, {0, -30 * kDeg, 0}), cfg);
  int visible = 0;
  for (int i = 0; i < vis.size(); ++i) {
    ASSERT_NE(Visibility(vis.data()[i]), Visibility::Hidden) << "cell " << i;
    visible += Visibility(vis.data()[i]) == Visibility::Visible;
  }
  EXPECT_GT(visible, 3000);
}

// Ground truth on a grid in a map frame turned by a yaw and offset in x, y and z: each cell holds
// the plane's height at the cell centre's world point minus the frame origin's z (heights are
// along M's z, which is the world's), Known with σ_z = 0; to 1e-5 m as above (float32 heights).
// A frame ignored in x, y or z would be off by ≥ |a·Δx + b·Δy| or |oz|, far more than that.
TEST(GroundTruth, ElevationOnAYawedOffsetGridIsInTheGridsFrame) {
  const double a = 0.12, b = std::tan(15 * kDeg), z0 = 0.2;
  const TerrainWorld w(test::planeTerrain(a, b, z0, 10.0, 0.1));
  const GroundTruth truth(*w.scene);
  const Eigen::Vector3d origin(1.3, -0.7, 0.45);
  const auto T_WM = perception::mapFrame(origin, 35 * kDeg);
  // Cell centres within √(4² + 5²) + |origin| < 8 m of the world origin: inside the 10 m plane.
  const auto grid = perception::MapGrid::covering(-4, 4, -3, 5, 0.1, T_WM);
  const perception::ElevationMap m = truth.elevation(grid);
  ASSERT_TRUE(m.grid().sameAs(grid));
  for (int r = 0; r < grid.rows; ++r)
    for (int c = 0; c < grid.cols; ++c) {
      const Eigen::Vector3d p = grid.worldPoint(r, c, 0.0);
      ASSERT_LT(std::max(std::abs(p.x()), std::abs(p.y())), 9.0);
      ASSERT_EQ(m.stateAt(r, c), perception::CellState::Known) << r << "," << c;
      EXPECT_NEAR(m.elevation()(r, c), a * p.x() + b * p.y() + z0 - origin.z(), 1e-5) << r << "," << c;
      EXPECT_EQ(m.sigma()(r, c), 0.0f);
    }
  // Not gravity-aligned: refused.
  Eigen::Isometry3d tilted = T_WM;
  tilted.linear() = Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitX()).toRotationMatrix();
  EXPECT_THROW(truth.elevation(perception::MapGrid::covering(-1, 1, -1, 1, 0.1, tilted)), std::invalid_argument);
}

// Every ray of a 64×256 ERIM scan of a fractal terrain with rocks: Embree and mj_ray agree on
// hit or miss, on the geom, and on the distance to 1e-5 m.
TEST(RayScene, AgreesWithMjRayOnEveryRayOfAFractalScanWithRocks) {
  const terrains::Terrain terrain = terrains::makeTerrain(test::fractalWithRocks(), 7);
  ASSERT_GT(terrain.rocks.size(), 20u);
  const TerrainWorld w(terrain);
  perception::SensorModel c;
  c.noise_k = 0, c.quantization_m = 0, c.ambiguity_m = 0, c.mixed_pixels = false;
  const auto T = perception::sensorPose({0, -5, 2.5}, {0, -25 * kDeg, 0});
  const Scan scan = ErimScanner(*w.scene, c).scan(T, 1);
  int hits = 0, rock_hits = 0;
  double worst = 0;
  for (int r = 0; r < scan.image.rows(); ++r)
    for (int col = 0; col < scan.image.cols(); ++col) {
      const Eigen::Vector3d d = T.linear() * perception::beamDirection(scan.image.phi[r], scan.image.theta[col]);
      int geom = -1;
      const auto t = w.world->ray(T.translation(), d, &geom);
      ASSERT_EQ(t.has_value(), std::isfinite(scan.true_range(r, col))) << "pixel " << r << "," << col;
      if (!t) continue;
      ++hits;
      rock_hits += geom > 0;
      EXPECT_EQ(geom, scan.geom(r, col)) << "pixel " << r << "," << col;
      worst = std::max(worst, std::abs(*t - scan.true_range(r, col)));
      EXPECT_NEAR(scan.true_range(r, col), *t, 1e-5) << "pixel " << r << "," << col;
    }
  EXPECT_GT(hits, 10000);
  EXPECT_GT(rock_hits, 300);
  RecordProperty("max_abs_difference_m", std::to_string(worst));
}

// A world of every primitive, a mesh and an hfield, posed arbitrarily: random rays agree with
// mj_ray to 1e-5 m and on the geom hit.
TEST(RayScene, AgreesWithMjRayOnEveryGeomType) {
  const MjcfWorld w(R"(
<mujoco>
  <asset>
    <hfield name="hf" file="hf.bin" size="2 1.5 0.5 0.3"/>
    <mesh name="tet" vertex="0 0 0  1 0 0  0 1 0  0 0 1"/>
  </asset>
  <worldbody>
    <geom type="plane" size="0 0 1" pos="0 0 -1"/>
    <geom type="hfield" hfield="hf" pos="0 0 -0.9"/>
    <geom type="sphere" size="0.4" pos="-2 2 0.5"/>
    <geom type="capsule" size="0.3 0.5" pos="0 2.5 0.6" euler="0.4 0.3 0.2"/>
    <geom type="ellipsoid" size="0.5 0.3 0.2" pos="2 2 0.5" euler="0.1 0.9 0.3"/>
    <geom type="cylinder" size="0.35 0.4" pos="-2 -2 0.4" euler="1.2 0 0.4"/>
    <geom type="box" size="0.4 0.3 0.2" pos="2 -2 0.4" euler="0.3 0.5 0.7"/>
    <geom type="mesh" mesh="tet" pos="0 -2.5 0.2" euler="0.2 0.1 0.5"/>
  </worldbody>
</mujoco>)",
                    {{"hf.bin", test::hfieldFile(3, 4, {0, 1, 0, 2, 1, 0, 2, 1, 3, 0, 1, 2})}});
  base::Rng rng(5);
  int hits = 0;
  for (int i = 0; i < 20000; ++i) {
    const Eigen::Vector3d o(rng.uniform(-4, 4), rng.uniform(-4, 4), rng.uniform(1.5, 4));
    const Eigen::Vector3d target(rng.uniform(-3, 3), rng.uniform(-3, 3), rng.uniform(-1, 1));
    const Eigen::Vector3d d = (target - o).normalized();
    int geom = -1;
    const auto t = w.world->ray(o, d, &geom);
    const auto hit = w.scene->intersect(o, d);
    ASSERT_EQ(t.has_value(), hit.has_value()) << "ray " << i;
    if (!t) continue;
    ++hits;
    EXPECT_NEAR(hit->t, *t, 1e-5) << "ray " << i << " geom " << geom;
    EXPECT_EQ(hit->geom, geom) << "ray " << i;
  }
  EXPECT_GT(hits, 15000);
}

// Range shadow ground truth: a 1 m wall seen from 2 m up hides the ground behind it up to where
// the line over its top edge meets the ground (similar triangles: y = 2·4.2 = 8.4 m).
TEST(GroundTruth, WallCastsTheAnalyticShadow) {
  const MjcfWorld w(R"(
<mujoco>
  <worldbody>
    <geom type="plane" size="20 20 1"/>
    <geom type="box" size="1 0.1 0.5" pos="0 4.1 0.5"/>
  </worldbody>
</mujoco>)");
  const GroundTruth truth(*w.scene);
  const auto grid = perception::MapGrid::covering(-4, 4, 1, 12, 0.1);
  const perception::ElevationMap truth_map = truth.elevation(grid);
  perception::SensorModel c;
  c.fov_h_rad = 100 * kDeg;
  c.fov_v_rad = 60 * kDeg;
  const auto T = perception::sensorPose({0, 0, 2}, {0, -20 * kDeg, 0});
  const auto vis = truth.visibility(truth_map, T, c);
  int hidden = 0, visible = 0;
  for (int r = 0; r < grid.rows; ++r)
    for (int col = 0; col < grid.cols; ++col) {
      const Eigen::Vector2d p = grid.center(r, col);
      const auto v = Visibility(vis(r, col));
      const double edge = p.y() > 4.2 ? p.y() / 4.2 : 1.0;  // the shadow's side at this y
      if (std::abs(p.x()) > edge + 0.1 && std::abs(p.x()) < 3.0 && p.y() > 3.0 && p.y() < 9.0 &&
          (p.y() < 3.9 || p.y() > 4.3)) {
        // beside the wall and its shadow, inside the field of view: never hidden
        EXPECT_EQ(v, Visibility::Visible) << p.transpose();
        ++visible;
      }
      if (p.y() > 4.3 && p.y() < 8.3 && std::abs(p.x()) < p.y() / 4.2 - 0.1) {
        EXPECT_EQ(v, Visibility::Hidden) << p.transpose();
        ++hidden;
      }
      if (p.y() > 8.5 && p.y() < 11 && std::abs(p.x()) < 1.5) {
        EXPECT_EQ(v, Visibility::Visible) << p.transpose();
      }
      if (p.y() < 3.9 && p.y() > 2.0 && std::abs(p.x()) < 0.5) {
        EXPECT_EQ(v, Visibility::Visible) << p.transpose();
      }
    }
  EXPECT_GT(hidden, 1000);
  EXPECT_GT(visible, 500);
}

}  // namespace
}  // namespace ambler::sim
