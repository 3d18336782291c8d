#include "terrains/rocks.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

#include "terrains/convex_hull.hpp"

namespace ambler::terrains {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr int kTableSegments = 2048;
constexpr double kMaxRocks = 2.0e6;
constexpr int kPlacementAttempts = 5000;
constexpr double kMaxBurial = 0.3;

// The cumulative number density G(D) = ∫_min^D n, tabulated at log-spaced diameters. In
// s = ln D the integrand (4kq/π)·exp(−q·e^s)·e^−s is smooth and slowly varying, so Simpson per
// segment is exact to ~1e-12 and linear interpolation inside a segment is ample.
struct DiameterTable {
  std::vector<double> log_d, cumulative;
};

DiameterTable diameterTable(const RockSpec& spec) {
  const double k = spec.abundance_k, q = rockDecay(k);
  auto integrand = [&](double s) { return 4.0 * k * q / kPi * std::exp(-q * std::exp(s) - s); };
  const double s0 = std::log(spec.min_diameter_m), s1 = std::log(spec.max_diameter_m);
  const double h = (s1 - s0) / kTableSegments;
  DiameterTable t{{s0}, {0.0}};
  for (int i = 0; i < kTableSegments; ++i) {
    const double a = s0 + i * h, b = (i + 1 == kTableSegments) ? s1 : a + h;
    const double simpson =
        (b - a) / 6.0 * (integrand(a) + 4.0 * integrand(0.5 * (a + b)) + integrand(b));
    t.log_d.push_back(b);
    t.cumulative.push_back(t.cumulative.back() + simpson);
  }
  return t;
}

double inverseCumulative(const DiameterTable& t, double g) {
  const auto it = std::upper_bound(t.cumulative.begin(), t.cumulative.end(), g);
  const std::size_t i =
      std::clamp<std::size_t>(it - t.cumulative.begin(), 1, t.cumulative.size() - 1);
  const double span = t.cumulative[i] - t.cumulative[i - 1];
  const double f = span > 0.0 ? std::clamp((g - t.cumulative[i - 1]) / span, 0.0, 1.0) : 0.0;
  return std::exp(t.log_d[i - 1] + f * (t.log_d[i] - t.log_d[i - 1]));
}

}  // namespace

void checkRockSpec(const RockSpec& s) {
  auto fail = [](const char* what) { throw std::invalid_argument(std::string("rocks: ") + what); };
  if (!(s.abundance_k > 0.0 && s.abundance_k < 1.0)) fail("abundance_k must be in (0, 1)");
  if (!(s.min_diameter_m > 0.0) || !std::isfinite(s.min_diameter_m))
    fail("min_diameter_m must be finite and > 0");
  if (!(s.max_diameter_m >= s.min_diameter_m) || !std::isfinite(s.max_diameter_m))
    fail("max_diameter_m must be finite and >= min_diameter_m");
}

double rockDecay(double abundance_k) { return 1.79 + 0.152 / abundance_k; }

double rockCumulativeFraction(const RockSpec& spec, double diameter_m) {
  const double q = rockDecay(spec.abundance_k);
  const double d = std::clamp(diameter_m, spec.min_diameter_m, spec.max_diameter_m);
  return spec.abundance_k * (std::exp(-q * d) - std::exp(-q * spec.max_diameter_m));
}

double rockNumberDensity(const RockSpec& spec) {
  checkRockSpec(spec);
  return diameterTable(spec).cumulative.back();
}

std::vector<double> sampleRockDiameters(const RockSpec& spec, double area_m2, base::Rng& rng) {
  checkRockSpec(spec);
  const DiameterTable table = diameterTable(spec);
  const double total = table.cumulative.back();
  const double expected = area_m2 * total;
  if (!(expected <= kMaxRocks))
    throw std::invalid_argument("rocks: " + std::to_string(expected) +
                                " rocks expected, more than the limit of 2e6");
  const long n = std::lround(expected);
  std::vector<double> diameters;
  diameters.reserve(n);
  // One draw per stratum of the CDF: the total rock area then varies far less than with
  // independent draws, which matters for the small counts of large rocks.
  for (long i = n - 1; i >= 0; --i)
    diameters.push_back(inverseCumulative(table, (double(i) + rng.uniform()) / double(n) * total));
  return diameters;
}

Rock makeRockShape(double diameter_m, base::Rng& rng) {
  const int points = 30 + int(rng.below(31));
  const double a = 0.5 * diameter_m, b = a * rng.uniform(0.6, 1.0);
  const double c = diameter_m * rng.uniform(0.25, 0.5);
  const double yaw = rng.uniform(0.0, 2.0 * kPi);
  const Eigen::Matrix3d turn = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  std::vector<Eigen::Vector3d> cloud;
  for (int i = 0; i < points; ++i) {
    // Uniform directions, each pulled in by up to 15 %: the hull gets facets and corners of
    // uneven size instead of a smooth ellipsoid.
    const Eigen::Vector3d u =
        Eigen::Vector3d(rng.normal(), rng.normal(), rng.normal()).normalized();
    const double jitter = rng.uniform(0.85, 1.0);
    cloud.push_back(turn * Eigen::Vector3d(a * u.x(), b * u.y(), c * u.z()) * jitter);
  }
  HullMesh hull = convexHull(cloud);

  Rock rock;
  rock.vertices = std::move(hull.vertices);
  rock.faces = std::move(hull.faces);
  rock.diameter_m = diameter_m;
  // Scaling x and y together is affine, so the mesh stays convex and its faces outward.
  const double scale = std::sqrt(0.25 * kPi * diameter_m * diameter_m / planViewArea(rock));
  for (auto& v : rock.vertices) v.head<2>() *= scale;
  return rock;
}

std::vector<Rock> makeRocks(const RockSpec& spec, const Heightfield& ground, std::uint64_t key) {
  checkRockSpec(spec);
  const double width = ground.xMax() - ground.xMin(), depth = ground.yMax() - ground.yMin();
  base::Rng sizes(base::streamKey(key, 0)), places(base::streamKey(key, 1));
  const std::vector<double> diameters = sampleRockDiameters(spec, width * depth, sizes);

  // Each rock's shape comes from its own stream, so it does not depend on how many tries
  // the placement of earlier rocks took.
  std::vector<Rock> rocks;
  std::vector<double> radius, burial;
  for (std::size_t i = 0; i < diameters.size(); ++i) {
    base::Rng shape(base::streamKey(key, 2, i));
    rocks.push_back(makeRockShape(diameters[i], shape));
    radius.push_back(boundingRadius(rocks.back()));
    burial.push_back(shape.uniform(0.0, kMaxBurial));
    if (2.0 * radius.back() >= std::min(width, depth))
      throw std::invalid_argument("rocks: a rock of diameter " + std::to_string(diameters[i]) +
                                  " m does not fit on the terrain");
  }
  if (rocks.empty()) return rocks;

  // Buckets twice the largest radius wide: any rock that can touch a candidate has its
  // centre in the candidate's bucket or one of the eight around it.
  const double bucket = 2.0 * *std::max_element(radius.begin(), radius.end());
  const int nx = int(width / bucket) + 1, ny = int(depth / bucket) + 1;
  std::vector<std::vector<int>> buckets(std::size_t(nx) * ny);
  auto bucketOf = [&](const Eigen::Vector2d& p) {
    const int bx = std::clamp(int((p.x() - ground.xMin()) / bucket), 0, nx - 1);
    const int by = std::clamp(int((p.y() - ground.yMin()) / bucket), 0, ny - 1);
    return Eigen::Vector2i(bx, by);
  };
  auto isFree = [&](const Eigen::Vector2d& p, double r) {
    const Eigen::Vector2i b = bucketOf(p);
    for (int y = std::max(0, b.y() - 1); y <= std::min(ny - 1, b.y() + 1); ++y)
      for (int x = std::max(0, b.x() - 1); x <= std::min(nx - 1, b.x() + 1); ++x)
        for (int j : buckets[std::size_t(y) * nx + x])
          if ((rocks[j].center.head<2>() - p).norm() < r + radius[j]) return false;
    return true;
  };

  for (std::size_t i = 0; i < rocks.size(); ++i) {
    const double r = radius[i];
    bool placed = false;
    for (int attempt = 0; attempt < kPlacementAttempts && !placed; ++attempt) {
      const Eigen::Vector2d p(places.uniform(ground.xMin() + r, ground.xMax() - r),
                              places.uniform(ground.yMin() + r, ground.yMax() - r));
      if (!isFree(p, r)) continue;
      const double top =
          std::max_element(rocks[i].vertices.begin(), rocks[i].vertices.end(),
                           [](const auto& u, const auto& v) { return u.z() < v.z(); })
              ->z();
      rocks[i].center = {p.x(), p.y(), *ground.height(p.x(), p.y()) - burial[i] * top};
      const Eigen::Vector2i b = bucketOf(p);
      buckets[std::size_t(b.y()) * nx + b.x()].push_back(int(i));
      placed = true;
    }
    if (!placed)
      throw std::invalid_argument("rocks: no free place for rock " + std::to_string(i) + " of " +
                                  std::to_string(rocks.size()) + "; abundance_k too high");
  }
  return rocks;
}

double planViewArea(const Rock& rock) {
  std::vector<Eigen::Vector2d> footprint;
  footprint.reserve(rock.vertices.size());
  for (const auto& v : rock.vertices) footprint.push_back(v.head<2>());
  return convexHullArea(std::move(footprint));
}

double boundingRadius(const Rock& rock) {
  double r = 0.0;
  for (const auto& v : rock.vertices) r = std::max(r, v.head<2>().norm());
  return r;
}

bool isConvex(const Rock& rock, double tolerance) {
  return isConvex(rock.vertices, rock.faces, tolerance);
}

bool isClosed(const Rock& rock) { return isClosed(rock.faces); }

}  // namespace ambler::terrains
