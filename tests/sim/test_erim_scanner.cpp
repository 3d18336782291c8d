// The ERIM emulator against closed forms: ranges on tilted planes, the noise model, quantisation,
// the ambiguity interval, the maximum range, dropouts, mixed pixels and determinism.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <numbers>
#include <string>

#include "fixtures.hpp"
#include "perception/range_image.hpp"
#include "perception/sensor_geometry.hpp"
#include "sim/erim_kernel.hpp"
#include "sim/erim_scanner.hpp"
#include "base/random.hpp"
#include "terrains/terrain.hpp"

namespace ambler::sim {
namespace {

using test::planeTerrain;
using test::TerrainWorld;

constexpr double kDeg = std::numbers::pi / 180.0;

perception::SensorModel idealSensor() {
  perception::SensorModel c;
  c.noise_k = 0;
  c.quantization_m = 0;
  c.ambiguity_m = 0;
  c.mixed_pixels = false;
  return c;
}

// The closed-form range from the sensor to the plane z = z0 + a·x + b·y along pixel (r, c), or
// NaN if it meets the plane behind the sensor or outside the square |x|, |y| < half − margin.
double planeRange(const perception::RangeImage& img, int r, int c, double a, double b, double z0,
                  double half = 10.0, double margin = 0.2) {
  const Eigen::Vector3d o = img.T_WS.translation();
  const Eigen::Vector3d d = img.T_WS.linear() * perception::beamDirection(img.phi[r], img.theta[c]);
  const double t = (z0 + a * o.x() + b * o.y() - o.z()) / (d.z() - a * d.x() - b * d.y());
  const Eigen::Vector3d p = o + t * d;
  if (!(t > 0) || std::abs(p.x()) > half - margin || std::abs(p.y()) > half - margin) return NAN;
  return t;
}

struct Tilt {
  double about_x_deg, about_y_deg;
};

class TiltedPlane : public ::testing::TestWithParam<Tilt> {};

// With every effect off, the emulator returns eq. 1's geometry exactly: the range to a tilted plane
// matches the closed form to 1e-4 m (float32 ray casting at ≤ 20 m: ~1e-6 m).
TEST_P(TiltedPlane, RangesMatchClosedForm) {
  const Tilt tilt = GetParam();
  const double a = -std::tan(tilt.about_y_deg * kDeg), b = std::tan(tilt.about_x_deg * kDeg);
  const TerrainWorld w(planeTerrain(a, b, 0.0));
  const ErimScanner scanner(*w.scene, idealSensor());
  for (const Eigen::Vector3d& rpy_deg : {Eigen::Vector3d(0, -30, 0), Eigen::Vector3d(5, -40, 20)}) {
    const auto T = perception::sensorPose({0.5, -6, 3 + 6 * std::abs(b) + 6 * std::abs(a)}, rpy_deg * kDeg);
    const Scan scan = scanner.scan(T, 1);
    int compared = 0;
    for (int r = 0; r < scan.image.rows(); ++r)
      for (int c = 0; c < scan.image.cols(); ++c) {
        const double t = planeRange(scan.image, r, c, a, b, 0.0);
        if (std::isnan(t) || t > 40.0) continue;
        ASSERT_TRUE(scan.image.valid(r, c)) << "pixel " << r << "," << c << " closed form " << t;
        EXPECT_NEAR(scan.image.range(r, c), t, 1e-4) << "pixel " << r << "," << c;
        EXPECT_NEAR(scan.true_range(r, c), t, 1e-4);
        ++compared;
      }
    EXPECT_GT(compared, 5000);
  }
}

INSTANTIATE_TEST_SUITE_P(Tilts, TiltedPlane,
                         ::testing::Values(Tilt{0, 0}, Tilt{20, 0}, Tilt{40, 0}, Tilt{0, 25}, Tilt{0, -40},
                                           Tilt{15, 30}));

// σ of the range noise is k·ρ²: the sample σ of many draws is within 4.5 standard errors of it
// (the standard error of a sample σ from n normal draws is σ/√(2n): 0.16 % for n = 200 000, so
// 0.71 %). Nothing else moves the error here: no quantisation or wrap, and m = ρ + kρ²·z stays
// far above the clamp at 0.
TEST(MeasureRange, NoiseSigmaIsKRhoSquared) {
  perception::SensorModel c = idealSensor();
  c.noise_k = 0.0003;
  for (double rho : {2.0, 7.5, 15.0, 30.0}) {
    const int n = 200000;
    double sum = 0, sum2 = 0;
    for (int i = 0; i < n; ++i) {
      const double e = measureRange(rho, base::normalFromKey(base::streamKey(9, i)), c) - rho;
      sum += e, sum2 += e * e;
    }
    const double mean = sum / n, sigma = std::sqrt(sum2 / n - mean * mean);
    const double expected = c.noise_k * rho * rho;
    EXPECT_NEAR(sigma / expected, 1.0, 4.5 / std::sqrt(2.0 * n)) << "rho " << rho;
    EXPECT_NEAR(mean, 0.0, 5 * expected / std::sqrt(n)) << "rho " << rho;
  }
}

// The same through the scanner: normalised errors (ρ − t)/(kt²) over a whole scan have unit σ,
// within 4.5 standard errors of a sample σ (1/√(2n)) and a mean within 5/√n. Each pixel draws
// its own key, so the n errors are independent; the float32 range (rounding ≤ 6e-8·ρ ≈ 1e-6 m)
// is < 1e-4 of σ = kρ² ≥ 0.002·(3 m)², far inside the 4.5/√(2n) ≈ 2 % allowed at n ≈ 25 000.
TEST(ErimScanner, NoisyScanHasSigmaKRhoSquared) {
  const TerrainWorld w(planeTerrain(0, 0, 0));
  perception::SensorModel c = idealSensor();
  c.noise_k = 0.002;  // large enough that float32 casting error (1e-6 m) is negligible
  c.rows = 128;
  const Scan scan = ErimScanner(*w.scene, c).scan(perception::sensorPose({0, -6, 3}, {0, -30 * kDeg, 0}), 5);
  double sum = 0, sum2 = 0;
  int n = 0;
  for (int r = 0; r < scan.image.rows(); ++r)
    for (int col = 0; col < scan.image.cols(); ++col) {
      const double t = scan.true_range(r, col);
      if (!scan.image.valid(r, col) || !std::isfinite(t)) continue;
      const double z = (scan.image.range(r, col) - t) / (c.noise_k * t * t);
      sum += z, sum2 += z * z, ++n;
    }
  ASSERT_GT(n, 20000);
  const double mean = sum / n, sigma = std::sqrt(sum2 / n - mean * mean);
  EXPECT_NEAR(sigma, 1.0, 4.5 / std::sqrt(2.0 * n));
  EXPECT_NEAR(mean, 0.0, 5.0 / std::sqrt(n));
}

// 8-bit quantisation: every range is a whole number of counts, within half a count of the truth.
TEST(ErimScanner, QuantisedRangesAreWholeCounts) {
  const TerrainWorld w(planeTerrain(0.1, 0.05, 0));
  perception::SensorModel c = idealSensor();
  c.quantization_m = 0.0762;
  const Scan scan = ErimScanner(*w.scene, c).scan(perception::sensorPose({0, -6, 3}, {0, -30 * kDeg, 0}), 1);
  int n = 0;
  for (int r = 0; r < scan.image.rows(); ++r)
    for (int col = 0; col < scan.image.cols(); ++col) {
      if (!scan.image.valid(r, col)) continue;
      const double counts = scan.image.range(r, col) / c.quantization_m;
      EXPECT_NEAR(counts, std::nearbyint(counts), 1e-4);
      EXPECT_LE(std::abs(scan.image.range(r, col) - scan.true_range(r, col)), c.quantization_m / 2 + 1e-5);
      ++n;
    }
  EXPECT_GT(n, 10000);
}

// Ranges wrap modulo the ambiguity interval: beyond 19.5 m the sensor reports ρ − 19.5.
TEST(ErimScanner, RangesWrapAtTheAmbiguityInterval) {
  const TerrainWorld w(planeTerrain(0, 0, 0, 30.0, 0.25));
  for (double q : {0.0, 0.0762}) {
    perception::SensorModel c = idealSensor();
    c.ambiguity_m = 19.5;
    c.quantization_m = q;
    c.max_range_m = 60;
    const Scan scan = ErimScanner(*w.scene, c).scan(perception::sensorPose({0, -20, 8}, {0, -20 * kDeg, 0}), 1);
    int wrapped = 0, direct = 0;
    for (int r = 0; r < scan.image.rows(); ++r)
      for (int col = 0; col < scan.image.cols(); ++col) {
        const double t = scan.true_range(r, col);
        if (!std::isfinite(t)) continue;
        ASSERT_TRUE(scan.image.valid(r, col));
        const double expected = std::fmod(t, c.ambiguity_m);
        double e = scan.image.range(r, col) - expected;
        e -= c.ambiguity_m * std::nearbyint(e / c.ambiguity_m);  // the top count reads as 0
        EXPECT_LE(std::abs(e), q / 2 + 1e-4) << "t " << t << " reported " << scan.image.range(r, col);
        EXPECT_LT(scan.image.range(r, col), c.ambiguity_m);
        (t >= c.ambiguity_m ? wrapped : direct)++;
      }
    EXPECT_GT(wrapped, 1000);
    EXPECT_GT(direct, 1000);
  }
}

// Nothing returns from beyond the maximum range; everything closer does.
TEST(ErimScanner, MaximumRangeCutsReturns) {
  const TerrainWorld w(planeTerrain(0, 0, 0, 30.0, 0.25));
  perception::SensorModel c = idealSensor();
  c.max_range_m = 15;
  const Scan scan = ErimScanner(*w.scene, c).scan(perception::sensorPose({0, -20, 5}, {0, -15 * kDeg, 0}), 1);
  int beyond = 0;
  for (int r = 0; r < scan.image.rows(); ++r)
    for (int col = 0; col < scan.image.cols(); ++col) {
      const double t = scan.true_range(r, col);
      if (!std::isfinite(t)) continue;
      EXPECT_EQ(scan.image.valid(r, col), t <= c.max_range_m) << "t " << t;
      beyond += t > c.max_range_m;
    }
  EXPECT_GT(beyond, 1000);
}

// Dropouts remove a fraction p of the returns (binomial: within 5 standard errors).
TEST(ErimScanner, DropoutFraction) {
  const TerrainWorld w(planeTerrain(0, 0, 0));
  perception::SensorModel c = idealSensor();
  c.dropout = 0.3;
  const Scan scan = ErimScanner(*w.scene, c).scan(perception::sensorPose({0, -6, 3}, {0, -30 * kDeg, 0}), 3);
  int hits = 0, missing = 0;
  for (int r = 0; r < scan.image.rows(); ++r)
    for (int col = 0; col < scan.image.cols(); ++col)
      if (std::isfinite(scan.true_range(r, col))) ++hits, missing += !scan.image.valid(r, col);
  const double p = double(missing) / hits;
  EXPECT_NEAR(p, c.dropout, 5 * std::sqrt(c.dropout * (1 - c.dropout) / hits));
}

// The ideal sensor with mixed pixels and a wide footprint (1°, several pixels straddle an edge):
// rows × cols over 10° × fov_h_deg.
perception::SensorModel wideFootprint(int rows, int cols, double fov_h_deg) {
  perception::SensorModel c = idealSensor();
  c.mixed_pixels = true;
  c.rows = rows;
  c.cols = cols;
  c.fov_v_rad = 10 * kDeg;
  c.fov_h_rad = fov_h_deg * kDeg;
  c.beam_divergence_rad = 1.0 * kDeg;
  return c;
}

// A mixed pixel lies between the two surfaces: a wall face at y = 5 m covering x < 0 in front
// of a backdrop at y = 10 m. A footprint straddling the wall's edge returns a range between the
// wall's and the backdrop's (the power-weighted mean of its sub-rays), never outside them; away
// from the edge, pixels return their own surface.
TEST(ErimScanner, MixedPixelLiesBetweenTheTwoSurfaces) {
  const test::MjcfWorld w(R"(
<mujoco>
  <worldbody>
    <geom type="box" size="2 0.05 3" pos="-2 5.05 0"/>
    <geom type="box" size="20 0.05 20" pos="0 10.05 0"/>
  </worldbody>
</mujoco>)");
  const perception::SensorModel c = wideFootprint(8, 64, 20);
  const Scan scan = ErimScanner(*w.scene, c).scan(Eigen::Isometry3d::Identity(), 1);
  int mixed = 0;
  for (int r = 0; r < c.rows; ++r)
    for (int col = 0; col < c.cols; ++col) {
      ASSERT_TRUE(scan.image.valid(r, col));
      const double rho = scan.image.range(r, col);
      // Along a direction d the planes y = 5 and y = 10 are at 5/d_y and 10/d_y; over the
      // footprint (half-angle 0.5°) d_y changes by well under 1 %.
      const double dy = perception::beamDirection(scan.image.phi[r], scan.image.theta[col]).y();
      const double near = 5.0 / dy, far = 10.0 / dy;
      EXPECT_GE(rho, 0.99 * near) << r << "," << col;
      EXPECT_LE(rho, 1.01 * far) << r << "," << col;
      const double x_wall = 5.0 * std::tan(scan.image.theta[col]);  // where the beam meets y = 5
      if (std::abs(x_wall) > 0.2) {  // the footprint (±0.044 m at 5 m) is clear of the edge
        EXPECT_NEAR(rho, x_wall < 0 ? near : far, 0.01 * far) << r << "," << col;
      }
      mixed += rho > near + 0.5 && rho < far - 0.5;
    }
  EXPECT_GE(mixed, c.rows);  // at least one mixed pixel per scanline
}

// Where a mixed pixel puts the edge (the locus mapper's reading, docs/locus.md "Range shadows"):
// the near fraction of its footprint, from its range between the two surfaces' by the
// power-weighted mean's inverse (SensorModel::nearFraction), is the disk's area fraction
// F(s) = 1/2 + (s·√(1 − s²) + asin s)/π for the edge's true offset s to within the 7-point
// cubature's error, 1/4 (SensorModel::kCubatureFractionError). A wall at y = 5 m covers the half
// of its plane on the near side of an edge through (0, 5, 0), turned by β from vertical to
// horizontal, in front of a backdrop at y = 10 m. Sub-rays are offset in (φ, θ) by the footprint's
// radius a times the cubature's points, so the edge's offset is s = −asin(d·u)/a with u the unit
// normal of the plane through the sensor and the edge, towards the far side (exact for β = 0°
// and 90°, within 2 % of a for the oblique edges at these ≤ 7° angles); the two surfaces' ranges
// vary over the footprint by under 0.2 %, which moves A by under 0.01.
TEST(ErimScanner, MixedPixelsPlaceTheEdgeWithinTheCubaturesError) {
  const perception::SensorModel c = wideFootprint(64, 64, 10);
  const double a = 0.5 * c.beam_divergence_rad;
  double worst = 0;
  for (const double beta : {0.0, 20.0, 45.0, 70.0, 90.0}) {
    const Eigen::Vector3d u(std::cos(beta * kDeg), 0, std::sin(beta * kDeg));  // in the wall, to the far side
    const Eigen::Vector3d centre = Eigen::Vector3d(0, 5.05, 0) - 10 * u;
    const test::MjcfWorld w("<mujoco><worldbody><geom type=\"box\" size=\"10 0.05 10\" pos=\"" +
                            std::to_string(centre.x()) + " " + std::to_string(centre.y()) + " " +
                            std::to_string(centre.z()) + "\" euler=\"0 " + std::to_string(-beta) +
                            " 0\"/><geom type=\"box\" size=\"30 0.05 30\" pos=\"0 10.05 0\"/></worldbody></mujoco>");
    const Scan scan = ErimScanner(*w.scene, c).scan(Eigen::Isometry3d::Identity(), 1);
    // The plane through the sensor (the origin) and the edge: its normal, towards the far side.
    const Eigen::Vector3d n = Eigen::Vector3d(0, 5, 0).cross(Eigen::Vector3d(-u.z(), 0, u.x())).normalized();
    const Eigen::Vector3d n_far = n.dot(u) > 0 ? n : Eigen::Vector3d(-n);
    int straddling = 0;
    for (int r = 0; r < c.rows; ++r)
      for (int col = 0; col < c.cols; ++col) {
        ASSERT_TRUE(scan.image.valid(r, col));
        const Eigen::Vector3d d = perception::beamDirection(scan.image.phi[r], scan.image.theta[col]);
        const double s = -std::asin(d.dot(n_far)) / a;
        const double A = perception::SensorModel::nearFraction(scan.image.range(r, col), 5.0 / d.y(), 10.0 / d.y());
        if (std::abs(s) >= 1.05) {  // the footprint clear of the edge: one surface
          EXPECT_NEAR(A, s > 0 ? 1.0 : 0.0, 0.01) << "beta " << beta << " at " << r << "," << col;
          continue;
        }
        if (std::abs(s) > 0.95) continue;  // within the oblique edges' 2 % of the rim
        ++straddling;
        const double F = 0.5 + (s * std::sqrt(1 - s * s) + std::asin(s)) / std::numbers::pi;
        EXPECT_LE(std::abs(A - F), perception::SensorModel::kCubatureFractionError + 0.01)
            << "beta " << beta << " at " << r << "," << col << ": s " << s;
        worst = std::max(worst, std::abs(A - F));
      }
    EXPECT_GT(straddling, 40) << "beta " << beta;
  }
  RecordProperty("worst_fraction_error", std::to_string(worst));
  std::printf("worst |A - F(s)| over the straddling pixels: %.3f\n", worst);
}

// Same seed: identical bits, whatever the number of threads; another seed: other noise.
TEST(ErimScanner, DeterministicAcrossThreadCounts) {
  const TerrainWorld w(planeTerrain(0.05, 0.1, 0));
  perception::SensorModel c;  // ERIM defaults: noise, quantisation, wrap, mixed pixels
  const ErimScanner scanner(*w.scene, c);
  const auto T = perception::sensorPose({0, -6, 3}, {0, -30 * kDeg, 0});
  const Scan a = scanner.scan(T, 42);
  Scan b;
  {
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    b = scanner.scan(T, 42);
  }
  const Scan other = scanner.scan(T, 43);
  const std::size_t bytes = sizeof(float) * a.image.range.size();
  EXPECT_EQ(std::memcmp(a.image.range.data(), b.image.range.data(), bytes), 0);
  EXPECT_EQ(std::memcmp(a.true_range.data(), b.true_range.data(), bytes), 0);
  EXPECT_NE(std::memcmp(a.image.range.data(), other.image.range.data(), bytes), 0);
}

// The scanner's AVX-512 kernels (refinement, noise, measurement) and the portable scalar ones give
// the same bits in every output: same seed, same world, whichever path the CPU takes. Covers
// partial edge tiles, mixed pixels, dropout, wraps, the ziggurat's slow draws (~3 % of pixels),
// rock meshes and analytic primitives.
TEST(ErimScanner, VectorAndScalarKernelsGiveIdenticalBits) {
  if (kernel::activeIsa() != kernel::Isa::Avx512) GTEST_SKIP() << "no AVX-512 on this CPU: only the scalar path runs";
  struct RestoreDispatch {
    ~RestoreDispatch() { kernel::forceScalar(false); }
  } restore;
  const TerrainWorld terrain(terrains::makeTerrain(test::fractalWithRocks(), 7));
  const test::MjcfWorld primitives(R"(
<mujoco>
  <worldbody>
    <geom type="plane" size="20 20 0.1"/>
    <geom type="box" size="0.5 0.3 0.4" pos="-1 4 0.4" euler="0 0 30"/>
    <geom type="sphere" size="0.6" pos="1.5 5 0.6"/>
    <geom type="capsule" size="0.2 0.5" pos="0 7 0.5" euler="90 0 0"/>
  </worldbody>
</mujoco>)");
  perception::SensorModel defaults;  // ERIM defaults: mixed pixels, noise, quantisation, wrap
  defaults.rows = 61;   // neither a multiple of 4: partial tiles on two edges
  defaults.cols = 203;
  perception::SensorModel single = idealSensor();
  single.rows = 64;
  single.cols = 256;
  single.noise_k = 0.01;  // large noise and a short interval: many draws matter, many wraps
  single.ambiguity_m = 5.0;
  single.quantization_m = 0.0762;
  single.dropout = 0.1;
  // Roll and yaw too, so that no entry of the rotation is zero and every product counts.
  const auto T = perception::sensorPose({0.3, -5, 2.5}, {4 * kDeg, -25 * kDeg, 7 * kDeg});
  int compared = 0;
  for (const RayScene* scene : {terrain.scene.get(), primitives.scene.get()})
    for (const perception::SensorModel& c : {defaults, single}) {
      const ErimScanner scanner(*scene, c);
      kernel::forceScalar(false);
      const Scan vec = scanner.scan(T, 11);
      kernel::forceScalar(true);
      const Scan ref = scanner.scan(T, 11);
      const std::size_t n = ref.image.range.size();
      EXPECT_EQ(std::memcmp(vec.image.range.data(), ref.image.range.data(), n * sizeof(float)), 0);
      EXPECT_EQ(std::memcmp(vec.true_range.data(), ref.true_range.data(), n * sizeof(float)), 0);
      EXPECT_EQ(std::memcmp(vec.geom.data(), ref.geom.data(), n * sizeof(int)), 0);
      for (std::size_t i = 0; i < n; ++i) compared += std::isfinite(ref.true_range.data()[i]);
    }
  EXPECT_GT(compared, 30000);
}

}  // namespace
}  // namespace ambler::sim
