// The sweep-hull Delaunay triangulation: empty circumcircles, an exact tiling of the hull, and
// degenerate input (lattices, collinear points, duplicates) without failure.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "perception/delaunay.hpp"

namespace ambler::perception {
namespace {

// Twice the signed area of a, b, c.
double cross(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c) {
  return (b.x() - a.x()) * (c.y() - a.y()) - (b.y() - a.y()) * (c.x() - a.x());
}

// Area of the convex hull (Andrew's monotone chain).
double hullArea(std::vector<Eigen::Vector2d> p) {
  std::sort(p.begin(), p.end(),
            [](const auto& a, const auto& b) { return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y()); });
  std::vector<Eigen::Vector2d> h(2 * p.size());
  std::size_t k = 0;
  for (std::size_t i = 0; i < p.size(); h[k++] = p[i++])
    while (k >= 2 && cross(h[k - 2], h[k - 1], p[i]) <= 0) --k;
  for (std::size_t i = p.size() - 1, t = k + 1; i > 0; h[k++] = p[--i])
    while (k >= t && cross(h[k - 2], h[k - 1], p[i - 1]) <= 0) --k;
  double a = 0;
  for (std::size_t i = 0; i + 1 < k; ++i) a += h[i].x() * h[i + 1].y() - h[i + 1].x() * h[i].y();
  return std::abs(a) / 2;
}

// A triangulation of the points tiles their hull exactly once (areas add up, all turn the same
// way) and is Delaunay (no point strictly inside a circumcircle).
void expectDelaunay(const std::vector<Eigen::Vector2d>& p, std::size_t expected_triangles) {
  const auto tris = delaunayTriangles(p);
  EXPECT_EQ(tris.size(), expected_triangles);
  double area = 0;
  for (const auto& t : tris) {
    const double s = cross(p[t[0]], p[t[1]], p[t[2]]);
    EXPECT_LT(s, 0);  // clockwise, all of them
    area -= s / 2;
    const double dx = p[t[1]].x() - p[t[0]].x(), dy = p[t[1]].y() - p[t[0]].y();
    const double ex = p[t[2]].x() - p[t[0]].x(), ey = p[t[2]].y() - p[t[0]].y();
    const double dl = dx * dx + dy * dy, el = ex * ex + ey * ey, k = 0.5 / (dx * ey - dy * ex);
    const Eigen::Vector2d o(p[t[0]].x() + (ey * dl - dy * el) * k, p[t[0]].y() + (dx * el - ex * dl) * k);
    const double r2 = (p[t[0]] - o).squaredNorm();
    for (const auto& q : p) EXPECT_GE((q - o).squaredNorm(), r2 * (1 - 1e-9));
  }
  EXPECT_NEAR(area, hullArea(p), 1e-9 * hullArea(p));
}

TEST(Delaunay, ScatteredPoints) {
  std::vector<Eigen::Vector2d> p;
  for (int i = 0; i < 400; ++i) {
    const auto frac = [](double v) { return v - std::floor(v); };
    p.emplace_back(20 * frac(std::sin(i * 12.9898) * 43758.5453),
                   20 * frac(std::sin(i * 78.233) * 12543.1234));
  }
  // Euler: 2n − 2 − h triangles for n points with h on the hull.
  std::size_t on_hull = 0;
  for (const auto& q : p) {  // q is a hull vertex if removing it shrinks the hull
    std::vector<Eigen::Vector2d> rest;
    for (const auto& o : p)
      if (&o != &q) rest.push_back(o);
    on_hull += hullArea(rest) < hullArea(p) * (1 - 1e-12);
  }
  expectDelaunay(p, 2 * p.size() - 2 - on_hull);
}

// A square lattice is as degenerate as it gets (every square cocircular; rows collinear), and
// scanlines on a plane project to collinear map points: still a tiling, never a crash.
TEST(Delaunay, DegenerateInputs) {
  std::vector<Eigen::Vector2d> lattice;
  for (int i = 0; i < 10; ++i)
    for (int j = 0; j < 10; ++j) lattice.emplace_back(i, j);
  expectDelaunay(lattice, 2 * 100 - 2 - 36);
  std::vector<Eigen::Vector2d> line;
  for (int i = 0; i < 10; ++i) line.emplace_back(0.5 * i, 0.25 * i);
  EXPECT_TRUE(delaunayTriangles(line).empty());
  std::vector<Eigen::Vector2d> twice = lattice;
  twice.insert(twice.end(), lattice.begin(), lattice.end());
  expectDelaunay(twice, 2 * 100 - 2 - 36);
  EXPECT_TRUE(delaunayTriangles({{0, 0}, {1, 1}}).empty());
}

}  // namespace
}  // namespace ambler::perception
