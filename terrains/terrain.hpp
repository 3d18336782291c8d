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

// Dem: a given base surface (heights on the spec's grid, e.g. a digital elevation model resampled by
// eval/geo/dem.hpp; terrains never reads files) with the components below added as for Plane.
enum class TerrainKind { Plane, Fractal, Sinusoid, Steps, Mars, Mjcf, Dem };

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
  // Kind Dem (docs/scenario.md, "terrain.kind: dem"): where the heights come from. Read by eval/geo/dem.hpp,
  // never by terrains; the DEM window is the grid's extent (size_m) sampled at cell_m.
  std::string dem;                                 // absolute path of the GeoTIFF
  std::optional<Eigen::Vector2d> dem_centre_m;     // window centre in the DEM's CRS; absent: the DEM's centre
  std::optional<double> dem_vertical_offset_m;     // world z = DEM height − offset; absent: the DEM's
                                                   // height at the window centre (so z = 0 there)
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

// The grid every kind's heightfield has: cols = round(size_x/cell) + 1, rows = round(size_y/cell) + 1,
// centred on the origin, all heights 0.
Heightfield terrainGrid(const TerrainSpec& spec);

// Builds the terrain of a spec (any kind but Mjcf and Dem). Same spec and seed, same terrain, bit for
// bit. Throws std::invalid_argument for a spec it cannot build.
Terrain makeTerrain(const TerrainSpec& spec, std::uint64_t seed);

// The same on a given base surface: `base` holds the heights of terrainGrid(spec) (rows × cols, row 0
// at the smallest y); the tilt, sinusoid, steps, craters and rocks of the spec are added on top as for
// kind Plane, rocks placed on the result. Kind Dem only; throws std::invalid_argument for another kind,
// a base of the wrong shape or a non-finite height.
Terrain makeTerrain(const TerrainSpec& spec, std::uint64_t seed, const HeightMatrix& base);

// The top of a terrain at (x, y): the ground (its triangulated heightfield), or the highest rock face
// above it (each face's plane over the triangle it covers in plan view; vertical faces have none):
// the surface a ray cast straight down meets. nullopt outside the heightfield.
std::optional<double> surfaceAt(const Terrain& terrain, double x, double y);

}  // namespace ambler::terrains
