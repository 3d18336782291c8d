#include "terrains/convex_hull.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <set>
#include <stdexcept>
#include <utility>

namespace ambler::terrains {
namespace {

using Points = std::vector<Eigen::Vector3d>;

struct Face {
  Eigen::Vector3i v;
  Eigen::Vector3d normal;  // unit, outward
  double offset = 0.0;     // normal · x = offset on the plane
  bool alive = true;
};

Face makeFace(const Points& p, int a, int b, int c) {
  Face f;
  f.v = {a, b, c};
  f.normal = (p[b] - p[a]).cross(p[c] - p[a]).normalized();
  f.offset = f.normal.dot(p[a]);
  return f;
}

double signedDistance(const Face& f, const Eigen::Vector3d& x) {
  return f.normal.dot(x) - f.offset;
}

// Four affinely independent points to start from, as far apart as the data allow, so the
// first faces are well conditioned.
std::array<int, 4> initialSimplex(const Points& p, double eps) {
  std::array<int, 6> extremes{};
  for (int i = 0; i < int(p.size()); ++i)
    for (int axis = 0; axis < 3; ++axis) {
      if (p[i][axis] < p[extremes[2 * axis]][axis]) extremes[2 * axis] = i;
      if (p[i][axis] > p[extremes[2 * axis + 1]][axis]) extremes[2 * axis + 1] = i;
    }
  int i0 = 0, i1 = 0;
  double best = -1.0;
  for (int a : extremes)
    for (int b : extremes)
      if (double d = (p[a] - p[b]).squaredNorm(); d > best) best = d, i0 = a, i1 = b;

  const Eigen::Vector3d dir = (p[i1] - p[i0]).normalized();
  int i2 = -1;
  best = eps;
  for (int i = 0; i < int(p.size()); ++i)
    if (double d = (p[i] - p[i0]).cross(dir).norm(); d > best) best = d, i2 = i;
  if (i2 < 0) throw std::invalid_argument("convexHull: the points are collinear");

  const Eigen::Vector3d n = (p[i1] - p[i0]).cross(p[i2] - p[i0]).normalized();
  int i3 = -1;
  best = eps;
  for (int i = 0; i < int(p.size()); ++i)
    if (double d = std::abs(n.dot(p[i] - p[i0])); d > best) best = d, i3 = i;
  if (i3 < 0) throw std::invalid_argument("convexHull: the points are coplanar");
  return {i0, i1, i2, i3};
}

}  // namespace

HullMesh convexHull(const Points& p) {
  if (p.size() < 4) throw std::invalid_argument("convexHull: needs at least four points");
  Eigen::Vector3d lo = p[0], hi = p[0];
  for (const auto& x : p) lo = lo.cwiseMin(x), hi = hi.cwiseMax(x);
  if (!((hi - lo).norm() > 0.0)) throw std::invalid_argument("convexHull: the points coincide");
  const double eps = 1e-10 * (hi - lo).norm();

  const auto s = initialSimplex(p, eps);
  std::vector<Face> faces;
  for (int skip = 0; skip < 4; ++skip) {
    std::array<int, 3> t{};
    for (int i = 0, k = 0; i < 4; ++i)
      if (i != skip) t[k++] = s[i];
    Face f = makeFace(p, t[0], t[1], t[2]);
    if (signedDistance(f, p[s[skip]]) > 0.0) f = makeFace(p, t[0], t[2], t[1]);
    faces.push_back(f);
  }

  for (int i = 0; i < int(p.size()); ++i) {
    if (std::find(s.begin(), s.end(), i) != s.end()) continue;
    // Strictly visible faces only: a point within eps of the surface adds nothing but slivers.
    std::set<std::pair<int, int>> visible_edges;
    for (auto& f : faces) {
      if (!f.alive || signedDistance(f, p[i]) <= eps) continue;
      f.alive = false;
      for (int e = 0; e < 3; ++e) visible_edges.insert({f.v[e], f.v[(e + 1) % 3]});
    }
    // The horizon: edges of visible faces whose twin belongs to a face that stays. Keeping each
    // edge's direction keeps the new faces counter-clockwise from outside.
    for (const auto& [a, b] : visible_edges)
      if (!visible_edges.count({b, a})) faces.push_back(makeFace(p, a, b, i));
  }

  HullMesh mesh;
  std::vector<int> index(p.size(), -1);
  for (const auto& f : faces)
    if (f.alive)
      for (int e = 0; e < 3; ++e) index[f.v[e]] = 0;
  for (int i = 0; i < int(p.size()); ++i)
    if (index[i] == 0) {
      index[i] = int(mesh.vertices.size());
      mesh.vertices.push_back(p[i]);
    }
  for (const auto& f : faces)
    if (f.alive) mesh.faces.emplace_back(index[f.v[0]], index[f.v[1]], index[f.v[2]]);
  return mesh;
}

double convexHullArea(std::vector<Eigen::Vector2d> p) {
  if (p.size() < 3) return 0.0;
  std::sort(p.begin(), p.end(), [](const auto& a, const auto& b) {
    return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y());
  });
  auto cross = [](const Eigen::Vector2d& o, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    return (a.x() - o.x()) * (b.y() - o.y()) - (a.y() - o.y()) * (b.x() - o.x());
  };
  // Andrew's monotone chain: lower hull left to right, then upper hull right to left.
  std::vector<Eigen::Vector2d> hull(2 * p.size());
  std::size_t k = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    while (k >= 2 && cross(hull[k - 2], hull[k - 1], p[i]) <= 0.0) --k;
    hull[k++] = p[i];
  }
  for (std::size_t i = p.size() - 1, lower = k + 1; i-- > 0;) {
    while (k >= lower && cross(hull[k - 2], hull[k - 1], p[i]) <= 0.0) --k;
    hull[k++] = p[i];
  }
  double twice_area = 0.0;
  for (std::size_t i = 0; i + 1 < k; ++i)
    twice_area += hull[i].x() * hull[i + 1].y() - hull[i + 1].x() * hull[i].y();
  return 0.5 * std::abs(twice_area);
}

bool isConvex(const Points& vertices, const std::vector<Eigen::Vector3i>& faces, double tolerance) {
  for (const auto& f : faces) {
    const Eigen::Vector3d n =
        (vertices[f[1]] - vertices[f[0]]).cross(vertices[f[2]] - vertices[f[0]]);
    if (!(n.norm() > 0.0)) return false;
    const Eigen::Vector3d u = n.normalized();
    for (const auto& v : vertices)
      if (u.dot(v - vertices[f[0]]) > tolerance) return false;
  }
  return !faces.empty();
}

bool isClosed(const std::vector<Eigen::Vector3i>& faces) {
  std::map<std::pair<int, int>, int> directed;
  for (const auto& f : faces) {
    if (f[0] == f[1] || f[1] == f[2] || f[2] == f[0]) return false;
    for (int e = 0; e < 3; ++e) ++directed[{f[e], f[(e + 1) % 3]}];
  }
  for (const auto& [edge, count] : directed) {
    auto twin = directed.find({edge.second, edge.first});
    if (count != 1 || twin == directed.end() || twin->second != 1) return false;
  }
  return !faces.empty();
}

}  // namespace ambler::terrains
