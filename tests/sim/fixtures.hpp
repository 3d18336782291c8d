#pragma once
// Shared test fixtures for sim/ and the integration tests: worlds made from terrains or MJCF, with
// their ray scene and ground truth, in temporary directories.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "sim/ground_truth.hpp"
#include "sim/ray_scene.hpp"
#include "sim/world.hpp"
#include "terrains/terrain.hpp"
#include "test_support.hpp"

namespace ambler::test {

// A loaded world in a temporary directory, with its ray scene and ground truth.
struct SimWorld {
  TempDir dir;
  std::unique_ptr<sim::World> world;
  std::unique_ptr<sim::RayScene> scene;
  std::unique_ptr<sim::GroundTruth> truth;

 protected:
  void load(sim::World w) {
    world = std::make_unique<sim::World>(std::move(w));
    scene = std::make_unique<sim::RayScene>(*world);
    truth = std::make_unique<sim::GroundTruth>(*scene);
  }
};

// A world written from `terrain` into a temporary directory and loaded back.
struct TerrainWorld : SimWorld {
  explicit TerrainWorld(const terrains::Terrain& terrain) {
    load(sim::World::load(sim::writeWorld(terrain, dir.path(), "test")));
  }
  // The terrain `spec` draws from `seed`.
  TerrainWorld(const terrains::TerrainSpec& spec, std::uint64_t seed) : TerrainWorld(terrains::makeTerrain(spec, seed)) {}
};

// A world from inline MJCF text, with asset files (name → bytes) written beside it first.
struct MjcfWorld : SimWorld {
  explicit MjcfWorld(const std::string& xml, const std::map<std::string, std::string>& files = {}) {
    for (const auto& [name, bytes] : files) std::ofstream(dir.path() / name, std::ios::binary) << bytes;
    load(sim::World::fromString(xml, dir.path()));
  }
};

// A flat-sided plane heightfield z = z0 + a·x + b·y over [-half, half]², sampled every `cell`.
// Fractal relief (0.8 m, 12 × 12 m at 10 cm) with Golombek–Rapp rocks (k = 0.15): the rough
// scene that the scanner tests cast through, every geom kind of a generated world in one.
inline terrains::TerrainSpec fractalWithRocks() {
  terrains::TerrainSpec spec;
  spec.kind = terrains::TerrainKind::Fractal;
  spec.size_m = {12.0, 12.0};
  spec.cell_m = 0.1;
  spec.relief_m = 0.8;
  spec.rocks = terrains::RockSpec{0.15, 0.15, 1.0};
  return spec;
}

inline terrains::Terrain planeTerrain(double a, double b, double z0, double half = 10.0, double cell = 0.1) {
  const int n = int(std::lround(2 * half / cell)) + 1;
  terrains::Terrain t{terrains::Heightfield(n, n, cell, {-half, -half}), {}};
  for (int r = 0; r < n; ++r)
    for (int c = 0; c < n; ++c) {
      const auto p = t.ground.position(r, c);
      t.ground.at(r, c) = z0 + a * p.x() + b * p.y();
    }
  return t;
}

// MuJoCo's binary hfield file (int32 rows, int32 cols, float32 data, row 0 at the smallest y).
inline std::string hfieldFile(int rows, int cols, const std::vector<float>& data) {
  std::string bytes(8, '\0');
  const std::int32_t dims[2] = {rows, cols};
  std::memcpy(bytes.data(), dims, 8);
  bytes.append(reinterpret_cast<const char*>(data.data()), data.size() * sizeof(float));
  return bytes;
}

}  // namespace ambler::test
