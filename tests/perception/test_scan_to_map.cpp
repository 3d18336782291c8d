// Maps in a frame of their own (MapGrid::T_WM): scanToMap, the locus mapper and the Cartesian
// baseline on noise-free synthetic planes, in a yawed, offset frame and in a translated one,
// against the plane's closed form and against the same lines mapped in the world frame.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "perception/cartesian_mapper.hpp"
#include "perception/locus_mapper.hpp"
#include "perception/scan_to_map.hpp"
#include "perception/sensor_geometry.hpp"
#include "synthetic.hpp"

namespace ambler::perception {
namespace {

using test::Plane;
using test::planeImage;

constexpr double kDeg = std::numbers::pi / 180.0;
constexpr double kU = 0x1p-24;  // unit round-off of float32: ranges and stored elevations

// A noise-free, unquantised sensor without an ambiguity interval (the synthetic image is not
// folded), of the synthetic image's geometry (64 × 256 over 30° × 80°: the defaults).
SensorModel exactSensor() {
  SensorModel s;
  s.noise_k = 0;
  s.quantization_m = 0;
  s.ambiguity_m = 0;
  return s;
}

// A plane has no occluding edge: the tests weigh the geometry, not the edge detector.
ScanToMapConfig geometryOnly() {
  ScanToMapConfig c;
  c.shadows = ShadowMethod::None;
  return c;
}

const Plane kPlane{0.15, -0.1, 0.2};
const Eigen::Isometry3d kSensor = sensorPose({0.3, -6, 3.5}, Eigen::Vector3d(3, -32, 20) * kDeg);

// |dz/dφ| along the vertical line through world (x, y) at world height z: how far a change of the
// sensor's scan angle φ moves the point along the line (central difference; the error is
// O(h²·φ''') ≪ the value).
double dzdphi(const Eigen::Isometry3d& T_WS, double x, double y, double z) {
  const double h = 1e-3;
  const Eigen::Isometry3d T_SW = T_WS.inverse();
  const double up = cartesianToSpherical(T_SW * Eigen::Vector3d(x, y, z + h)).phi;
  const double down = cartesianToSpherical(T_SW * Eigen::Vector3d(x, y, z - h)).phi;
  return 2 * h / std::abs(up - down);
}

// Two searches of the same line on the same image each stop with a bracket narrower than ε in φ
// that holds the one crossing (a plane has one), so each returned point is within ε·|dz/dφ| of
// it along the line: they differ by at most 2ε·|dz/dφ| (with 1 % for dz/dφ's change across the
// bracket); a map stores each as float32 (≤ u·|z| each, two of them at most).
double searchTolerance(const LocusConfig& c, double dz_dphi, double z) {
  return 2 * c.epsilon_rad * dz_dphi * 1.01 + 2 * kU * std::abs(z) + 1e-12;
}

// The angle between the beam and the plane at its world point p.
double grazingAngle(const Plane& plane, const Eigen::Vector3d& sensor, const Eigen::Vector3d& p) {
  return std::asin(std::abs((p - sensor).normalized().dot(plane.normal())));
}

// (a) A yawed, offset frame: every Known cell holds the plane's height at the cell centre's world
// point minus the frame origin's z. Against the same vertical line (in the world) searched by a
// world-frame mapper: within the search's stopping rule (searchTolerance). Against the plane's
// closed form: within 2 mm where the beam meets the plane at 10° or more and ρ ≤ 15 m — the bound
// of bilinear interpolation of ρ between pixels (ρ''·Δφ²/8 ≈ 1.6 mm there, test_locus_mapper.cpp),
// which no frame changes; the frame adds only the search's ≤ 3e-4 m and float rounding.
TEST(ScanToMap, YawedOffsetFrameHoldsThePlaneHeightsOfItsCells) {
  const SensorModel sensor = exactSensor();
  const RangeImage img = planeImage(kPlane, kSensor);
  const Eigen::Vector3d origin(1.5, 2.0, 0.35);
  const Eigen::Isometry3d T_WM = mapFrame(origin, 50 * kDeg);
  const MapGrid grid = MapGrid::covering(-12, 12, -12, 12, 0.1, T_WM);
  const ScanMap out = scanToMap(img, sensor, kSensor, grid, geometryOnly());
  ASSERT_TRUE(out.map.grid().sameAs(grid));
  EXPECT_FALSE(out.edges.has_value());

  const LocusMapper world(img, sensor, nullptr, geometryOnly().locus);
  int known = 0, near_field = 0;
  for (int r = 0; r < grid.rows; ++r)
    for (int c = 0; c < grid.cols; ++c) {
      if (out.map.stateAt(r, c) != CellState::Known) continue;
      ++known;
      const Eigen::Vector3d p = grid.worldPoint(r, c, 0.0);
      const double z = out.map.elevation()(r, c);
      const LocusHit ref = world.elevationAt(p.x(), p.y());
      ASSERT_EQ(ref.state, CellState::Known) << "cell " << r << "," << c;
      const double tol = searchTolerance(geometryOnly().locus, dzdphi(kSensor, p.x(), p.y(), ref.point.z()), z);
      EXPECT_NEAR(z, ref.point.z() - origin.z(), tol) << "cell " << r << "," << c;
      const Eigen::Vector3d on_plane(p.x(), p.y(), kPlane.z(p.x(), p.y()));
      if (grazingAngle(kPlane, kSensor.translation(), on_plane) < 10 * kDeg ||
          (on_plane - kSensor.translation()).norm() > 15.0)
        continue;
      EXPECT_NEAR(z, kPlane.z(p.x(), p.y()) - origin.z(), 2e-3) << "cell " << r << "," << c;
      ++near_field;
    }
  EXPECT_GT(known, 5000);
  EXPECT_GT(near_field, 2000);
}

// (b) The same cells in the world frame and in a frame that is a pure translation (the grid
// shifted with it, so that every cell centre is the same world point): the same states, and
// elevations that differ by the origin's z up to the search's stopping rule.
TEST(ScanToMap, TranslatedFrameAgreesWithTheWorldFrameCellByCell) {
  const SensorModel sensor = exactSensor();
  const RangeImage img = planeImage(kPlane, kSensor);
  const Eigen::Vector3d origin(1.25, -0.75, 0.5);  // dyadic: the shifted grid's bounds are exact
  const Eigen::Isometry3d T_WM = mapFrame(origin, 0.0);
  ASSERT_TRUE(T_WM.linear().isIdentity(0.0));
  const MapGrid in_world = MapGrid::covering(-8, 8, -4, 12, 0.1);
  const MapGrid in_m = MapGrid::covering(-8 - origin.x(), 8 - origin.x(), -4 - origin.y(), 12 - origin.y(), 0.1, T_WM);
  ASSERT_EQ(in_world.rows, in_m.rows);
  ASSERT_EQ(in_world.cols, in_m.cols);
  const ScanMap w = scanToMap(img, sensor, kSensor, in_world, geometryOnly());
  const ScanMap m = scanToMap(img, sensor, kSensor, in_m, geometryOnly());
  ASSERT_TRUE(m.map.grid().sameAs(in_m));
  LocusConfig config;
  int known = 0;
  for (int r = 0; r < in_world.rows; ++r)
    for (int c = 0; c < in_world.cols; ++c) {
      const Eigen::Vector3d pw = in_world.worldPoint(r, c, 0.0), pm = in_m.worldPoint(r, c, 0.0);
      ASSERT_NEAR((pw.head<2>() - pm.head<2>()).norm(), 0.0, 1e-12);  // the same vertical line
      ASSERT_EQ(pm.z() - pw.z(), origin.z());
      ASSERT_EQ(w.map.stateAt(r, c), m.map.stateAt(r, c)) << "cell " << r << "," << c;
      if (w.map.stateAt(r, c) != CellState::Known) continue;
      ++known;
      const double zw = w.map.elevation()(r, c), zm = m.map.elevation()(r, c);
      EXPECT_NEAR(zm, zw - origin.z(), searchTolerance(config, dzdphi(kSensor, pw.x(), pw.y(), zw), zw))
          << "cell " << r << "," << c;
    }
  EXPECT_GT(known, 5000);
}

// mapAtPose: a scan mapped again from another pose, in another frame, gives the bits scanToMap
// gives for the measured image at that pose (unwrapping and edges do not depend on the pose), GNC
// edges on.
TEST(ScanToMap, MapAtPoseIsScanToMapAtThatPose) {
  const SensorModel sensor = exactSensor();
  const RangeImage img = planeImage(kPlane, kSensor);
  const Eigen::Isometry3d other = sensorPose({0.5, -5.5, 3.4}, Eigen::Vector3d(2, -30, 25) * kDeg);
  const MapGrid grid = MapGrid::covering(-4, 4, -2, 8, 0.1, mapFrame({0.5, -0.25, 0.1}, 10 * kDeg));
  const ScanMap at_first = scanToMap(img, sensor, kSensor, grid);
  const ElevationMap again = mapAtPose(at_first, other, grid, LocusConfig{});
  const ElevationMap direct = scanToMap(img, sensor, other, grid).map;
  ASSERT_GT(direct.count(CellState::Known), 1000);
  for (int r = 0; r < grid.rows; ++r)
    for (int c = 0; c < grid.cols; ++c) {
      ASSERT_EQ(again.stateAt(r, c), direct.stateAt(r, c)) << r << " " << c;
      if (direct.stateAt(r, c) != CellState::Known) continue;
      ASSERT_EQ(again.elevation()(r, c), direct.elevation()(r, c));
      ASSERT_EQ(again.sigma()(r, c), direct.sigma()(r, c));
    }
}

// (c) Frames and grids that cannot be mapped are refused.
TEST(ScanToMap, RefusesTiltedFramesEmptyGridsAndAForeignFrame) {
  const SensorModel sensor = exactSensor();
  const RangeImage img = planeImage(kPlane, kSensor);
  Eigen::Isometry3d tilted = mapFrame({0, 0, 0}, 0.3);
  tilted.linear() = tilted.linear() * Eigen::AngleAxisd(0.05, Eigen::Vector3d::UnitX()).toRotationMatrix();
  EXPECT_THROW(scanToMap(img, sensor, kSensor, MapGrid::covering(-2, 2, 0, 4, 0.1, tilted)), std::invalid_argument);
  MapGrid empty = MapGrid::covering(-2, 2, 0, 4, 0.1);
  empty.rows = 0;
  EXPECT_THROW(scanToMap(img, sensor, kSensor, empty), std::invalid_argument);
  MapGrid no_cols = MapGrid::covering(-2, 2, 0, 4, 0.1);
  no_cols.cols = 0;
  EXPECT_THROW(scanToMap(img, sensor, kSensor, no_cols), std::invalid_argument);
  MapGrid zero_cell = MapGrid::covering(-2, 2, 0, 4, 0.1);
  zero_cell.cell = 0;
  EXPECT_THROW(scanToMap(img, sensor, kSensor, zero_cell), std::invalid_argument);
  SensorModel bad = sensor;
  bad.noise_k = -1;
  EXPECT_THROW(scanToMap(img, bad, kSensor, MapGrid::covering(-2, 2, 0, 4, 0.1)), std::invalid_argument);

  // A mapper maps only grids of its own frame.
  const Eigen::Isometry3d T_A = mapFrame({1, 2, 0.5}, 0.4);
  const LocusMapper in_a(img, sensor, nullptr, LocusConfig{}, T_A);
  EXPECT_NO_THROW(in_a.map(MapGrid::covering(-1, 1, 0, 2, 0.1, T_A)));
  EXPECT_THROW(in_a.map(MapGrid::covering(-1, 1, 0, 2, 0.1)), std::invalid_argument);
  EXPECT_THROW(in_a.map(MapGrid::covering(-1, 1, 0, 2, 0.1, mapFrame({1, 2, 0.5}, 0.41))), std::invalid_argument);
  const LocusMapper in_world(img, sensor, nullptr);
  EXPECT_THROW(in_world.map(MapGrid::covering(-1, 1, 0, 2, 0.1, T_A)), std::invalid_argument);
}

// (d) The Cartesian baseline in a yawed, offset frame. In M the plane is z_M(x, y) =
// plane(R·(x, y) + o_xy) − o_z, still a plane, so a binned cell (the mean of its points) holds
// z_M at its points' mean (x, y), and a linearly filled cell z_M at its centre, up to float
// rounding: ρ rounded to float moves a point off the plane by ≤ u·ρ·√(1+a²+b²) vertically, and
// z is stored as float (u·|z|). Points are binned by their (x, y) in M: a binned cell's mean lies
// inside the cell.
TEST(ScanToMap, CartesianBaselineInAYawedFramePutsThePlaneAtTheRightHeights) {
  const RangeImage img = planeImage(kPlane, kSensor);
  const Eigen::Vector3d origin(-0.8, 1.1, -0.3);
  const Eigen::Isometry3d T_WM = mapFrame(origin, -35 * kDeg);
  const MapGrid grid = MapGrid::covering(-10, 10, -10, 10, 0.1, T_WM);
  const Eigen::Matrix2d R = T_WM.linear().topLeftCorner<2, 2>();
  auto zM = [&](const Eigen::Vector2d& xy) {
    const Eigen::Vector2d w = R * xy + origin.head<2>();
    return kPlane.z(w.x(), w.y()) - origin.z();
  };
  double rho_max = 0;
  for (int r = 0; r < img.rows(); ++r)
    for (int c = 0; c < img.cols(); ++c)
      if (img.valid(r, c)) rho_max = std::max(rho_max, double(img.range(r, c)));
  const double slope_factor = std::sqrt(1 + kPlane.a * kPlane.a + kPlane.b * kPlane.b);
  const CartesianBins bins = binPoints(img, grid);
  const ElevationMap map = cartesianMap(img, grid, CartesianConfig{GapFill::Linear, 0.5});
  ASSERT_TRUE(map.grid().sameAs(grid));
  int binned = 0, filled = 0;
  for (int r = 0; r < grid.rows; ++r)
    for (int c = 0; c < grid.cols; ++c) {
      if (map.stateAt(r, c) != CellState::Known) continue;
      const double z = map.elevation()(r, c);
      const double tol = kU * (rho_max * slope_factor + std::abs(z)) + 1e-12;
      const Eigen::Vector2d centre = grid.center(r, c);
      if (bins.count(r, c) > 0) {
        const Eigen::Vector2d mean(bins.mean_x(r, c), bins.mean_y(r, c));
        EXPECT_LE((mean - centre).cwiseAbs().maxCoeff(), 0.5 * grid.cell + 1e-12) << "cell " << r << "," << c;
        EXPECT_NEAR(z, zM(mean), tol) << "cell " << r << "," << c;
        ++binned;
      } else {
        EXPECT_NEAR(z, zM(centre), tol) << "cell " << r << "," << c;
        ++filled;
      }
    }
  EXPECT_GT(binned, 3000);
  EXPECT_GT(filled, 500);
}

}  // namespace
}  // namespace ambler::perception
