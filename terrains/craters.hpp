#pragma once
// Simple bowl-shaped impact craters with a raised rim and an ejecta blanket
// (docs/terrains.md, "Craters").
#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "terrains/heightfield.hpp"
#include "terrains/terrain.hpp"

namespace ambler::terrains {

// Fresh simple craters: depth and rim height as fractions of the diameter (Pike 1977).
inline constexpr double kCraterDepthRatio = 0.2;
inline constexpr double kCraterRimRatio = 0.04;
// The ejecta blanket is tapered to zero at this many radii, so a crater touches a bounded area.
inline constexpr double kCraterCutoffRadii = 8.0;

struct Crater {
  Eigen::Vector2d center = Eigen::Vector2d::Zero();
  double diameter_m = 0.0;
};

// Throws std::invalid_argument naming the field for a spec that cannot be sampled.
void checkCraterSpec(const CraterSpec& spec);

// The diameter whose exceedance probability under the truncated power law
// P(≥D) = (D^−b − Dmax^−b)/(Dmin^−b − Dmax^−b) is 1 − u (u in [0, 1]).
double craterDiameterQuantile(const CraterSpec& spec, double u);

// The height a crater of diameter D adds at distance r from its centre: (d+h)(r/R)² − d inside,
// h·(R/r)³ outside (tapered to zero at kCraterCutoffRadii·R), d = 0.2·D, h = 0.04·D.
double craterProfile(double r, double diameter_m);

// spec.count craters with power-law diameters and centres uniform over the grid's extent.
std::vector<Crater> sampleCraters(const CraterSpec& spec, const Heightfield& grid,
                                  std::uint64_t key);

// Adds each crater's profile to the heights (overlapping craters add up).
void addCraters(Heightfield& ground, const std::vector<Crater>& craters);

}  // namespace ambler::terrains
