// The Cartesian baseline on analytic planes: binning, nearest and linear gap filling, holes,
// the field-of-view edge, determinism, and the fall of point density with range.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <numbers>
#include <vector>

#include "perception/cartesian_mapper.hpp"
#include "perception/sensor_geometry.hpp"

namespace ambler::perception {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;
constexpr double kU = 0x1p-24;  // unit round-off of float32: ranges and elevations are floats
const double kSqrt2 = std::numbers::sqrt2;

struct Plane {
  double a, b, c;
  double at(double x, double y) const { return a * x + b * y + c; }
  double slope() const { return std::hypot(a, b); }
};

// The ERIM's default image of the plane, each pixel the exact range of its ray (rounded to float),
// NaN where the ray misses it in front. `nan_rows` [first, last) get no return.
RangeImage planeImage(const Plane& p, int nan_first = 0, int nan_last = 0) {
  RangeImage im = RangeImage::blank(64, 256, 30 * kDeg, 80 * kDeg);
  im.T_WS = sensorPose({0, -6, 3}, {0, -30 * kDeg, 0});
  const Eigen::Vector3d o = im.T_WS.translation();
  for (int r = 0; r < im.rows(); ++r)
    for (int c = 0; c < im.cols(); ++c) {
      const Eigen::Vector3d d = im.T_WS.linear() * beamDirection(im.phi[r], im.theta[c]);
      const double rho = (p.at(o.x(), o.y()) - o.z()) / (d.z() - p.a * d.x() - p.b * d.y());
      if (rho > 0 && rho < 40 && (r < nan_first || r >= nan_last)) im.range(r, c) = float(rho);
    }
  return im;
}

const MapGrid kGrid = MapGrid::covering(-5, 5, -3, 8, 0.1);  // the scenario's default region
const Plane kPlane{0.04, 0.06, 0.2};

// The test's own binning, from RangeImage::pointWorld: the points of every cell.
std::vector<std::vector<Eigen::Vector3d>> referenceBins(const RangeImage& im, const MapGrid& g) {
  std::vector<std::vector<Eigen::Vector3d>> cells(g.cells());
  for (int r = 0; r < im.rows(); ++r)
    for (int c = 0; c < im.cols(); ++c)
      if (im.valid(r, c)) {
        const Eigen::Vector3d p = im.pointWorld(r, c);
        const auto cell = g.cellOf(p.x(), p.y());
        if (cell) cells[long((*cell)(0)) * g.cols + (*cell)(1)].push_back(p);
      }
  return cells;
}

// Bound on |z − plane(x, y)| of a stored elevation: ρ is rounded to float (|δρ| ≤ u·ρ, which moves
// the point off the plane by δρ·|d_z − a·d_x − b·d_y| ≤ δρ·√(1+a²+b²)), then z is rounded to float.
double floatTolerance(const RangeImage& im, const Plane& p) {
  double rho_max = 0, z_max = 0;
  for (int r = 0; r < im.rows(); ++r)
    for (int c = 0; c < im.cols(); ++c)
      if (im.valid(r, c)) {
        rho_max = std::max(rho_max, double(im.range(r, c)));
        z_max = std::max(z_max, std::abs(im.pointWorld(r, c).z()));
      }
  return kU * (rho_max * std::sqrt(1 + p.a * p.a + p.b * p.b) + z_max) + 1e-12;
}

ElevationMap mapWith(const RangeImage& im, GapFill fill, double max_gap_m = 0.5) {
  return cartesianMap(im, kGrid, CartesianConfig{fill, max_gap_m});
}

// Where the ground point under a cell centre is seen from: (φ, θ) and its distance from the
// sensor's x axis (|∇φ| = 1/that, |∇θ| = 1/ρ is smaller).
struct Look {
  double phi, theta, r_perp;
};
Look lookAt(const RangeImage& im, const Plane& p, const Eigen::Vector2d& xy) {
  const Eigen::Vector3d s = im.T_WS.inverse() * Eigen::Vector3d(xy.x(), xy.y(), p.at(xy.x(), xy.y()));
  const Spherical sph = cartesianToSpherical(s);
  return {sph.phi, sph.theta, std::hypot(s.y(), s.z())};
}

// True if every ground point within `reach` (horizontal) of the cell centre is seen outside the
// image's pixel-centre angles: moving s metres along the plane turns φ and θ by at most
// s / (r⊥ − s) with s = reach·√(1 + slope²).
bool outsideFieldOfView(const RangeImage& im, const Plane& p, const Eigen::Vector2d& xy, double reach) {
  const Look l = lookAt(im, p, xy);
  const double s = reach * std::sqrt(1 + p.slope() * p.slope());
  if (l.r_perp <= s) return false;
  const double m = s / (l.r_perp - s);
  return l.phi > im.phi.front() + m || l.phi < im.phi.back() - m || l.theta < im.theta.front() - m ||
         l.theta > im.theta.back() + m;
}

// Every binned cell holds the mean of its points: z equals the plane at the points' mean (x, y) up
// to float rounding, and differs from the plane at the cell centre by at most slope × half-diagonal.
TEST(CartesianMapper, BinnedCellsAreTheMeanOfTheirPoints) {
  const RangeImage im = planeImage(kPlane);
  const auto ref = referenceBins(im, kGrid);
  const CartesianBins bins = binPoints(im, kGrid);
  const ElevationMap map = mapWith(im, GapFill::None);
  const double tol = floatTolerance(im, kPlane);
  long binned = 0, multi = 0;
  double worst_mean = 0, worst_centre = 0;
  for (int r = 0; r < kGrid.rows; ++r)
    for (int c = 0; c < kGrid.cols; ++c) {
      const auto& pts = ref[long(r) * kGrid.cols + c];
      ASSERT_EQ(bins.count(r, c), int(pts.size())) << r << "," << c;
      if (pts.empty()) {
        EXPECT_EQ(map.stateAt(r, c), CellState::Unseen);
        EXPECT_TRUE(std::isnan(map.elevation()(r, c)) && std::isnan(bins.mean_z(r, c)));
        continue;
      }
      ++binned;
      Eigen::Vector3d mean = Eigen::Vector3d::Zero();
      for (const auto& p : pts) mean += p;
      mean /= double(pts.size());
      ASSERT_EQ(map.stateAt(r, c), CellState::Known);
      const double z = map.elevation()(r, c);
      EXPECT_NEAR(bins.mean_x(r, c), mean.x(), 1e-12);
      EXPECT_NEAR(bins.mean_y(r, c), mean.y(), 1e-12);
      EXPECT_NEAR(z, mean.z(), kU * std::abs(mean.z()) + 1e-12);  // the average, stored as float
      const double e_mean = std::abs(z - kPlane.at(mean.x(), mean.y()));
      EXPECT_LE(e_mean, tol);
      const Eigen::Vector2d centre = kGrid.center(r, c);
      const double e_centre = std::abs(z - kPlane.at(centre.x(), centre.y()));
      EXPECT_LE(e_centre, kPlane.slope() * kGrid.cell / kSqrt2 + tol);
      worst_mean = std::max(worst_mean, e_mean);
      worst_centre = std::max(worst_centre, e_centre);
      if (pts.size() < 2) {
        EXPECT_TRUE(std::isnan(map.sigma()(r, c)));
        continue;
      }
      ++multi;
      double ss = 0;
      for (const auto& p : pts) ss += (p.z() - mean.z()) * (p.z() - mean.z());
      const double sem = std::sqrt(ss / (double(pts.size()) * (pts.size() - 1)));
      EXPECT_NEAR(map.sigma()(r, c), sem, 2 * kU * sem + 1e-12);
    }
  EXPECT_GT(binned, 3000);
  EXPECT_GT(multi, 1000);
  std::printf("binned %ld cells (%ld with >= 2 points); |z - plane(mean xy)| <= %.2e (bound %.2e), "
              "|z - plane(centre)| <= %.2e (bound %.2e)\n",
              binned, multi, worst_mean, tol, worst_centre, kPlane.slope() * kGrid.cell / kSqrt2 + tol);
}

// Barycentric interpolation of samples of a plane is the plane: every filled cell is exact up to
// the vertices' float rounding, and the interior of the footprint is covered.
TEST(CartesianMapper, LinearFillReproducesThePlane) {
  const RangeImage im = planeImage(kPlane);
  const CartesianBins bins = binPoints(im, kGrid);
  const ElevationMap none = mapWith(im, GapFill::None);
  const ElevationMap map = mapWith(im, GapFill::Linear);
  const double tol = floatTolerance(im, kPlane);
  long filled = 0, interior = 0;
  double worst = 0;
  for (int r = 0; r < kGrid.rows; ++r)
    for (int c = 0; c < kGrid.cols; ++c) {
      const Eigen::Vector2d centre = kGrid.center(r, c);
      if (bins.count(r, c) > 0) {
        EXPECT_EQ(map.elevation()(r, c), none.elevation()(r, c));  // binned cells are left alone
        continue;
      }
      // Well inside: the ground within two cell diagonals is seen inside the image.
      const Look l = lookAt(im, kPlane, centre);
      const double m = 2 * kSqrt2 * kGrid.cell * 1.01 / (l.r_perp - 2 * kSqrt2 * kGrid.cell);
      if (l.phi < im.phi.front() - m && l.phi > im.phi.back() + m && l.theta > im.theta.front() + m &&
          l.theta < im.theta.back() - m) {
        ++interior;
        EXPECT_EQ(map.stateAt(r, c), CellState::Known) << "interior cell " << r << "," << c;
      }
      if (map.stateAt(r, c) != CellState::Known) continue;
      ++filled;
      const double e = std::abs(map.elevation()(r, c) - kPlane.at(centre.x(), centre.y()));
      EXPECT_LE(e, tol) << r << "," << c;
      worst = std::max(worst, e);
      EXPECT_TRUE(std::isnan(map.sigma()(r, c)));
    }
  EXPECT_GT(filled, 500);
  EXPECT_GT(interior, 500);
  std::printf("linear: %ld empty cells filled (%ld interior ones checked), max error %.2e (bound %.2e)\n",
              filled, interior, worst, tol);
}

// Nearest fill copies the value of the nearest binned cell: its error is at most slope × the
// distance from the cell centre to that cell's centroid, ≤ d + half a diagonal. It fills exactly
// the empty cells within max_gap_m of a binned cell.
TEST(CartesianMapper, NearestFillErrorIsBoundedBySlopeTimesDistance) {
  const RangeImage im = planeImage(kPlane);
  const double max_gap = 0.5;
  const ElevationMap map = mapWith(im, GapFill::Nearest, max_gap);
  const double tol = floatTolerance(im, kPlane);
  // Binned cells up to w cells beyond the grid count too: points off the map serve its border.
  const int w = int(std::ceil(max_gap / kGrid.cell)) + 1;
  const MapGrid wide{kGrid.x_min - w * kGrid.cell, kGrid.y_max + w * kGrid.cell, kGrid.cell, kGrid.rows + 2 * w,
                     kGrid.cols + 2 * w};
  const CartesianBins bins = binPoints(im, wide);
  long filled = 0;
  double worst_ratio = 0;
  for (int r = 0; r < kGrid.rows; ++r)
    for (int c = 0; c < kGrid.cols; ++c) {
      if (bins.count(r + w, c + w) > 0) continue;
      double d = INFINITY;  // to the nearest binned cell centre, metres
      for (int i = r; i <= r + 2 * w; ++i)
        for (int j = c; j <= c + 2 * w; ++j)
          if (bins.count(i, j) > 0) d = std::min(d, kGrid.cell * std::hypot(i - r - w, j - c - w));
      if (d > max_gap + 1e-9) {
        EXPECT_EQ(map.stateAt(r, c), CellState::Unseen) << r << "," << c;
        continue;
      }
      ASSERT_EQ(map.stateAt(r, c), CellState::Known) << r << "," << c;
      ++filled;
      const Eigen::Vector2d centre = kGrid.center(r, c);
      const double e = std::abs(map.elevation()(r, c) - kPlane.at(centre.x(), centre.y()));
      const double bound = kPlane.slope() * (d + kGrid.cell / kSqrt2) + tol;
      EXPECT_LE(e, bound) << r << "," << c;
      worst_ratio = std::max(worst_ratio, e / bound);
    }
  EXPECT_GT(filled, 500);
  std::printf("nearest: %ld cells filled, largest error / bound %.3f\n", filled, worst_ratio);
}

// How far from the data each mode may put a known cell (horizontal metres from a cell centre to
// some point): None, the cell itself; Nearest, max_gap_m to a binned centre, then half a diagonal;
// Linear, the longest edge (max_gap_m + diagonal) to a vertex, a centroid within a diagonal of a point.
double reachOf(GapFill fill, double max_gap, double cell) {
  switch (fill) {
    case GapFill::None: return cell / kSqrt2;
    case GapFill::Nearest: return max_gap + cell / kSqrt2;
    case GapFill::Linear: return max_gap + 2 * kSqrt2 * cell;
  }
  return 0;
}

// A band of rows with no return (as behind a ridge) leaves a hole on the ground far wider than
// max_gap_m: no mode fills its middle, although Linear would with a max_gap_m as wide as the hole;
// a one-row gap is bridged by both fills.
TEST(CartesianMapper, HoleWiderThanMaxGapIsNotFilled) {
  const double max_gap = 0.3;
  const int first = 20, last = 44;  // 24 scanlines ≈ 1.9 m of ground
  const RangeImage im = planeImage(kPlane, first, last);
  std::vector<Eigen::Vector2d> pts;  // every return, on the map or off it
  for (int r = 0; r < im.rows(); ++r)
    for (int c = 0; c < im.cols(); ++c)
      if (im.valid(r, c)) pts.push_back(im.pointWorld(r, c).head<2>());
  std::vector<Eigen::Vector2i> middle;  // hole cells out of Linear's reach, away from the hole's ends
  for (const GapFill fill : {GapFill::None, GapFill::Nearest, GapFill::Linear}) {
    const ElevationMap map = mapWith(im, fill, max_gap);
    const double reach = reachOf(fill, max_gap, kGrid.cell);
    long hole = 0;
    for (int r = 0; r < kGrid.rows; ++r)
      for (int c = 0; c < kGrid.cols; ++c) {
        const Look l = lookAt(im, kPlane, kGrid.center(r, c));
        const bool in_band = l.phi < im.phi[first] && l.phi > im.phi[last - 1];
        if (!in_band || std::abs(l.theta) >= im.theta.back()) continue;
        double d2 = INFINITY;
        for (const auto& p : pts) d2 = std::min(d2, (p - kGrid.center(r, c)).squaredNorm());
        if (std::sqrt(d2) <= reach) continue;
        ++hole;
        EXPECT_EQ(map.stateAt(r, c), CellState::Unseen) << "mode " << int(fill) << " cell " << r << "," << c;
        if (fill == GapFill::Linear && std::abs(l.theta) < 0.8 * im.theta.back()) middle.emplace_back(r, c);
      }
    EXPECT_GT(hole, 300) << "mode " << int(fill);  // the hole is there, wider than the reach
    std::printf("hole: %ld cells beyond the reach of mode %d, all unseen\n", hole, int(fill));
  }
  const ElevationMap wide = mapWith(im, GapFill::Linear, 2.5);  // the rule, not the method, kept it open
  for (const auto& rc : middle) EXPECT_EQ(wide.stateAt(rc(0), rc(1)), CellState::Known);
  EXPECT_GT(middle.size(), 200u);
  // One missing scanline (≈ 0.1 m): both fills close it wherever the ground around is seen.
  const RangeImage thin = planeImage(kPlane, 30, 31);
  for (const GapFill fill : {GapFill::Nearest, GapFill::Linear}) {
    const ElevationMap map = mapWith(thin, fill, max_gap);
    long bridged = 0;
    for (int r = 0; r < kGrid.rows; ++r)
      for (int c = 0; c < kGrid.cols; ++c) {
        const Look l = lookAt(thin, kPlane, kGrid.center(r, c));
        if (l.phi < thin.phi[29] && l.phi > thin.phi[31] && std::abs(l.theta) < 0.9 * thin.theta.back()) {
          ++bridged;
          EXPECT_EQ(map.stateAt(r, c), CellState::Known) << "mode " << int(fill) << " cell " << r << "," << c;
        }
      }
    EXPECT_GT(bridged, 50);
  }
}

// Cells whose whole reach lies outside the image's angles stay unseen; with no filling the known
// cells are exactly the cells that hold a point.
TEST(CartesianMapper, OutsideTheFieldOfViewStaysUnseen) {
  const RangeImage im = planeImage(kPlane);
  const CartesianBins bins = binPoints(im, kGrid);
  for (const GapFill fill : {GapFill::None, GapFill::Nearest, GapFill::Linear}) {
    const ElevationMap map = mapWith(im, fill);
    const double reach = reachOf(fill, 0.5, kGrid.cell);
    long outside = 0;
    for (int r = 0; r < kGrid.rows; ++r)
      for (int c = 0; c < kGrid.cols; ++c) {
        if (fill == GapFill::None) {
          EXPECT_EQ(map.stateAt(r, c) == CellState::Known, bins.count(r, c) > 0) << r << "," << c;
        }
        if (!outsideFieldOfView(im, kPlane, kGrid.center(r, c), reach)) continue;
        ++outside;
        EXPECT_EQ(map.stateAt(r, c), CellState::Unseen) << "mode " << int(fill) << " cell " << r << "," << c;
      }
    EXPECT_GT(outside, 1000) << "mode " << int(fill);
  }
}

// Same input, same bits, on one thread or many.
TEST(CartesianMapper, DeterministicWhateverTheThreadCount) {
  RangeImage im = planeImage(kPlane, 40, 43);
  for (int r = 0; r < im.rows(); ++r)  // a rough surface: a deterministic ripple on the ranges
    for (int c = 0; c < im.cols(); ++c) im.range(r, c) *= float(1 + 2e-3 * std::sin(0.7 * r + 1.3 * c));
  const auto same = [](const ElevationMap& x, const ElevationMap& y) {
    const auto bytes = [](const auto& m) { return std::size_t(m.size()) * sizeof(*m.data()); };
    return std::memcmp(x.elevation().data(), y.elevation().data(), bytes(x.elevation())) == 0 &&
           std::memcmp(x.sigma().data(), y.sigma().data(), bytes(x.sigma())) == 0 &&
           std::memcmp(x.state().data(), y.state().data(), bytes(x.state())) == 0;
  };
  for (const GapFill fill : {GapFill::None, GapFill::Nearest, GapFill::Linear}) {
    ElevationMap one;
    {
      tbb::global_control only(tbb::global_control::max_allowed_parallelism, 1);
      one = mapWith(im, fill);
    }
    const ElevationMap many = mapWith(im, fill), again = mapWith(im, fill);
    EXPECT_TRUE(same(one, many)) << "mode " << int(fill);
    EXPECT_TRUE(same(many, again)) << "mode " << int(fill);
  }
}

TEST(CartesianMapper, RejectsBadConfigAndGrid) {
  const RangeImage im = planeImage(kPlane);
  EXPECT_THROW(cartesianMap(im, kGrid, {GapFill::Linear, -0.1}), std::invalid_argument);
  EXPECT_THROW(cartesianMap(im, kGrid, {GapFill::Linear, NAN}), std::invalid_argument);
  EXPECT_THROW(cartesianMap(im, MapGrid{}, {}), std::invalid_argument);
}

// Points per cell on flat ground fall as h/ρ³: a pixel covers ρ²·cosθ·Δφ·Δθ / cos α of ground and
// cos α = h/ρ. The counts in 1 m² blocks near and far match the integral of that density within
// the lattice-point discrepancy of the block's image in (φ, θ) (|N − A| ≤ P/2 + 1, Nosarzewska).
TEST(CartesianMapper, PointDensityFallsAsHeightOverRangeCubed) {
  const Plane flat{0, 0, 0};
  const RangeImage im = planeImage(flat);
  const CartesianBins bins = binPoints(im, kGrid);
  const double dphi = 30 * kDeg / 64, dtheta = 80 * kDeg / 256, h = 3.0;
  std::printf("   y_m  range_m  predicted_pts_per_cell  measured  empty_cells\n");
  for (const double y0 : {-2.0, 0.0, 2.0, 4.0}) {
    const Eigen::Vector2d lo(-0.5, y0), hi(0.5, y0 + 1.0);
    double expected = 0;  // ∫ density over the block (midpoint rule, 1 cm² pieces)
    const int k = 100;
    for (int i = 0; i < k; ++i)
      for (int j = 0; j < k; ++j) {
        const Eigen::Vector2d xy = lo + (hi - lo).cwiseProduct(Eigen::Vector2d(i + 0.5, j + 0.5) / k);
        const Eigen::Vector3d s = im.T_WS.inverse() * Eigen::Vector3d(xy.x(), xy.y(), 0);
        const double rho = s.norm(), cos_theta = std::hypot(s.y(), s.z()) / rho;
        expected += (h / rho) / (rho * rho * cos_theta * dphi * dtheta) * 1e-4;
      }
    double perimeter = 0;  // of the block's image in lattice units
    const std::vector<Eigen::Vector2d> corners = {lo, {hi.x(), lo.y()}, hi, {lo.x(), hi.y()}, lo};
    for (std::size_t s = 0; s + 1 < corners.size(); ++s)
      for (int i = 0; i < k; ++i) {
        const Look a = lookAt(im, flat, corners[s] + (corners[s + 1] - corners[s]) * i / double(k));
        const Look b = lookAt(im, flat, corners[s] + (corners[s + 1] - corners[s]) * (i + 1) / double(k));
        perimeter += std::hypot((a.phi - b.phi) / dphi, (a.theta - b.theta) / dtheta);
      }
    long n = 0, empty = 0;
    for (int r = 0; r < kGrid.rows; ++r)
      for (int c = 0; c < kGrid.cols; ++c) {
        const Eigen::Vector2d m = kGrid.center(r, c);
        if (m.x() > lo.x() && m.x() < hi.x() && m.y() > lo.y() && m.y() < hi.y()) {
          n += bins.count(r, c);
          empty += bins.count(r, c) == 0;
        }
      }
    EXPECT_NEAR(double(n), expected, perimeter / 2 + 1) << "block at y = " << y0;
    const double rho = (im.T_WS.translation() - Eigen::Vector3d(0, y0 + 0.5, 0)).norm();
    std::printf("%6.1f  %7.2f  %22.2f  %8.2f  %10ld\n", y0 + 0.5, rho, expected / 100, n / 100.0, empty);
  }
}

}  // namespace
}  // namespace ambler::perception
