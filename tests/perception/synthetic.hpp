#pragma once
// Synthetic range images with exact ranges, for perception tests that need no simulator.
#include <cmath>
#include <algorithm>
#include <limits>
#include <vector>

#include "perception/elevation_map.hpp"
#include "perception/range_image.hpp"
#include "perception/sensor_geometry.hpp"

namespace ambler::test {

// The plane z = a·x + b·y + c.
struct Plane {
  double a = 0, b = 0, c = 0;
  double z(double x, double y) const { return a * x + b * y + c; }
  Eigen::Vector3d normal() const { return Eigen::Vector3d(-a, -b, 1).normalized(); }
};

// Exact range of the ray from the sensor along `d` (world) to the plane, NaN if it never meets it
// in front.
inline double rangeToPlane(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const Plane& p) {
  const double den = d.z() - p.a * d.x() - p.b * d.y();
  const double t = (p.z(o.x(), o.y()) - o.z()) / den;
  return t > 0 ? t : std::numeric_limits<double>::quiet_NaN();
}

inline perception::RangeImage planeImage(const Plane& plane, const Eigen::Isometry3d& T_WS, int rows = 64,
                                         int cols = 256, double fov_v = 30 * M_PI / 180,
                                         double fov_h = 80 * M_PI / 180, double max_range = 40) {
  auto img = perception::RangeImage::blank(rows, cols, fov_v, fov_h);
  img.T_WS = T_WS;
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) {
      const Eigen::Vector3d d = T_WS.linear() * perception::beamDirection(img.phi[r], img.theta[c]);
      const double t = rangeToPlane(T_WS.translation(), d, plane);
      img.range(r, c) = t <= max_range ? float(t) : std::numeric_limits<float>::quiet_NaN();
    }
  return img;
}

// The sphere of centre c and radius R (the dome is its cap above the ground it replaces).
struct Dome {
  Eigen::Vector3d c{1.0, 4.0, -5.5};
  double R = 6.0;
  double z(double x, double y) const { return c.z() + std::sqrt(R * R - (x - c.x()) * (x - c.x()) - (y - c.y()) * (y - c.y())); }
};

// A noise-free image of the dome: each ray's first meeting with the sphere, NaN if none.
inline perception::RangeImage domeImage(const Dome& dome, const Eigen::Isometry3d& T_WS) {
  perception::RangeImage img = perception::RangeImage::blank(64, 256, 30 * M_PI / 180, 80 * M_PI / 180);
  img.T_WS = T_WS;
  const Eigen::Vector3d o = T_WS.translation();
  for (int r = 0; r < img.rows(); ++r)
    for (int c = 0; c < img.cols(); ++c) {
      const Eigen::Vector3d d = T_WS.linear() * perception::beamDirection(img.phi[r], img.theta[c]);
      const Eigen::Vector3d oc = o - dome.c;
      const double b = d.dot(oc), disc = b * b - (oc.squaredNorm() - dome.R * dome.R);
      const double t = disc >= 0 ? -b - std::sqrt(disc) : std::numeric_limits<double>::quiet_NaN();
      img.range(r, c) = t > 0 ? float(t) : std::numeric_limits<float>::quiet_NaN();
    }
  return img;
}

// Map 1: the dome's exact heights over x ∈ [−1, 3], y ∈ [1.5, 5] at 10 cm (the part of it the
// sensor below sees well: the back side past y ≈ 5.8 faces away from it).
inline perception::ElevationMap domeMap(const Dome& dome) {
  perception::ElevationMap m(perception::MapGrid::covering(-1, 3, 1.5, 5, 0.1));
  for (int r = 0; r < m.grid().rows; ++r)
    for (int c = 0; c < m.grid().cols; ++c) {
      const Eigen::Vector2d p = m.grid().center(r, c);
      m.setKnown(r, c, float(dome.z(p.x(), p.y())), 1e-3f);
    }
  return m;
}

// Ground with three sphere caps (rock-like bumps): every one of the six parameters is constrained.
struct Caps {
  std::vector<Eigen::Vector3d> centre{{-1.0, 4.0, -1.2}, {1.5, 6.0, -0.6}, {0.5, 2.5, -0.9}};
  std::vector<double> radius{1.5, 1.0, 1.1};
  double z(double x, double y) const {
    double z = 0;
    for (std::size_t i = 0; i < centre.size(); ++i) {
      const double d2 = (x - centre[i].x()) * (x - centre[i].x()) + (y - centre[i].y()) * (y - centre[i].y());
      if (d2 < radius[i] * radius[i]) z = std::max(z, centre[i].z() + std::sqrt(radius[i] * radius[i] - d2));
    }
    return z;
  }
  // The first meeting of the ray o + t·d with the ground or a cap above it.
  double range(const Eigen::Vector3d& o, const Eigen::Vector3d& d) const {
    double best = d.z() < 0 ? -o.z() / d.z() : std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < centre.size(); ++i) {
      const Eigen::Vector3d oc = o - centre[i];
      const double b = d.dot(oc), disc = b * b - (oc.squaredNorm() - radius[i] * radius[i]);
      if (disc < 0) continue;
      const double t = -b - std::sqrt(disc);
      if (t > 0 && t < best && (o + t * d).z() >= 0) best = t;
    }
    return best;
  }
};

inline perception::RangeImage capsImage(const Caps& caps, const Eigen::Isometry3d& T_WS) {
  perception::RangeImage img = perception::RangeImage::blank(64, 256, 30 * M_PI / 180, 80 * M_PI / 180);
  img.T_WS = T_WS;
  for (int r = 0; r < img.rows(); ++r)
    for (int c = 0; c < img.cols(); ++c) {
      const double t = caps.range(T_WS.translation(), T_WS.linear() * perception::beamDirection(img.phi[r], img.theta[c]));
      img.range(r, c) = t < 40 ? float(t) : std::numeric_limits<float>::quiet_NaN();
    }
  return img;
}

// Whether two maps are the same bits: every cell's state, elevation, σ and shadow ceiling (NaN
// equal to NaN).
inline bool sameBits(const perception::ElevationMap& a, const perception::ElevationMap& b) {
  const auto same = [](const perception::Raster<float>& x, const perception::Raster<float>& y) {
    return x.rows() == y.rows() && x.cols() == y.cols() &&
           ((x.array() == y.array()) || (x.array().isNaN() && y.array().isNaN())).all();
  };
  if (a.grid().rows != b.grid().rows || a.grid().cols != b.grid().cols) return false;
  for (int r = 0; r < a.grid().rows; ++r)
    for (int c = 0; c < a.grid().cols; ++c)
      if (a.stateAt(r, c) != b.stateAt(r, c)) return false;
  return same(a.elevation(), b.elevation()) && same(a.sigma(), b.sigma()) && same(a.shadowCeiling(), b.shadowCeiling());
}

}  // namespace ambler::test
