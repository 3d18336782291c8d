#pragma once
// An emulator of the ERIM scanning laser range finder: eq. 1 beam geometry, range noise with
// σ = k·ρ², 8-bit quantisation, the ambiguity interval (ranges wrap), a maximum range, random
// dropouts and mixed pixels at depth discontinuities — each switchable.
#include <Eigen/Geometry>
#include <cstdint>
#include <optional>

#include "perception/raster.hpp"
#include "perception/range_image.hpp"
#include "perception/sensor_model.hpp"

namespace ambler::sim {

class RayScene;


// Sub-rays of the beam footprint: the 7-point cubature of a uniform disk (the centre with
// weight 1/4, six points at √(2/3) of the radius with weight 1/8 each).
inline constexpr int kFootprintSamples = 7;

struct Scan {
  perception::RangeImage image;   // what the sensor reports
  perception::Raster<float> true_range;  // the central ray's true range; NaN if it hit nothing
  Eigen::Matrix<int, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> geom;  // -1: no hit

  // The true hit of pixel (r, c)'s central ray in the world frame (nullopt if it hit nothing):
  // the ray the scanner cast, to the refined true range. Derived, not stored, to keep the
  // scanner's memory traffic to what it measures.
  std::optional<Eigen::Vector3d> trueHit(int r, int c) const;
};

class ErimScanner {
 public:
  // Throws std::invalid_argument for a sensor model out of range (perception::validate).
  ErimScanner(const RayScene& scene, perception::SensorModel sensor);

  // One range image from sensor pose T_WS. All random draws derive from `seed` and the pixel
  // index, so the result does not depend on the thread schedule. Parallel over all cores.
  Scan scan(const Eigen::Isometry3d& T_WS, std::uint64_t seed) const;
  // The same into `out`, reusing its memory when its size matches (for sweeps and benchmarks).
  void scan(const Eigen::Isometry3d& T_WS, std::uint64_t seed, Scan& out) const;

  const perception::SensorModel& sensor() const { return sensor_; }

 private:
  const RayScene& scene_;
  perception::SensorModel sensor_;
};

// The direction, in the world, of pixel (r, c)'s central ray: exactly what the scanner casts.
Eigen::Vector3d pixelDirection(const perception::RangeImage& image, int r, int c);

// The measurement model applied to one true range (no geometry): noise, wrap, quantisation.
// `normal` is a standard normal draw. Returns the reported range (never negative).
double measureRange(double rho, double normal, const perception::SensorModel& sensor);

}  // namespace ambler::sim
