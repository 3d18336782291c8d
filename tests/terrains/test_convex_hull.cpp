#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include "terrains/convex_hull.hpp"
#include "base/random.hpp"

namespace ambler::terrains {
namespace {

// Signed volume by the divergence theorem: positive only if the faces turn outward.
double volume(const HullMesh& m) {
  double v = 0.0;
  for (const auto& f : m.faces)
    v += m.vertices[f[0]].dot(m.vertices[f[1]].cross(m.vertices[f[2]])) / 6.0;
  return v;
}

double smallestFaceArea(const HullMesh& m) {
  double a = INFINITY;
  for (const auto& f : m.faces)
    a = std::min(a, 0.5 * (m.vertices[f[1]] - m.vertices[f[0]])
                              .cross(m.vertices[f[2]] - m.vertices[f[0]])
                              .norm());
  return a;
}

// Every point on or behind every face plane of the hull.
void expectContains(const HullMesh& m, const std::vector<Eigen::Vector3d>& points, double tol) {
  for (const auto& f : m.faces) {
    const Eigen::Vector3d n = (m.vertices[f[1]] - m.vertices[f[0]])
                                  .cross(m.vertices[f[2]] - m.vertices[f[0]])
                                  .normalized();
    for (const auto& p : points) ASSERT_LE(n.dot(p - m.vertices[f[0]]), tol);
  }
}

TEST(ConvexHull, CubeWithInteriorAndFacePoints) {
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < 8; ++i) points.emplace_back(i & 1, (i >> 1) & 1, (i >> 2) & 1);
  base::Rng rng(5);
  for (int i = 0; i < 50; ++i) points.emplace_back(rng.uniform(), rng.uniform(), rng.uniform());
  for (int i = 0; i < 20; ++i) points.emplace_back(rng.uniform(), rng.uniform(), 1.0);
  const HullMesh hull = convexHull(points);
  EXPECT_EQ(hull.vertices.size(), 8u);
  EXPECT_EQ(hull.faces.size(), 12u);  // two triangles per square
  EXPECT_NEAR(volume(hull), 1.0, 1e-12);
  EXPECT_TRUE(isClosed(hull.faces));
  EXPECT_TRUE(isConvex(hull.vertices, hull.faces, 1e-12));
  EXPECT_NEAR(smallestFaceArea(hull), 0.5, 1e-12);
  expectContains(hull, points, 1e-12);
}

TEST(ConvexHull, PointsOnASphereAreAllVertices) {
  base::Rng rng(6);
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < 300; ++i)
    points.push_back(Eigen::Vector3d(rng.normal(), rng.normal(), rng.normal()).normalized());
  const HullMesh hull = convexHull(points);
  // Points in general position on a sphere: every one is a vertex, and a closed triangulated
  // sphere has F = 2V − 4 faces (Euler).
  EXPECT_EQ(hull.vertices.size(), points.size());
  EXPECT_EQ(hull.faces.size(), 2 * points.size() - 4);
  EXPECT_TRUE(isClosed(hull.faces));
  EXPECT_TRUE(isConvex(hull.vertices, hull.faces, 1e-12));
  EXPECT_GT(smallestFaceArea(hull), 0.0);
  // The inscribed polytope's volume is a little below the sphere's.
  EXPECT_GT(volume(hull), 0.95 * 4.0 / 3.0 * std::numbers::pi);
  EXPECT_LT(volume(hull), 4.0 / 3.0 * std::numbers::pi);
}

TEST(ConvexHull, ContainsRandomClouds) {
  base::Rng rng(7);
  for (int trial = 0; trial < 200; ++trial) {
    std::vector<Eigen::Vector3d> points;
    const int n = 4 + int(rng.below(80));
    for (int i = 0; i < n; ++i)
      points.emplace_back(rng.uniform(-1, 1), 0.3 * rng.uniform(-1, 1), 2.0 * rng.normal());
    const HullMesh hull = convexHull(points);
    ASSERT_TRUE(isClosed(hull.faces));
    ASSERT_TRUE(isConvex(hull.vertices, hull.faces, 1e-12));
    ASSERT_GT(volume(hull), 0.0);
    expectContains(hull, points, 1e-9);
  }
}

TEST(ConvexHull, RejectsDegenerateInput) {
  EXPECT_THROW(convexHull({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}), std::invalid_argument);
  EXPECT_THROW(convexHull({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}, {0.5, 0.2, 0}}),
               std::invalid_argument);
  EXPECT_THROW(convexHull({{0, 0, 0}, {1, 1, 1}, {2, 2, 2}, {3, 3, 3}}), std::invalid_argument);
  EXPECT_THROW(convexHull({{1, 1, 1}, {1, 1, 1}, {1, 1, 1}, {1, 1, 1}}), std::invalid_argument);
}

TEST(ConvexHullArea, MatchesClosedForms) {
  base::Rng rng(8);
  std::vector<Eigen::Vector2d> square{{0, 0}, {2, 0}, {2, 3}, {0, 3}, {0, 1.5}};
  for (int i = 0; i < 100; ++i) square.emplace_back(rng.uniform(0, 2), rng.uniform(0, 3));
  EXPECT_NEAR(convexHullArea(square), 6.0, 1e-12);

  const int n = 17;  // a regular polygon of circumradius 1: (n/2)·sin(2π/n)
  std::vector<Eigen::Vector2d> polygon;
  for (int i = 0; i < n; ++i) {
    const double t = 2.0 * std::numbers::pi * i / n;
    polygon.emplace_back(std::cos(t), std::sin(t));
    polygon.emplace_back(0.5 * std::cos(t), 0.5 * std::sin(t));
  }
  EXPECT_NEAR(convexHullArea(polygon), 0.5 * n * std::sin(2.0 * std::numbers::pi / n), 1e-12);

  EXPECT_EQ(convexHullArea({{0, 0}, {1, 1}, {2, 2}}), 0.0);
  EXPECT_EQ(convexHullArea({{0, 0}, {1, 1}}), 0.0);
}

TEST(MeshChecks, DetectOpenAndDentedMeshes) {
  const std::vector<Eigen::Vector3d> v{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  const std::vector<Eigen::Vector3i> tetra{{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  EXPECT_TRUE(isClosed(tetra));
  EXPECT_TRUE(isConvex(v, tetra));
  EXPECT_FALSE(isClosed({tetra[0], tetra[1], tetra[2]}));
  // All faces flipped: closed, but every vertex is in front of some face.
  std::vector<Eigen::Vector3i> inward;
  for (const auto& f : tetra) inward.emplace_back(f[0], f[2], f[1]);
  EXPECT_TRUE(isClosed(inward));
  EXPECT_FALSE(isConvex(v, inward));
  EXPECT_FALSE(isClosed({{0, 0, 1}}));
}

}  // namespace
}  // namespace ambler::terrains
