#include "terrains/terrain.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>

#include "terrains/craters.hpp"
#include "terrains/fractal.hpp"
#include "base/random.hpp"
#include "terrains/rocks.hpp"

namespace ambler::terrains {
namespace {

constexpr double kMaxSamples = 25.0e6;

// One stream per random component: adding rocks leaves the fractal and the craters as they were.
enum Stream : std::uint64_t { kFractalStream = 1, kCraterStream = 2, kRockStream = 3 };

[[noreturn]] void fail(const std::string& what) { throw std::invalid_argument("terrain: " + what); }

bool finite(double v) { return std::isfinite(v); }

// The craters and rocks a spec asks for: given explicitly, or the defaults of kind Mars.
std::optional<CraterSpec> cratersOf(const TerrainSpec& s) {
  if (s.kind == TerrainKind::Mars) return s.craters.value_or(CraterSpec{});
  return s.craters;
}
std::optional<RockSpec> rocksOf(const TerrainSpec& s) {
  if (s.kind == TerrainKind::Mars) return s.rocks.value_or(RockSpec{});
  return s.rocks;
}

void checkSpec(const TerrainSpec& s) {
  if (s.kind == TerrainKind::Mjcf) fail("kind mjcf is loaded from its file, not generated");
  if (!(s.size_m.x() > 0.0 && s.size_m.y() > 0.0) || !s.size_m.allFinite())
    fail("size_m must be finite and positive");
  if (!(s.cell_m > 0.0) || !finite(s.cell_m)) fail("cell_m must be finite and positive");
  const double cols = std::round(s.size_m.x() / s.cell_m) + 1,
               rows = std::round(s.size_m.y() / s.cell_m) + 1;
  if (cols < 2 || rows < 2) fail("cell_m must be at most twice size_m, for two samples per side");
  if (rows * cols > kMaxSamples)
    fail("grid of " + std::to_string(long(rows)) + " x " + std::to_string(long(cols)) +
         " samples exceeds the limit of 25M; increase cell_m");
  if (!(s.relief_m >= 0.0) || !finite(s.relief_m)) fail("relief_m must be finite and >= 0");
  if (!(s.hurst > 0.0 && s.hurst < 1.0)) fail("hurst must be in (0, 1)");
  if (!(std::abs(s.slope_deg.x()) < 90.0 && std::abs(s.slope_deg.y()) < 90.0))
    fail("slope_deg must be within (-90, 90)");
  if (s.sinusoid) {
    if (!(s.sinusoid->amplitude_m >= 0.0) || !finite(s.sinusoid->amplitude_m))
      fail("sinusoid.amplitude_m must be finite and >= 0");
    if (!(s.sinusoid->wavelength_m > 0.0) || !finite(s.sinusoid->wavelength_m))
      fail("sinusoid.wavelength_m must be finite and positive");
  }
  for (const auto& step : s.steps)
    if (!finite(step.x_m) || !finite(step.height_m)) fail("steps: x_m and height_m must be finite");
  if (const auto craters = cratersOf(s)) checkCraterSpec(*craters);
  if (const auto rocks = rocksOf(s)) {
    checkRockSpec(*rocks);
    // An elongated rock's bounding circle reaches ~0.7·D; half the side leaves room to place it.
    if (rocks->max_diameter_m > 0.5 * std::min(s.size_m.x(), s.size_m.y()))
      fail("rocks.max_diameter_m must be at most half the terrain's smaller side");
  }
}

// z = y·tan(slope_x) − x·tan(slope_y): the plane z = 0 turned right-handedly by slope_x about x
// (or by slope_y about y); with both non-zero, the plane with both of those gradients.
void addTilt(Heightfield& g, const Eigen::Vector2d& slope_deg) {
  const double tx = std::tan(slope_deg.x() * std::numbers::pi / 180.0);
  const double ty = std::tan(slope_deg.y() * std::numbers::pi / 180.0);
  for (int r = 0; r < g.rows(); ++r)
    for (int c = 0; c < g.cols(); ++c) {
      const Eigen::Vector2d p = g.position(r, c);
      g.at(r, c) += p.y() * tx - p.x() * ty;
    }
}

// An egg-crate: z = A·sin(2πx/λ)·sin(2πy/λ), zero along the axes and on a λ/2 lattice.
void addSinusoid(Heightfield& g, const SinusoidSpec& s) {
  const double k = 2.0 * std::numbers::pi / s.wavelength_m;
  for (int r = 0; r < g.rows(); ++r)
    for (int c = 0; c < g.cols(); ++c) {
      const Eigen::Vector2d p = g.position(r, c);
      g.at(r, c) += s.amplitude_m * std::sin(k * p.x()) * std::sin(k * p.y());
    }
}

// Samples with x > x_m rise by the full height, the others not at all: the ledge is as sharp
// as the triangulated surface allows, a ramp one cell wide.
void addStep(Heightfield& g, const StepSpec& s) {
  for (int c = 0; c < g.cols(); ++c)
    if (g.position(0, c).x() > s.x_m) g.heights().col(c).array() += s.height_m;
}

Terrain compose(const TerrainSpec& spec, std::uint64_t seed, const HeightMatrix* base) {
  Terrain terrain{terrainGrid(spec), {}};
  Heightfield& ground = terrain.ground;
  if (base) ground.heights() = *base;

  const TerrainKind kind = spec.kind;
  addTilt(ground, spec.slope_deg);
  if (kind == TerrainKind::Fractal || kind == TerrainKind::Mars)
    addFractal(ground, spec.relief_m, spec.hurst, base::streamKey(seed, kFractalStream));
  if (spec.sinusoid || kind == TerrainKind::Sinusoid)
    addSinusoid(ground, spec.sinusoid.value_or(SinusoidSpec{}));
  if (spec.steps.empty() && kind == TerrainKind::Steps) addStep(ground, StepSpec{});
  for (const auto& step : spec.steps) addStep(ground, step);
  if (const auto craters = cratersOf(spec))
    addCraters(ground, sampleCraters(*craters, ground, base::streamKey(seed, kCraterStream)));
  if (const auto rocks = rocksOf(spec))
    terrain.rocks = makeRocks(*rocks, ground, base::streamKey(seed, kRockStream));
  return terrain;
}

}  // namespace

Heightfield terrainGrid(const TerrainSpec& spec) {
  checkSpec(spec);
  const int cols = int(std::round(spec.size_m.x() / spec.cell_m)) + 1;
  const int rows = int(std::round(spec.size_m.y() / spec.cell_m)) + 1;
  const Eigen::Vector2d origin(-(cols - 1) * spec.cell_m / 2.0, -(rows - 1) * spec.cell_m / 2.0);
  return Heightfield(rows, cols, spec.cell_m, origin);
}

Terrain makeTerrain(const TerrainSpec& spec, std::uint64_t seed) {
  if (spec.kind == TerrainKind::Dem) fail("kind dem is built on its base heights: makeTerrain(spec, seed, base)");
  return compose(spec, seed, nullptr);
}

Terrain makeTerrain(const TerrainSpec& spec, std::uint64_t seed, const HeightMatrix& base) {
  if (spec.kind != TerrainKind::Dem) fail("base heights are given to kind dem only");
  const Heightfield grid = terrainGrid(spec);  // checks the spec first
  const int rows = grid.rows(), cols = grid.cols();
  if (base.rows() != rows || base.cols() != cols)
    fail("base heights are " + std::to_string(base.rows()) + " x " + std::to_string(base.cols()) +
         ", the grid is " + std::to_string(rows) + " x " + std::to_string(cols));
  if (!base.allFinite()) fail("base heights must be finite");
  return compose(spec, seed, &base);
}

std::optional<double> surfaceAt(const Terrain& terrain, double x, double y) {
  std::optional<double> top = terrain.ground.height(x, y);
  if (!top) return std::nullopt;
  for (const Rock& rock : terrain.rocks) {
    for (const Eigen::Vector3i& f : rock.faces) {
      const Eigen::Vector3d a = rock.center + rock.vertices[f[0]], b = rock.center + rock.vertices[f[1]],
                            c = rock.center + rock.vertices[f[2]];
      // (x, y)'s barycentric coordinates in the face's plan-view triangle; d is twice its signed area.
      const double d = (b.y() - c.y()) * (a.x() - c.x()) + (c.x() - b.x()) * (a.y() - c.y());
      if (std::abs(d) < 1e-15) continue;  // a vertical face
      const double la = ((b.y() - c.y()) * (x - c.x()) + (c.x() - b.x()) * (y - c.y())) / d;
      const double lb = ((c.y() - a.y()) * (x - c.x()) + (a.x() - c.x()) * (y - c.y())) / d;
      const double lc = 1.0 - la - lb;
      if (la >= 0 && lb >= 0 && lc >= 0) top = std::max(*top, la * a.z() + lb * b.z() + lc * c.z());
    }
  }
  return top;
}

}  // namespace ambler::terrains
