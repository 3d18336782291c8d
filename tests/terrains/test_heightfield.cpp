#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <array>
#include <stdexcept>

#include "terrains/heightfield.hpp"
#include "base/random.hpp"

namespace ambler::terrains {
namespace {

Heightfield randomField(int rows, int cols, double cell, Eigen::Vector2d origin, base::Rng& rng) {
  Heightfield hf(rows, cols, cell, origin);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) hf.at(r, c) = rng.uniform(-1.0, 1.0);
  return hf;
}

// Barycentric interpolation on the triangle (a, b, c) of grid samples, solved from positions
// rather than from fractional indices, as an independent reference.
std::optional<double> onTriangle(const Heightfield& hf, const std::array<Eigen::Vector2i, 3>& t,
                                 const Eigen::Vector2d& p) {
  const Eigen::Vector2d a = hf.position(t[0].x(), t[0].y());
  const Eigen::Vector2d b = hf.position(t[1].x(), t[1].y());
  const Eigen::Vector2d c = hf.position(t[2].x(), t[2].y());
  Eigen::Matrix2d m;
  m << b - a, c - a;
  const Eigen::Vector2d w = m.lu().solve(p - a);
  const double l0 = 1.0 - w.x() - w.y();
  if (l0 < -1e-12 || w.x() < -1e-12 || w.y() < -1e-12) return std::nullopt;
  return l0 * hf.at(t[0].x(), t[0].y()) + w.x() * hf.at(t[1].x(), t[1].y()) +
         w.y() * hf.at(t[2].x(), t[2].y());
}

TEST(Heightfield, ReproducesAnyPlaneExactly) {
  base::Rng rng(1);
  for (int trial = 0; trial < 20; ++trial) {
    const double z0 = rng.uniform(-5, 5), gx = rng.uniform(-3, 3), gy = rng.uniform(-3, 3);
    Heightfield hf(7, 9, 0.3, {-1.2, 0.7});
    for (int r = 0; r < hf.rows(); ++r)
      for (int c = 0; c < hf.cols(); ++c) {
        const Eigen::Vector2d p = hf.position(r, c);
        hf.at(r, c) = z0 + gx * p.x() + gy * p.y();
      }
    for (int i = 0; i < 1000; ++i) {
      const double x = rng.uniform(hf.xMin(), hf.xMax()), y = rng.uniform(hf.yMin(), hf.yMax());
      ASSERT_NEAR(*hf.height(x, y), z0 + gx * x + gy * y, 1e-12);
    }
  }
}

TEST(Heightfield, InterpolatesOnMuJoCoTriangles) {
  base::Rng rng(2);
  const Heightfield hf = randomField(6, 11, 0.17, {-0.9, -0.4}, rng);
  for (int i = 0; i < 20000; ++i) {
    const Eigen::Vector2d p(rng.uniform(hf.xMin(), hf.xMax()), rng.uniform(hf.yMin(), hf.yMax()));
    const int c = std::min(int((p.x() - hf.xMin()) / hf.cell()), hf.cols() - 2);
    const int r = std::min(int((p.y() - hf.yMin()) / hf.cell()), hf.rows() - 2);
    // MuJoCo 2.2.2 splits cell (r, c) into {(r,c),(r+1,c+1),(r,c+1)} and
    // {(r,c),(r+1,c+1),(r+1,c)}; a point on the diagonal belongs to both.
    auto expected = onTriangle(hf, {{{r, c}, {r + 1, c + 1}, {r, c + 1}}}, p);
    if (!expected) expected = onTriangle(hf, {{{r, c}, {r + 1, c + 1}, {r + 1, c}}}, p);
    ASSERT_TRUE(expected.has_value());
    ASSERT_NEAR(*hf.height(p.x(), p.y()), *expected, 1e-12);
  }
}

TEST(Heightfield, ReturnsSamplesAtGridPoints) {
  base::Rng rng(3);
  // A dyadic cell and origin make the positions exact, so the samples must come back bit for bit.
  const Heightfield exact = randomField(5, 8, 0.25, {-1.0, 0.5}, rng);
  for (int r = 0; r < exact.rows(); ++r)
    for (int c = 0; c < exact.cols(); ++c) {
      const Eigen::Vector2d p = exact.position(r, c);
      EXPECT_EQ(*exact.height(p.x(), p.y()), exact.at(r, c));
    }
  // Otherwise the position carries a rounding error of a few ulp of the coordinates.
  const Heightfield inexact = randomField(5, 8, 0.1, {-0.37, 0.21}, rng);
  for (int r = 0; r < inexact.rows(); ++r)
    for (int c = 0; c < inexact.cols(); ++c) {
      const Eigen::Vector2d p = inexact.position(r, c);
      EXPECT_NEAR(*inexact.height(p.x(), p.y()), inexact.at(r, c), 1e-14);
    }
}

TEST(Heightfield, ReturnsNulloptOutside) {
  base::Rng rng(4);
  const Heightfield hf = randomField(4, 5, 0.5, {-1.0, -0.75}, rng);
  const double e = 1e-9;
  EXPECT_FALSE(hf.height(hf.xMin() - e, 0.0));
  EXPECT_FALSE(hf.height(hf.xMax() + e, 0.0));
  EXPECT_FALSE(hf.height(0.0, hf.yMin() - e));
  EXPECT_FALSE(hf.height(0.0, hf.yMax() + e));
  EXPECT_FALSE(hf.height(hf.xMax() + e, hf.yMax() + e));
  EXPECT_FALSE(hf.height(100.0, -100.0));
  // The boundary itself is inside.
  EXPECT_DOUBLE_EQ(*hf.height(hf.xMax(), hf.yMax()), hf.at(hf.rows() - 1, hf.cols() - 1));
  EXPECT_DOUBLE_EQ(*hf.height(hf.xMin(), hf.yMin()), hf.at(0, 0));
}

TEST(Heightfield, RejectsBadGrids) {
  EXPECT_THROW(Heightfield(1, 5, 0.1, {0, 0}), std::invalid_argument);
  EXPECT_THROW(Heightfield(5, 1, 0.1, {0, 0}), std::invalid_argument);
  EXPECT_THROW(Heightfield(5, 5, 0.0, {0, 0}), std::invalid_argument);
}

}  // namespace
}  // namespace ambler::terrains
