// The generalized locus algorithm against closed forms on synthetic range images.
#include <gtest/gtest.h>

#include <algorithm>

#include <cmath>
#include <cstring>
#include <limits>
#include <numbers>
#include <string>

#include "perception/locus_mapper.hpp"
#include "perception/range_edges.hpp"
#include "synthetic.hpp"

namespace ambler::perception {
namespace {

using test::Plane;
using test::planeImage;

constexpr double kDeg = std::numbers::pi / 180.0;

// The ERIM without range noise or quantisation.
SensorModel noiseFree() {
  SensorModel s;
  s.noise_k = 0;
  s.quantization_m = 0;
  return s;
}

// The angle between the beam and the plane at the point the sensor sees above (x, y).
double grazingAngle(const Plane& plane, const Eigen::Vector3d& sensor, double x, double y) {
  const Eigen::Vector3d p(x, y, plane.z(x, y));
  return std::asin(std::abs((p - sensor).normalized().dot(plane.normal())));
}

struct Tilt {
  double about_x_deg, about_y_deg;
};

class LocusPlane : public ::testing::TestWithParam<Tilt> {};

// Noise-free planes tilted up to 40° about either axis are mapped to 2 mm wherever the beam meets
// them at 10° or more. The bound: bilinear interpolation of ρ between pixels 0.47° apart errs by
// at most ρ''·Δφ²/8, which at 10° grazing and ≤ 15 m is ≈ 1.6 mm of elevation.
TEST_P(LocusPlane, MapsTiltedPlanesToTwoMillimetres) {
  const Tilt t = GetParam();
  const Plane plane{-std::tan(t.about_y_deg * kDeg), std::tan(t.about_x_deg * kDeg), 0.0};
  // A plane falling away from the sensor needs a steeper look to be seen at all.
  const double extra = std::min(0.0, t.about_x_deg);
  for (const Eigen::Vector3d& rpy : {Eigen::Vector3d(0, -30 + extra, 0), Eigen::Vector3d(3, -35 + extra, 25)}) {
    const Eigen::Vector3d sensor(0.3, -6, 3 + 6 * std::abs(plane.b) + 0.3 * std::abs(plane.a));
    const auto img = planeImage(plane, sensorPose(sensor, rpy * kDeg));
    const LocusMapper mapper(img, noiseFree(), nullptr);
    const auto grid = MapGrid::covering(-8, 8, -4, 12, 0.1);
    const ElevationMap map = mapper.map(grid);
    int checked = 0;
    double worst = 0;
    for (int r = 0; r < grid.rows; ++r)
      for (int c = 0; c < grid.cols; ++c) {
        if (map.stateAt(r, c) != CellState::Known) continue;
        const Eigen::Vector2d xy = grid.center(r, c);
        const double err = std::abs(map.elevation()(r, c) - plane.z(xy.x(), xy.y()));
        if (grazingAngle(plane, sensor, xy.x(), xy.y()) < 10 * kDeg) continue;
        worst = std::max(worst, err);
        EXPECT_LE(err, 2e-3) << "cell " << xy.transpose() << " tilt " << t.about_x_deg << "," << t.about_y_deg;
        ++checked;
      }
    EXPECT_GT(checked, 1000);  // the test must look at a real part of the plane
    RecordProperty("worst_error_m", std::to_string(worst));
  }
}

INSTANTIATE_TEST_SUITE_P(Tilts, LocusPlane,
                         ::testing::Values(Tilt{0, 0}, Tilt{20, 0}, Tilt{40, 0}, Tilt{-40, 0}, Tilt{0, 20},
                                           Tilt{0, 40}, Tilt{0, -40}, Tilt{25, 25}));

// Any resolution: the 2 cm and 10 cm maps agree at the cell centres they share (each 10 cm centre
// is a 2 cm centre). The same line gives the same answer up to the search's stopping rule:
// |Δφ| < ε moves the point along the line by at most ε·ρ/sin(line, beam) ≈ 1e-5·12/0.5 m.
// The constructor refuses what its tables cannot describe: an image smaller than one 2×2 cell,
// scan angles that are not evenly spaced (φ falling, θ rising), an edge mask of another size, and
// a map frame that is not gravity-aligned.
TEST(LocusMapper, RefusesImagesItsTablesCannotDescribe) {
  const Plane plane{0.0, 0.0, 0.0};
  const auto img = planeImage(plane, sensorPose({0, -6, 3}, {0, -30 * kDeg, 0}));
  EXPECT_NO_THROW(LocusMapper(img, SensorModel{}, nullptr));
  auto uneven = img;
  uneven.phi[10] += 0.1 * (img.phi[0] - img.phi[1]);
  EXPECT_THROW(LocusMapper(uneven, SensorModel{}, nullptr), std::invalid_argument);
  auto reversed = img;
  std::reverse(reversed.theta.begin(), reversed.theta.end());
  EXPECT_THROW(LocusMapper(reversed, SensorModel{}, nullptr), std::invalid_argument);
  const Raster<std::uint8_t> small = Raster<std::uint8_t>::Zero(img.rows() - 1, img.cols());
  EXPECT_THROW(LocusMapper(img, SensorModel{}, &small), std::invalid_argument);
  const auto tiny = RangeImage::blank(1, 8, 0.5, 0.5);
  EXPECT_THROW(LocusMapper(tiny, SensorModel{}, nullptr), std::invalid_argument);
  Eigen::Isometry3d tilted = Eigen::Isometry3d::Identity();
  tilted.linear() = Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitX()).toRotationMatrix();
  EXPECT_THROW(LocusMapper(img, SensorModel{}, nullptr, LocusConfig{}, tilted), std::invalid_argument);
}

TEST(LocusMapper, ResolutionIndependent) {
  const Plane plane{0.1, 0.2, 0.0};
  const auto img = planeImage(plane, sensorPose({0, -6, 3}, {0, -30 * kDeg, 0}));
  const LocusMapper mapper(img, noiseFree(), nullptr);
  const auto coarse = mapper.map(MapGrid::covering(-4, 4, -2, 8, 0.10));
  const auto fine = mapper.map(MapGrid::covering(-4, 4, -2, 8, 0.02));
  int shared = 0;
  for (int r = 0; r < coarse.grid().rows; ++r)
    for (int c = 0; c < coarse.grid().cols; ++c) {
      const int rf = 5 * r + 2, cf = 5 * c + 2;
      ASSERT_NEAR(coarse.grid().center(r, c).x(), fine.grid().center(rf, cf).x(), 1e-12);
      ASSERT_NEAR(coarse.grid().center(r, c).y(), fine.grid().center(rf, cf).y(), 1e-12);
      ASSERT_EQ(coarse.stateAt(r, c), fine.stateAt(rf, cf));
      if (coarse.stateAt(r, c) != CellState::Known) continue;
      EXPECT_NEAR(coarse.elevation()(r, c), fine.elevation()(rf, cf), 3e-4);
      ++shared;
    }
  EXPECT_GT(shared, 3000);
}

// The field of view: on a noise-free plane, every cell whose line the image covers where it meets
// the surface — the line's points on the two scanlines around the crossing both between the
// outermost pixel centres, with a tenth of a pixel to spare — is known, and no cell whose surface
// point lies outside the image is. For a level sensor and for rolled and yawed ones, whose
// vertical lines run slantwise through the image and leave it through its sides (the search clips
// each line to the part between the sides: docs/locus.md).
TEST(LocusMapper, KnownExactlyWhereTheImageCoversTheSurface) {
  const Plane plane{0.05, 0.1, 0.0};
  for (const Eigen::Vector3d& rpy : {Eigen::Vector3d(0, -30, 0), Eigen::Vector3d(20, -35, 25), Eigen::Vector3d(-15, -25, -40)}) {
    const Eigen::Isometry3d T = sensorPose({0.3, -6, 3}, rpy * kDeg);
    const auto img = planeImage(plane, T);
    const LocusMapper mapper(img, noiseFree(), nullptr);
    const auto grid = MapGrid::covering(-14, 14, -6, 16, 0.1);
    const ElevationMap map = mapper.map(grid);
    const double dphi = img.phi[0] - img.phi[1], dtheta = img.theta[1] - img.theta[0];
    int inside = 0, outside = 0;
    for (int r = 0; r < grid.rows; ++r)
      for (int c = 0; c < grid.cols; ++c) {
        const Eigen::Vector2d xy = grid.center(r, c);
        const Spherical q = cartesianToSpherical(T.inverse() * Eigen::Vector3d(xy.x(), xy.y(), plane.z(xy.x(), xy.y())));
        const double rf = (img.phi[0] - q.phi) / dphi, cf = (q.theta - img.theta[0]) / dtheta;
        // The line's column on the scan planes of rows r and r + 1 around the crossing.
        const auto columnOnRow = [&](int row) {
          const Eigen::Vector3d a = T.inverse() * Eigen::Vector3d(xy.x(), xy.y(), 0.0), b = T.linear().transpose().col(2);
          const double sp = std::sin(img.phi[row]), cp = std::cos(img.phi[row]);
          const Eigen::Vector3d p = a - (a.z() * cp - a.y() * sp) / (b.z() * cp - b.y() * sp) * b;
          return (cartesianToSpherical(p).theta - img.theta[0]) / dtheta;
        };
        const int r0 = int(std::floor(rf));
        const bool in = rf > 0.1 && rf < img.rows() - 1.1 && q.rho < 40 &&
                        std::min(columnOnRow(r0), columnOnRow(r0 + 1)) > 0.1 &&
                        std::max(columnOnRow(r0), columnOnRow(r0 + 1)) < img.cols() - 1.1;
        const bool out = rf < -0.1 || rf > img.rows() - 0.9 || cf < -0.1 || cf > img.cols() - 0.9 || q.rho > 40;
        if (in) {
          EXPECT_EQ(map.stateAt(r, c), CellState::Known) << "cell " << xy.transpose() << " rpy " << rpy.transpose();
          ++inside;
        }
        if (out) {
          EXPECT_NE(map.stateAt(r, c), CellState::Known) << "cell " << xy.transpose() << " rpy " << rpy.transpose();
          ++outside;
        }
      }
    EXPECT_GT(inside, 5000);
    EXPECT_GT(outside, 5000);
  }
}

// The paper's plain bisection and the default steps close the same bracket below the same ε: the
// maps agree to the bound of ResolutionIndependent.
TEST(LocusMapper, BisectionAndDefaultStepsAgree) {
  const Plane plane{0.1, 0.2, 0.0};
  const auto img = planeImage(plane, sensorPose({0, -6, 3}, {0, -30 * kDeg, 0}));
  LocusConfig halving;
  halving.bisection = true;
  const auto grid = MapGrid::covering(-4, 4, -2, 8, 0.10);
  const auto fast = LocusMapper(img, noiseFree(), nullptr).map(grid);
  const auto paper = LocusMapper(img, noiseFree(), nullptr, halving).map(grid);
  int known = 0;
  for (int r = 0; r < grid.rows; ++r)
    for (int c = 0; c < grid.cols; ++c) {
      ASSERT_EQ(fast.stateAt(r, c), paper.stateAt(r, c));
      if (fast.stateAt(r, c) != CellState::Known) continue;
      EXPECT_NEAR(fast.elevation()(r, c), paper.elevation()(r, c), 3e-4);
      ++known;
    }
  EXPECT_GT(known, 3000);
}

// A pixel that returned nothing is never bridged: every known cell's final interpolation uses
// returned pixels only, and the cells whose locus crosses the hole are not known.
TEST(LocusMapper, UnreturnedPixelsNeverMakeKnownCells) {
  const Plane plane{0, 0, 0};
  auto img = planeImage(plane, sensorPose({0, -6, 3}, {0, -30 * kDeg, 0}));
  const auto full = LocusMapper(img, noiseFree(), nullptr).map(MapGrid::covering(-4, 4, -4, 8, 0.05));
  for (int r = 30; r < 34; ++r)
    for (int c = 120; c < 130; ++c) img.range(r, c) = std::numeric_limits<float>::quiet_NaN();
  const LocusMapper mapper(img, noiseFree(), nullptr);
  const auto holed = mapper.map(full.grid());
  int lost = 0;
  for (int r = 0; r < full.grid().rows; ++r)
    for (int c = 0; c < full.grid().cols; ++c) {
      if (holed.stateAt(r, c) == CellState::Known) {
        const Eigen::Vector2d xy = full.grid().center(r, c);
        const LocusHit hit = mapper.elevationAt(xy.x(), xy.y());
        const double rf = (img.phi[0] - hit.phi) / (img.phi[0] - img.phi[1]);
        const double cf = (hit.theta - img.theta[0]) / (img.theta[1] - img.theta[0]);
        for (int dr = 0; dr < 2; ++dr)
          for (int dc = 0; dc < 2; ++dc) {
            const int pr = std::min(int(rf) + dr, img.rows() - 1), pc = std::min(int(cf) + dc, img.cols() - 1);
            const double w = (dr ? rf - int(rf) : 1 - (rf - int(rf))) * (dc ? cf - int(cf) : 1 - (cf - int(cf)));
            if (w > 0) {
              EXPECT_TRUE(img.valid(pr, pc)) << "cell " << xy.transpose() << " uses pixel " << pr << "," << pc;
            }
          }
      }
      lost += full.stateAt(r, c) == CellState::Known && holed.stateAt(r, c) != CellState::Known;
    }
  EXPECT_GT(lost, 20);  // the hole removed cells
}

// The generalized locus: a tilted line meets the plane where the line–plane closed form says.
TEST(LocusMapper, GeneralLinesMeetThePlaneWhereTheClosedFormSays) {
  const Plane plane{0.15, -0.1, 0.2};
  const auto img = planeImage(plane, sensorPose({0, -6, 3}, {0, -30 * kDeg, 0}));
  const LocusMapper mapper(img, noiseFree(), nullptr);
  for (double tilt : {0.0, 0.2, 0.4}) {
    const Eigen::Vector3d v = Eigen::Vector3d(std::sin(tilt), 0.3 * std::sin(tilt), std::cos(tilt)).normalized();
    const Eigen::Vector3d u(0.5, 2.0, 0.0);
    const LocusHit hit = mapper.intersect(u, v);
    ASSERT_EQ(hit.state, CellState::Known);
    const double s = (plane.z(u.x(), u.y()) - u.z()) / (v.z() - plane.a * v.x() - plane.b * v.y());
    EXPECT_NEAR(hit.s, s, 2e-3);
  }
}

TEST(LocusMapper, PolygonQueryLeavesOutsideCellsUnseen) {
  const Plane plane{0, 0, 0.1};
  const auto img = planeImage(plane, sensorPose({0, -6, 3}, {0, -30 * kDeg, 0}));
  const LocusMapper mapper(img, noiseFree(), nullptr);
  const std::vector<Eigen::Vector2d> triangle{{-1, 1}, {1, 1}, {0, 3}};
  const ElevationMap m = mapper.mapPolygon(triangle, 0.05);
  int inside = 0;
  for (int r = 0; r < m.grid().rows; ++r)
    for (int c = 0; c < m.grid().cols; ++c) {
      const Eigen::Vector2d p = m.grid().center(r, c);
      const bool in = p.y() > 1 && p.y() < 3 && std::abs(p.x()) < (3 - p.y()) / 2;
      const bool clearly_out = p.y() < 0.99 || std::abs(p.x()) > (3 - p.y()) / 2 + 0.01;
      if (in && std::abs(p.x()) < (3 - p.y()) / 2 - 0.01) {  // clearly inside
        EXPECT_EQ(m.stateAt(r, c), CellState::Known);
        EXPECT_NEAR(m.elevation()(r, c), 0.1, 2e-3);
        ++inside;
      }
      if (clearly_out) {
        EXPECT_EQ(m.stateAt(r, c), CellState::Unseen);
      }
    }
  EXPECT_GT(inside, 500);
}

}  // namespace
// The SIMD lanes hand back every cell they cannot finish exactly as the scalar search would —
// holes of unreturned pixels, edge pixels, lines beside the image or past its last scanline — so
// the map is the scalar map bit for bit, at every lane ISA the CPU has: a rolled, yawed sensor
// over a tilted plane with holes and a scattered edge mask, at three cell sizes.
TEST(LocusMapper, LanesHandBackWhatTheyCannotFinish) {
  const Plane plane{0.15, -0.1, 0.2};
  auto img = planeImage(plane, sensorPose({0.3, -6, 3}, {5 * kDeg, -28 * kDeg, 12 * kDeg}));
  for (int r = 20; r < 26; ++r)
    for (int c = 60; c < 75; ++c) img.range(r, c) = std::numeric_limits<float>::quiet_NaN();
  for (int c = 0; c < img.cols(); c += 7) img.range(40, c) = std::numeric_limits<float>::quiet_NaN();
  perception::Raster<std::uint8_t> edges = perception::Raster<std::uint8_t>::Zero(img.rows(), img.cols());
  for (int r = 0; r < img.rows(); ++r)
    for (int c = (r * 13) % 17; c < img.cols(); c += 17) edges(r, c) = 1;
  LocusConfig lanes, scalar;
  scalar.vectorized = false;
  const LocusMapper fast(img, noiseFree(), &edges, lanes), slow(img, noiseFree(), &edges, scalar);
  for (const auto isa : {LaneIsa::Avx512, LaneIsa::Avx2}) {
    const LaneIsaCap cap(isa);
    for (const double cell : {0.03, 0.10, 0.25}) {
      const auto grid = MapGrid::covering(-8, 8, -4, 12, cell);
      long by_lanes = -1;
      const auto a = fast.map(grid, &by_lanes), b = slow.map(grid);
      int known = 0, unknown = 0, differ = 0;
      for (int r = 0; r < grid.rows; ++r)
        for (int c = 0; c < grid.cols; ++c) {
          const float za = a.elevation()(r, c), zb = b.elevation()(r, c), sa = a.sigma()(r, c), sb = b.sigma()(r, c);
          differ += a.stateAt(r, c) != b.stateAt(r, c) || std::memcmp(&za, &zb, sizeof za) != 0 ||
                    std::memcmp(&sa, &sb, sizeof sa) != 0;
          (a.stateAt(r, c) == CellState::Known ? known : unknown) += 1;
        }
      EXPECT_EQ(differ, 0) << "cell " << cell << ", lanes " << int(LocusMapper::laneIsa());
      EXPECT_GT(known, grid.cells() / 4);
      EXPECT_GT(unknown, grid.cells() / 10);  // the map reaches past the image on every side
      if (LocusMapper::laneIsa() != LaneIsa::None) {
        EXPECT_GT(by_lanes, known / 3);
      }
    }
  }
}

// Bridge σ (LocusConfig::bridge_sigma, docs/locus.md, "Bridged occlusions") against the ground
// truth of a lip too shallow to be an occlusion (range_edges' ShallowOcclusionsAreBridgedDeepOnesKept:
// 0.6 times what the gnc_bridge rule keeps, so the edge detector with the rule finds no edge). Seen
// from 3 m, the ray past a lip at y0 lands a drop D lower at y0·(3 + D)/3: the far ground between
// is hidden, and the map bridges it from the lip to the far ground. Two sensors: noise-free, and
// the ERIM's 7.62 cm counts without noise (whole counts: the staircase the sensor reports). With
// bridge σ every hidden cell the map calls known is within 3σ of the truth, and so is the visible
// ground away from the lip. The negative control: with plain σ the counts' staircase hides the
// lip's jump from the roughness term, and bridged cells lie beyond 3σ.
TEST(LocusMapper, BridgeSigmaCoversTheGroundAShallowOcclusionHides) {
  const double h = 3, y0 = 9, dphi = 30 * kDeg / 64;
  GncConfig gnc;
  gnc.occlusion_depth_k = 3;
  const double rho = std::hypot(y0, h), L = rho * rho * dphi / h;
  const double drop = 0.6 * gnc.occlusion_depth_k * gnc.surface_sigma_m * std::pow(L / gnc.surface_scale_m, gnc.surface_hurst);
  const auto hiddenAt = [&](double y) { return y > y0 && y < y0 * (h + drop) / h; };
  const auto truthAt = [&](double y) { return y < y0 ? 0.0 : -drop; };
  for (const double q : {0.0, 0.0762}) {
    SensorModel sensor = noiseFree();
    sensor.quantization_m = q;
    auto img = RangeImage::blank(64, 256, 30 * kDeg, 80 * kDeg);
    img.T_WS = sensorPose({0, 0, h}, {0, -25 * kDeg, 0});
    const Eigen::Vector3d o = img.T_WS.translation();
    for (int r = 0; r < img.rows(); ++r)
      for (int c = 0; c < img.cols(); ++c) {
        const Eigen::Vector3d d = img.T_WS.linear() * beamDirection(img.phi[r], img.theta[c]);
        const double t_near = test::rangeToPlane(o, d, {0, 0, 0}), t_far = test::rangeToPlane(o, d, {0, 0, -drop});
        const double t = o.y() + t_near * d.y() < y0 ? t_near : t_far;
        img.range(r, c) = !(t <= 20) ? std::numeric_limits<float>::quiet_NaN() : float(q > 0 ? q * std::nearbyint(t / q) : t);
      }
    const auto edges = detectRangeEdges(img, sensor, gnc);
    const auto grid = MapGrid::covering(-2, 2, y0 - 1, y0 + 1.5, 0.1);
    for (const bool bridge : {false, true}) {
      LocusConfig config;
      config.bridge_sigma = bridge;
      const ElevationMap map = LocusMapper(img, sensor, &edges, config).map(grid);
      int hidden_known = 0, hidden_beyond = 0, visible_known = 0, visible_beyond = 0;
      for (int r = 0; r < grid.rows; ++r)
        for (int c = 0; c < grid.cols; ++c) {
          if (map.stateAt(r, c) != CellState::Known) continue;
          const double y = grid.center(r, c).y(), err = std::abs(map.elevation()(r, c) - truthAt(y));
          const bool beyond = err > 3 * map.sigma()(r, c);
          if (hiddenAt(y)) {
            ++hidden_known, hidden_beyond += beyond;
          } else if (std::abs(y - y0) > 0.3) {  // visible ground away from the lip's bracket
            ++visible_known, visible_beyond += beyond;
          }
        }
      SCOPED_TRACE(std::string(bridge ? "bridge sigma" : "plain sigma") + ", counts of " + std::to_string(q) + " m");
      ASSERT_GT(hidden_known, 20) << "the hidden band is bridged, not left out";
      ASSERT_GT(visible_known, 500);
      EXPECT_EQ(visible_beyond, 0);
      if (bridge) EXPECT_EQ(hidden_beyond, 0);
      if (!bridge && q > 0) EXPECT_GT(hidden_beyond, 0) << "the negative control: plain sigma misses the bridge";
    }
  }
}

}  // namespace ambler::perception
