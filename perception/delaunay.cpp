#include "perception/delaunay.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

namespace ambler::perception {

namespace {

using Points = std::vector<Eigen::Vector2d>;

double dist2(const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return (a - b).squaredNorm(); }

// (r − p) × (q − p) with its sign kept only where rounding cannot have decided it (Shewchuk's
// error bound for the 2×2 determinant); 0 otherwise.
double orientIfSure(const Eigen::Vector2d& p, const Eigen::Vector2d& r, const Eigen::Vector2d& q) {
  const double l = (r.y() - p.y()) * (q.x() - p.x());
  const double rr = (r.x() - p.x()) * (q.y() - p.y());
  return std::abs(l - rr) >= 3.3306690738754716e-16 * std::abs(l + rr) ? l - rr : 0.0;
}

// True if r, q, p turn counter-clockwise, asking the three rotations of the triangle in turn so
// that one triangle always gets one answer.
bool ccw(const Eigen::Vector2d& r, const Eigen::Vector2d& q, const Eigen::Vector2d& p) {
  double s = orientIfSure(p, r, q);
  if (s == 0) s = orientIfSure(r, q, p);
  if (s == 0) s = orientIfSure(q, p, r);
  return s < 0;
}

// True if p is inside the circumcircle of the clockwise triangle a, b, c.
bool inCircle(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c,
              const Eigen::Vector2d& p) {
  const Eigen::Vector2d d = a - p, e = b - p, f = c - p;
  const double ap = d.squaredNorm(), bp = e.squaredNorm(), cp = f.squaredNorm();
  return d.x() * (e.y() * cp - bp * f.y()) - d.y() * (e.x() * cp - bp * f.x()) +
             ap * (e.x() * f.y() - e.y() * f.x()) <
         0;
}

// Offset of the circumcentre of a, b, c from a (infinite when they are collinear).
Eigen::Vector2d circumOffset(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c) {
  const Eigen::Vector2d d = b - a, e = c - a;
  const double bl = d.squaredNorm(), cl = e.squaredNorm();
  const double k = 0.5 / (d.x() * e.y() - d.y() * e.x());
  return {(e.y() * bl - d.y() * cl) * k, (d.x() * cl - e.x() * bl) * k};
}

// Monotone in the angle of (dx, dy), in [0, 1), without trigonometry.
double pseudoAngle(double dx, double dy) {
  if (dx == 0 && dy == 0) return 0;  // the seed's circumcentre itself
  const double p = dx / (std::abs(dx) + std::abs(dy));
  return (dy > 0 ? 3 - p : 1 + p) / 4;
}

class SweepHull {
 public:
  explicit SweepHull(const Points& pts) : p_(pts) {}
  std::vector<std::array<int, 3>> run();

 private:
  int hashKey(const Eigen::Vector2d& q) const {
    const double a = pseudoAngle(q.x() - centre_.x(), q.y() - centre_.y());
    return int(std::floor(a * double(hash_.size()))) % int(hash_.size());
  }
  void link(int a, int b) {
    half_[a] = b;
    if (b != -1) half_[b] = a;
  }
  int addTriangle(int i0, int i1, int i2, int a, int b, int c) {
    const int t = int(tri_.size());
    tri_.insert(tri_.end(), {i0, i1, i2});
    half_.insert(half_.end(), {-1, -1, -1});
    link(t, a), link(t + 1, b), link(t + 2, c);
    return t;
  }
  int legalize(int a);

  const Points& p_;
  Eigen::Vector2d centre_;
  std::vector<int> tri_, half_;                    // vertex and opposite half-edge of each half-edge
  std::vector<int> hull_prev_, hull_next_, hull_tri_, hash_;
  int hull_start_ = 0;
};

// Flips the edge a and, recursively, the edges behind it until every pair is Delaunay.
int SweepHull::legalize(int a) {
  std::array<int, 512> stack;  // only extremely degenerate input could fill it; then a flip is skipped
  int depth = 0, ar = 0;
  for (;;) {
    const int b = half_[a];
    const int a0 = a - a % 3;
    ar = a0 + (a + 2) % 3;
    if (b == -1) {  // a hull edge
      if (depth == 0) break;
      a = stack[--depth];
      continue;
    }
    const int b0 = b - b % 3, al = a0 + (a + 1) % 3, bl = b0 + (b + 2) % 3;
    const int p0 = tri_[ar], pr = tri_[a], pl = tri_[al], p1 = tri_[bl];
    if (inCircle(p_[p0], p_[pr], p_[pl], p_[p1])) {
      tri_[a] = p1;
      tri_[b] = p0;
      const int hbl = half_[bl];
      if (hbl == -1) {  // the flipped edge was on the hull: repoint the hull's triangle
        int e = hull_start_;
        do {
          if (hull_tri_[e] == bl) {
            hull_tri_[e] = a;
            break;
          }
          e = hull_prev_[e];
        } while (e != hull_start_);
      }
      link(a, hbl);
      link(b, half_[ar]);
      link(ar, bl);
      if (depth < int(stack.size())) stack[depth++] = b0 + (b + 1) % 3;
    } else {
      if (depth == 0) break;
      a = stack[--depth];
    }
  }
  return ar;
}

std::vector<std::array<int, 3>> SweepHull::run() {
  const int n = int(p_.size());
  if (n < 3) return {};
  Eigen::Vector2d lo = p_[0], hi = p_[0];
  for (const auto& q : p_) lo = lo.cwiseMin(q), hi = hi.cwiseMax(q);
  const Eigen::Vector2d mid = (lo + hi) / 2;
  // Seed: the point nearest the middle, its nearest neighbour, and the point making the smallest
  // circumcircle with them.
  int i0 = 0, i1 = -1, i2 = -1;
  for (int i = 1; i < n; ++i)
    if (dist2(mid, p_[i]) < dist2(mid, p_[i0])) i0 = i;
  double best = std::numeric_limits<double>::infinity();
  for (int i = 0; i < n; ++i) {
    const double d = dist2(p_[i0], p_[i]);
    if (i != i0 && d > 0 && d < best) i1 = i, best = d;
  }
  if (i1 < 0) return {};
  best = std::numeric_limits<double>::infinity();
  for (int i = 0; i < n; ++i) {
    if (i == i0 || i == i1) continue;
    const double r = circumOffset(p_[i0], p_[i1], p_[i]).squaredNorm();
    if (r < best) i2 = i, best = r;
  }
  if (i2 < 0 || !std::isfinite(best)) return {};  // all collinear
  if (ccw(p_[i0], p_[i1], p_[i2])) std::swap(i1, i2);  // triangles run clockwise
  centre_ = p_[i0] + circumOffset(p_[i0], p_[i1], p_[i2]);

  std::vector<std::pair<double, int>> order(n);  // by distance from the seed's circumcentre, then index
  for (int i = 0; i < n; ++i) order[i] = {dist2(p_[i], centre_), i};
  std::sort(order.begin(), order.end());

  hull_prev_.assign(n, 0), hull_next_.assign(n, 0), hull_tri_.assign(n, 0);
  hash_.assign(std::size_t(std::ceil(std::sqrt(double(n)))), -1);
  tri_.reserve(std::size_t(2 * n) * 3), half_.reserve(std::size_t(2 * n) * 3);
  hull_start_ = i0;
  hull_next_[i0] = hull_prev_[i2] = i1;
  hull_next_[i1] = hull_prev_[i0] = i2;
  hull_next_[i2] = hull_prev_[i1] = i0;
  hull_tri_[i0] = 0, hull_tri_[i1] = 1, hull_tri_[i2] = 2;
  hash_[hashKey(p_[i0])] = i0, hash_[hashKey(p_[i1])] = i1, hash_[hashKey(p_[i2])] = i2;
  addTriangle(i0, i1, i2, -1, -1, -1);

  Eigen::Vector2d prev(std::numeric_limits<double>::quiet_NaN(), 0);
  for (const auto& entry : order) {
    const int i = entry.second;
    const Eigen::Vector2d& x = p_[i];
    if (std::abs(x.x() - prev.x()) <= 0x1p-52 && std::abs(x.y() - prev.y()) <= 0x1p-52) continue;
    prev = x;
    if (i == i0 || i == i1 || i == i2) continue;
    // A hull edge that x sees, found from the angular hash.
    int start = 0;
    for (int j = 0, key = hashKey(x); j < int(hash_.size()); ++j) {
      start = hash_[(key + j) % hash_.size()];
      if (start != -1 && start != hull_next_[start]) break;
    }
    start = hull_prev_[start];
    int e = start, q = 0;
    while (q = hull_next_[e], !ccw(x, p_[e], p_[q])) {
      e = q;
      if (e == start) {
        e = -1;
        break;
      }
    }
    if (e == -1) continue;  // inside the hull up to rounding: a near-duplicate

    int t = addTriangle(e, i, hull_next_[e], -1, -1, hull_tri_[e]);
    hull_tri_[i] = legalize(t + 2);
    hull_tri_[e] = t;
    int nx = hull_next_[e];  // walk forward along the hull while x sees its edges
    while (q = hull_next_[nx], ccw(x, p_[nx], p_[q])) {
      t = addTriangle(nx, i, q, hull_tri_[i], -1, hull_tri_[nx]);
      hull_tri_[i] = legalize(t + 2);
      hull_next_[nx] = nx;  // removed from the hull
      nx = q;
    }
    if (e == start) {  // and backward
      while (q = hull_prev_[e], ccw(x, p_[q], p_[e])) {
        t = addTriangle(q, i, e, -1, hull_tri_[e], hull_tri_[q]);
        legalize(t + 2);
        hull_tri_[q] = t;
        hull_next_[e] = e;
        e = q;
      }
    }
    hull_start_ = hull_prev_[i] = e;
    hull_next_[e] = hull_prev_[nx] = i;
    hull_next_[i] = nx;
    hash_[hashKey(x)] = i;
    hash_[hashKey(p_[e])] = e;
  }

  std::vector<std::array<int, 3>> out(tri_.size() / 3);
  for (std::size_t t = 0; t < out.size(); ++t) out[t] = {tri_[3 * t], tri_[3 * t + 1], tri_[3 * t + 2]};
  return out;
}

}  // namespace

std::vector<std::array<int, 3>> delaunayTriangles(const std::vector<Eigen::Vector2d>& points) {
  return SweepHull(points).run();
}

}  // namespace ambler::perception
