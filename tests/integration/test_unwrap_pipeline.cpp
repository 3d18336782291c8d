// Unwrapping where the near field itself is folded, through the simulator and against its ground
// truth: the plane of scenarios/experiments/plane_base.yaml tilted 45° sideways. Its side that falls
// away is beyond the 19.5 m ambiguity interval already in the bottom rows of the image, so those
// rows cannot all be taken as unfolded; taking them so leaves ~10 pixels per scan at their wrapped
// ranges (0.1–4.5 m instead of 19.6–24 m), and the locus map puts up to 33 cells 0.9–2.4 m above
// the plane from them (docs/experiments/locus_vs_cartesian.md, "The ambiguity edge").
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <string>

#include "perception/scan_to_map.hpp"
#include "base/random.hpp"
#include "eval/scenario/scenario.hpp"
#include "perception/range_edges.hpp"
#include "perception/sensor_geometry.hpp"
#include "sim/erim_scanner.hpp"
#include "sim/ground_truth.hpp"
#include "sim/ray_scene.hpp"
#include "sim/world.hpp"
#include "terrains/terrain.hpp"
#include "test_support.hpp"

namespace ambler {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

// The plane of plane_base.yaml (24 m square, through the origin) tilted by `slope_y_deg` about y.
struct SidewaysPlane {
  test::TempDir dir;
  sim::World world;
  sim::RayScene scene;
  sim::GroundTruth truth;
  explicit SidewaysPlane(double slope_y_deg)
      : world(sim::World::load(sim::writeWorld(terrains::makeTerrain(spec(slope_y_deg), 1), dir.path(), "t"))),
        scene(world), truth(scene) {}
  static terrains::TerrainSpec spec(double slope_y_deg) {
    terrains::TerrainSpec t;
    t.kind = terrains::TerrainKind::Plane;
    t.size_m = {24, 24};
    t.cell_m = 0.05;
    t.slope_deg = {0, slope_y_deg};
    return t;
  }
};

// plane_base.yaml's view: 3 m above the pivot's level, 30° down, boresight on the origin.
eval::ViewSpec baseView() {
  eval::ViewSpec v;
  v.xyz_m = {0, -5.196, 3.0};
  v.rpy_rad = {0, -30 * kDeg, 0};
  return v;
}

// The fractional pixel position (row, column) of a sensor-frame point: φ = atan2(z, y),
// θ = asin(x/ρ) (eq. 1), on the image's evenly spaced pixel-centre angles.
Eigen::Vector2d pixelOf(const perception::RangeImage& image, const Eigen::Vector3d& p) {
  const double phi = std::atan2(p.z(), p.y()), theta = std::asin(p.x() / p.norm());
  return {(image.phi[0] - phi) / (image.phi[0] - image.phi[1]),
          (theta - image.theta[0]) / (image.theta[1] - image.theta[0])};
}

struct NoiseCase {
  double k;
  std::uint64_t seed;
};

// Per pixel: the unwrapped range is within 6σ of the true one, or NaN. Per known map cell whose
// crossing lies on or next to a pixel whose true range is past the interval (the cells that depend
// on unwrapping): the elevation is within 5σ_z plus the stopping rule's ε of the truth.
//
// The bounds. σ(ρ) = q/√12 + kρ² bounds the ERIM's noise (docs/range_edges.md) and mixed pixels
// are off (a bias outside the model, as in every σ test), so a pixel's error is at most one unit
// of it: 6σ is passed by a fair pixel but for ~2e-9 of them (16 k pixels × 9 scans: 3e-4 overall)
// and is ~0.1–1 m against the 19.5 m of a wrong fold. The map bound is 5σ_z, not 3σ_z: the test
// checks 2 000–4 000 cells per scan, ~20 000 in all, so a 3σ tail (0.27 %) would fail dozens of
// fair cells; a 5σ tail (5.7e-7) fails one with probability ~1 %. A cell mapped at a wrapped range
// is 0.9–2.4 m off, ≥ 18σ_z. The search stops when its bracket in φ is narrower than ε, which
// moves the point along the vertical line by at most ε/|dφ/dz|, computed exactly per cell.
TEST(UnwrapSideways, FoldedNearFieldIsUnwrappedAndMappedRight) {
  const SidewaysPlane plane(45.0);
  const eval::ViewSpec view = baseView();
  eval::MapSpec map;
  map.cell_m = 0.10;
  map.x_m = {-8, 12};  // plane_base's region, widened to the terrain's edge on the falling side
  map.y_m = {-2.5, 12};
  const auto grid = map.grid();
  const perception::ElevationMap truth_map = plane.truth.elevation(grid);
  const auto& z_true = truth_map.elevation();
  const double a = 19.5;
  for (const NoiseCase nc : {NoiseCase{0.0, 1}, NoiseCase{3e-4, 1}, NoiseCase{3e-4, 2}, NoiseCase{3e-4, 3},
                             NoiseCase{1e-3, 1}, NoiseCase{1e-3, 2}, NoiseCase{1e-3, 3}}) {
    SCOPED_TRACE("k " + std::to_string(nc.k) + " seed " + std::to_string(nc.seed));
    perception::SensorModel sensor;  // the ERIM: 8-bit counts, wrap at 19.5 m
    sensor.noise_k = nc.k;
    sensor.mixed_pixels = false;
    const Eigen::Isometry3d T_WS = perception::sensorPose(view.xyz_m, view.rpy_rad);
    const sim::Scan scan = sim::ErimScanner(plane.scene, sensor).scan(T_WS, base::viewSeed(nc.seed, 0));
    const perception::RangeImage& measured = scan.image;
    const int rows = measured.rows(), cols = measured.cols();
    const perception::ScanMap b = perception::scanToMap(measured, sensor, T_WS, grid, map.scanToMapConfig());

    // The situation: the bottom row has pixels past the interval.
    int bottom_folded = 0;
    for (int c = 0; c < cols; ++c) bottom_folded += measured.valid(rows - 1, c) && scan.true_range(rows - 1, c) > a;
    ASSERT_GT(bottom_folded, 2);

    const perception::SensorModel& noise = sensor;
    long valid = 0, nan = 0, far = 0, wrong = 0;
    for (int r = 0; r < rows; ++r)
      for (int c = 0; c < cols; ++c) {
        if (!measured.valid(r, c)) continue;
        ++valid;
        const double t = scan.true_range(r, c), u = b.image.range(r, c);
        far += t > a;
        if (!std::isfinite(u)) {
          ++nan;
          continue;
        }
        if (std::abs(u - t) > 6 * noise.rangeSigma(t)) {
          ++wrong;
          ADD_FAILURE() << "pixel " << r << " " << c << ": true " << t << " m, measured " << measured.range(r, c)
                        << " m, unwrapped " << u << " m";
        }
      }
    EXPECT_EQ(wrong, 0);
    EXPECT_GT(far, 100);
    // Continuity decides every fold of a plane; only the far field of k = 1e-3 (σ ≥ 0.4 m past
    // 20 m) may be too noisy to decide.
    EXPECT_LT(double(nan) / far, nc.k > 5e-4 ? 0.1 : 1e-12);

    // Pixels past the interval, widened by the noise that could fold a pixel short of it.
    auto folded = [&](int r, int c) {
      if (r < 0 || r >= rows || c < 0 || c >= cols) return false;
      const double t = scan.true_range(r, c);
      return std::isfinite(t) && t > a - 6 * noise.rangeSigma(a);
    };
    const Eigen::Isometry3d T_SW = measured.T_WS.inverse();
    const double epsilon = map.epsilon_rad;
    int region = 0, region_far = 0;
    for (int r = 0; r < grid.rows; ++r)
      for (int c = 0; c < grid.cols; ++c) {
        if (b.map.stateAt(r, c) != perception::CellState::Known) continue;
        const Eigen::Vector2d xy = grid.center(r, c);
        const double z = b.map.elevation()(r, c);
        const Eigen::Vector3d p = T_SW * Eigen::Vector3d(xy.x(), xy.y(), z);
        const Eigen::Vector2d px = pixelOf(measured, p);
        const int r0 = int(std::floor(px.x())), c0 = int(std::floor(px.y()));
        bool near_fold = false;  // the crossing's 2×2 pixels and one pixel around them
        for (int i = r0 - 1; i <= r0 + 2; ++i)
          for (int j = c0 - 1; j <= c0 + 2; ++j) near_fold = near_fold || folded(i, j);
        if (!near_fold) continue;
        ++region;
        region_far += p.norm() > a;
        // dφ/dz on the vertical line through the point, in the sensor frame: b = R^T·z.
        const Eigen::Vector3d v = T_SW.linear() * Eigen::Vector3d::UnitZ();
        const double dphi_dz = (p.y() * v.z() - p.z() * v.y()) / (p.y() * p.y() + p.z() * p.z());
        const double bound = 5 * b.map.sigma()(r, c) + epsilon / std::abs(dphi_dz);
        EXPECT_LE(std::abs(z - z_true(r, c)), bound) << "cell at x " << xy.x() << " y " << xy.y();
      }
    // Cells that need the unwrapping are known, and mapped beyond the interval.
    EXPECT_GT(region_far, 20);
    RecordProperty("cells_near_fold_k" + std::to_string(nc.k) + "_s" + std::to_string(nc.seed),
                   std::to_string(region));
  }
}

}  // namespace
}  // namespace ambler
