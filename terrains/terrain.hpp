#pragma once
// The terrain of one scenario: a ground heightfield plus rocks, built deterministically from a
// spec and a seed.
#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "terrains/heightfield.hpp"

namespace ambler::terrains {

enum class TerrainKind { Plane, Fractal, Sinusoid, Steps, Mars, Mjcf };

struct SinusoidSpec {
  double amplitude_m = 0.05;
  double wavelength_m = 0.4;
};

struct StepSpec {
  double x_m = 2.0;       // z rises by height_m for x > x_m
  double height_m = 0.4;
};

// Golombek–Rapp rock abundance: cumulative fractional area of rocks with diameter >= D is
// k·exp(−q(k)·D), q(k) = 1.79 + 0.152/k. Rocks with diameter in [min, max] are generated.
struct RockSpec {
  double abundance_k = 0.10;
  double min_diameter_m = 0.1;
  double max_diameter_m = 1.0;
};

// Impact craters; diameters follow a power-law size–frequency distribution N(>=D) ∝ D^−exponent.
struct CraterSpec {
  int count = 4;
  double min_diameter_m = 1.0;
  double max_diameter_m = 5.0;
  double sfd_exponent = 2.0;
};

struct TerrainSpec {
  TerrainKind kind = TerrainKind::Fractal;
  Eigen::Vector2d size_m{20.0, 20.0};  // extent in x and y, centred on the world origin
  double cell_m = 0.05;
  double relief_m = 0.6;               // fractal: peak-to-peak height of the fractal component
  double hurst = 0.7;                  // fractal roughness exponent, 0 < hurst < 1
  Eigen::Vector2d slope_deg{0.0, 0.0}; // tilt about x and y (right-handed), all kinds
  std::optional<SinusoidSpec> sinusoid;
  std::vector<StepSpec> steps;
  std::optional<RockSpec> rocks;
  std::optional<CraterSpec> craters;
  std::string mjcf;                    // kind Mjcf: path of the MuJoCo world to load
};

// A convex rock mesh: vertices relative to `center` (world frame), faces counter-clockwise
// seen from outside. `diameter_m` is the plan-view equivalent diameter: the mesh's footprint
// seen from above has area π·D²/4.
struct Rock {
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector3d> vertices;
  std::vector<Eigen::Vector3i> faces;
  double diameter_m = 0.0;
};

struct Terrain {
  Heightfield ground;
  std::vector<Rock> rocks;
};

// Builds the terrain of a spec (any kind but Mjcf). Same spec and seed, same terrain, bit for bit.
// Throws std::invalid_argument for a spec it cannot build.
Terrain makeTerrain(const TerrainSpec& spec, std::uint64_t seed);

}  // namespace ambler::terrains
