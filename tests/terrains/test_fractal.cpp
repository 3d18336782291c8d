#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>
#include <stdexcept>
#include <vector>

#include "terrains/fractal.hpp"
#include "base/random.hpp"
#include "terrains/terrain.hpp"

namespace ambler::terrains {
namespace {

constexpr double kPi = std::numbers::pi;

TerrainSpec fractalSpec(double hurst, double relief, Eigen::Vector2d size, double cell) {
  TerrainSpec s;
  s.kind = TerrainKind::Fractal;
  s.hurst = hurst;
  s.relief_m = relief;
  s.size_m = size;
  s.cell_m = cell;
  return s;
}

// Structure function S(h) = E[(z(p + h) − z(p))²] over the grid, for lags of `lag` cells along
// x and along y, averaged: for a plane wave of uniformly random direction each is an unbiased
// estimate of the isotropic S(|h|), and their mean cancels the direction's scatter at small k·h.
double structureFunction(const HeightMatrix& z, int lag) {
  double sx = 0.0, sy = 0.0;
  for (int r = 0; r < z.rows(); ++r)
    for (int c = 0; c + lag < z.cols(); ++c) sx += std::pow(z(r, c + lag) - z(r, c), 2);
  for (int r = 0; r + lag < z.rows(); ++r)
    for (int c = 0; c < z.cols(); ++c) sy += std::pow(z(r + lag, c) - z(r, c), 2);
  return 0.5 *
         (sx / (double(z.rows()) * (z.cols() - lag)) + sy / (double(z.rows() - lag) * z.cols()));
}

// The model's structure function up to a constant: for the isotropic power spectrum
// P(k) ∝ k^−(2+2H) on [k_min, k_max], S(h) = 2∫∫P(k)(1 − cos k·h) d²k ∝ ∫ k^−(1+2H)(1 − J0(kh)) dk,
// integrated here by Simpson's rule in ln k (4000 steps per e-fold: J0 is resolved up to k·h ~
// 1e3).
double modelStructureFunction(double h, double hurst, const FractalBand& band) {
  const int n = 2 * int(2000.0 * std::log(band.k_max / band.k_min)) + 2;
  const double s0 = std::log(band.k_min), ds = (std::log(band.k_max) - s0) / n;
  double sum = 0.0;
  for (int i = 0; i <= n; ++i) {
    const double k = std::exp(s0 + i * ds);
    const double f = std::pow(k, -2.0 * hurst) * (1.0 - std::cyl_bessel_j(0.0, k * h));
    sum += f * ((i == 0 || i == n) ? 1.0 : (i % 2 ? 4.0 : 2.0));
  }
  return sum * ds / 3.0;
}

// Least-squares slope of ln S against ln h.
double logSlope(const std::vector<double>& h, const std::vector<double>& s) {
  double mx = 0, my = 0;
  for (std::size_t i = 0; i < h.size(); ++i) mx += std::log(h[i]), my += std::log(s[i]);
  mx /= h.size(), my /= h.size();
  double sxy = 0, sxx = 0;
  for (std::size_t i = 0; i < h.size(); ++i) {
    sxy += (std::log(h[i]) - mx) * (std::log(s[i]) - my);
    sxx += std::pow(std::log(h[i]) - mx, 2);
  }
  return sxy / sxx;
}

TEST(Fractal, PeakToPeakEqualsRelief) {
  for (double hurst : {0.1, 0.5, 0.95})
    for (double relief : {0.01, 0.6, 3.0}) {
      const Terrain t = makeTerrain(fractalSpec(hurst, relief, {6.0, 3.5}, 0.05), 42);
      EXPECT_NEAR(t.ground.maxHeight() - t.ground.minHeight(), relief, 1e-9);
      // Centred on zero: the hfield's normalisation does not depend on the seed's offset.
      EXPECT_NEAR(t.ground.maxHeight() + t.ground.minHeight(), 0.0, 1e-9);
    }
  EXPECT_EQ(makeTerrain(fractalSpec(0.7, 0.0, {2.0, 2.0}, 0.1), 1).ground.maxHeight(), 0.0);
}

TEST(Fractal, BandSpansTerrainToTwoCells) {
  Heightfield grid(81, 201, 0.05, {-5.0, -2.0});
  const FractalBand band = fractalBand(grid);
  EXPECT_DOUBLE_EQ(band.k_min, 2.0 * kPi / 10.0);
  EXPECT_DOUBLE_EQ(band.k_max, kPi / 0.05);
}

TEST(Fractal, DependsOnTheSeed) {
  const TerrainSpec spec = fractalSpec(0.7, 0.6, {4.0, 4.0}, 0.05);
  const Terrain a = makeTerrain(spec, 7), b = makeTerrain(spec, 7), c = makeTerrain(spec, 8);
  EXPECT_TRUE(a.ground.heights() == b.ground.heights());
  EXPECT_GT((a.ground.heights() - c.ground.heights()).cwiseAbs().maxCoeff(), 0.05);
}

TEST(Fractal, ReferenceStructureFunctionMatchesTheFullBandClosedForm) {
  // Checks the test's own reference: over (0, ∞), ∫ k^−(1+μ)(1 − J0(kh)) dk = C·h^μ with
  // C = 2^−μ Γ(1 − μ/2) / (μ Γ(1 + μ/2)), μ = 2H. With a finite band the two tails are missing;
  // 1 − J0(x) <= min(2, x²/4) bounds them, and that bound is the tolerance.
  const FractalBand wide{1e-6, 1e10};
  for (double hurst : {0.2, 0.5, 0.8})
    for (double h : {0.1, 1.0}) {
      const double mu = 2.0 * hurst;
      const double full = std::pow(2.0, -mu) * std::tgamma(1.0 - mu / 2.0) /
                          (mu * std::tgamma(1.0 + mu / 2.0)) * std::pow(h, mu);
      const double high_tail = 2.0 * std::pow(wide.k_max, -mu) / mu;
      const double low_tail = h * h * std::pow(wide.k_min, 2.0 - mu) / (4.0 * (2.0 - mu));
      EXPECT_NEAR(modelStructureFunction(h, hurst, wide), full, high_tail + low_tail + 1e-6 * full)
          << "H = " << hurst << ", h = " << h;
    }
}

// The slope of ln S(h) against ln h is 2H for an fBm. On a finite grid the band is cut at the
// terrain size and at two cells, which flattens the slope for large H and steepens it for
// small H; the reference therefore is the same band-limited spectrum's S(h), and the tolerance
// is 4 standard errors of the slope from the scatter over independent seeds.
TEST(Fractal, StructureFunctionSlopeFollowsHurst) {
  const double cell = 0.05, side = 12.8;
  const std::vector<int> lags{4, 8, 16};
  const int seeds = 16;
  double previous = 0.0;
  for (double hurst : {0.3, 0.5, 0.8}) {
    std::vector<double> h, mean_s(lags.size(), 0.0), model, slopes;
    for (int lag : lags) h.push_back(lag * cell);
    FractalBand band;
    for (int seed = 0; seed < seeds; ++seed) {
      const Terrain t = makeTerrain(fractalSpec(hurst, 1.0, {side, side}, cell), 100 + seed);
      band = fractalBand(t.ground);
      std::vector<double> s;
      for (std::size_t i = 0; i < lags.size(); ++i) {
        s.push_back(structureFunction(t.ground.heights(), lags[i]));
        mean_s[i] += s.back() / seeds;
      }
      slopes.push_back(logSlope(h, s));
    }
    for (double x : h) model.push_back(modelStructureFunction(x, hurst, band));
    double mean = 0.0, var = 0.0;
    for (double x : slopes) mean += x / seeds;
    for (double x : slopes) var += (x - mean) * (x - mean) / (seeds - 1);
    const double standard_error = std::sqrt(var / seeds);
    const double measured = logSlope(h, mean_s), expected = logSlope(h, model);
    EXPECT_NEAR(measured, expected, 4.0 * standard_error) << "H = " << hurst;
    // Over these lags the band-limited slope stays within 0.2 of 2H for 0.3 <= H <= 0.8.
    EXPECT_NEAR(expected, 2.0 * hurst, 0.2) << "H = " << hurst;
    EXPECT_GT(measured, previous + 0.2) << "rougher for smaller H";
    previous = measured;
    std::printf("H = %.1f: slope %.4f, band-limited model %.4f, 2H %.1f, standard error %.4f\n",
                hurst, measured, expected, 2.0 * hurst, standard_error);
  }
}

TEST(Fractal, RejectsBadParameters) {
  Heightfield grid(10, 10, 0.1, {0.0, 0.0});
  EXPECT_THROW(addFractal(grid, 1.0, 0.0, 1), std::invalid_argument);
  EXPECT_THROW(addFractal(grid, 1.0, 1.0, 1), std::invalid_argument);
  EXPECT_THROW(addFractal(grid, -1.0, 0.5, 1), std::invalid_argument);
  EXPECT_THROW(addFractal(grid, NAN, 0.5, 1), std::invalid_argument);
}

}  // namespace
}  // namespace ambler::terrains
