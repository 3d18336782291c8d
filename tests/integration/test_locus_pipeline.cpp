// The mapping pipeline on simulated scans against ground truth: range shadows behind a ledge,
// calibrated σ_z on noisy fractal terrain, a Monte Carlo check of σ_z, and wrapped far fields.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <numbers>
#include <string>

#include "eval/score/map_metrics.hpp"
#include "perception/scan_to_map.hpp"
#include "eval/run/runner.hpp"
#include "perception/range_edges.hpp"
#include "perception/sensor_geometry.hpp"
#include "sim/erim_scanner.hpp"
#include "sim/ground_truth.hpp"
#include "sim/ray_scene.hpp"
#include "sim/world.hpp"
#include "sim/fixtures.hpp"
#include "terrains/terrain.hpp"

namespace ambler::eval {
namespace {

namespace fs = std::filesystem;
constexpr double kDeg = std::numbers::pi / 180.0;

// A generated terrain loaded into MuJoCo and Embree, in a temporary directory.
struct Bench : test::TerrainWorld {
  Bench(const terrains::TerrainSpec& spec, std::uint64_t seed) : TerrainWorld(spec, seed) {}
  // Scan from `view`, map, and score against ground truth.
  MapMetrics run(const perception::SensorModel& sensor, const ViewSpec& view, const MapSpec& map, std::uint64_t seed,
                 perception::ScanMap* keep = nullptr, const perception::LocusConfig* config = nullptr) const {
    const Eigen::Isometry3d T_WS = perception::sensorPose(view.xyz_m, view.rpy_rad);
    const sim::Scan scan = sim::ErimScanner(*scene, sensor).scan(T_WS, seed);
    const auto grid = map.grid();
    const perception::ElevationMap z = truth->elevation(grid);
    const auto vis = truth->visibility(z, T_WS, sensor);
    perception::ScanToMapConfig c = map.scanToMapConfig();
    if (config) c.locus = *config;
    perception::ScanMap b = perception::scanToMap(scan.image, sensor, T_WS, grid, c);
    const MapMetrics m = mapMetrics(b.map, z, vis);
    if (keep) *keep = std::move(b);
    return m;
  }
};

terrains::TerrainSpec ledge() {
  terrains::TerrainSpec t;
  t.kind = terrains::TerrainKind::Steps;
  t.size_m = {20, 20};
  t.cell_m = 0.05;
  t.steps = {{0.0, 0.4}};  // z = 0.4 for x > 0
  return t;
}

// Behind a 0.4 m ledge the locus map marks the range shadow: precision ≥ 0.9 against
// ground-truth visibility, and no truly hidden cell reported known with an error above 3σ_z —
// from several places on the ledge top, noise-free and noisy. Cells where the top may go on
// past its last sample are unseen, never shadow (docs/locus.md): the lip lies anywhere in a gap
// w ≈ ρ²·Δφ/h wide on the ground, so the map gives up to one gap of the shadow's depth S to the
// top, and half a gap at its far end: recall ≥ 1 − 1.5·w/S whatever the lip's place in the gap
// (0.77–0.79 for these views), and noise-free ≥ 0.9 (what the place of the lip in the gap
// gives on average here: 1 − 0.625·w/S ≈ 0.91).
TEST(LocusPipeline, LedgeCastsAShadowThatTheMapFinds) {
  const Bench bench(ledge(), 1);
  struct View {
    Eigen::Vector3d xyz_m, rpy_deg;
  };
  // From the top of the ledge looking down it, towards −x: straight, from higher and lower, and
  // askew.
  for (const View& v : {View{{5, 0, 3.4}, {0, -30, 90}}, View{{4, -1, 4.4}, {0, -40, 80}},
                        View{{7, 1, 2.4}, {0, -18, 100}}}) {
    ViewSpec view;
    view.xyz_m = v.xyz_m;
    view.rpy_rad = v.rpy_deg * kDeg;
    MapSpec map;
    map.cell_m = 0.05;
    map.x_m = {-6, 4};
    map.y_m = {-4, 4};
    for (const bool noisy : {false, true}) {
      perception::SensorModel sensor;
      sensor.mixed_pixels = false;
      if (!noisy) sensor.noise_k = 0, sensor.quantization_m = 0;
      const MapMetrics m = bench.run(sensor, view, map, 3);
      const std::string what = std::string(noisy ? "noisy" : "noise-free") + " from x = " + std::to_string(v.xyz_m.x());
      EXPECT_GT(m.hidden, 500) << what << ": the scene must have a real shadow";
      const double h = v.xyz_m.z() - 0.4, d = v.xyz_m.x();  // above the top; from the lip
      const double w = (h * h + d * d) * (30.0 * kDeg / 64) / h, S = 0.4 * d / h;
      EXPECT_GE(m.shadow_precision, 0.9) << what;
      EXPECT_GE(m.shadow_recall, 1 - 1.5 * w / S) << what;
      if (!noisy) {
        EXPECT_GE(m.shadow_recall, 0.9) << what;
      }
      EXPECT_EQ(m.known_in_shadow_above_3sigma, 0) << what;
      std::printf("ledge %s: hidden %ld, shadow precision %.3f recall %.3f\n", what.c_str(), long(m.hidden),
                  m.shadow_precision, m.shadow_recall);
    }
  }
}

terrains::TerrainSpec fractal() {
  terrains::TerrainSpec t;
  t.kind = terrains::TerrainKind::Fractal;
  t.size_m = {20, 20};
  t.cell_m = 0.05;
  t.relief_m = 0.6;
  t.hurst = 0.7;
  return t;
}

// σ_z is calibrated: on a noisy fractal terrain with quantisation on, 64–72 % of known cells lie
// within 1σ_z of the truth and 93–97 % within 2σ_z (a normal distribution gives 68.3 % and 95.4 %).
TEST(LocusPipeline, SigmaIsCalibratedOnNoisyFractalTerrain) {
  const Bench bench(fractal(), 2);
  perception::SensorModel sensor;  // ERIM defaults: noise k = 3e-4, quantisation 7.62 cm, wrap at 19.5 m
  sensor.mixed_pixels = false;  // a separate effect, outside the σ model (docs/locus.md)
  ViewSpec view;
  view.xyz_m = {0, -6, 3};
  view.rpy_rad = {0, -30 * kDeg, 0};
  MapSpec map;  // the default region and 10 cm cells
  const MapMetrics m = bench.run(sensor, view, map, 5);
  EXPECT_GT(m.compared, 3000);
  EXPECT_GE(m.within_1sigma, 0.64);
  EXPECT_LE(m.within_1sigma, 0.72);
  EXPECT_GE(m.within_2sigma, 0.93);
  EXPECT_LE(m.within_2sigma, 0.97);
  RecordProperty("within_1sigma", std::to_string(m.within_1sigma));
  RecordProperty("within_2sigma", std::to_string(m.within_2sigma));
}

// Monte Carlo: over many noisy scans of the same terrain, each cell's spread of elevations matches
// the noise part of its predicted σ_z (the roughness part is a fixed error of the terrain, the
// same in every scan, so it is switched off here). The sample σ from n = 60 scans has a relative
// standard error of 1/√(2n) ≈ 9 % per cell; averaged over thousands of cells the ratio's mean is
// within a few percent of 1.
TEST(LocusPipeline, SigmaMatchesMonteCarloSpread) {
  const Bench bench(fractal(), 4);
  perception::SensorModel sensor;
  sensor.mixed_pixels = false;
  sensor.quantization_m = 0;  // quantisation is not independent between scans at small noise
  sensor.noise_k = 1e-3;
  ViewSpec view;
  view.xyz_m = {0, -6, 3};
  view.rpy_rad = {0, -30 * kDeg, 0};
  MapSpec map;
  map.shadows = perception::ShadowMethod::None;
  map.cell_m = 0.2;
  const int n = 60;
  const auto grid = map.grid();
  Eigen::ArrayXXd sum = Eigen::ArrayXXd::Zero(grid.rows, grid.cols), sum2 = sum, sigma = sum, count = sum;
  perception::LocusConfig noise_only = map.scanToMapConfig().locus;
  noise_only.roughness = false;
  for (int k = 0; k < n; ++k) {
    perception::ScanMap b;
    bench.run(sensor, view, map, 100 + k, &b, &noise_only);
    for (int r = 0; r < grid.rows; ++r)
      for (int c = 0; c < grid.cols; ++c) {
        if (b.map.stateAt(r, c) != perception::CellState::Known) continue;
        const double z = b.map.elevation()(r, c);
        sum(r, c) += z, sum2(r, c) += z * z, sigma(r, c) += b.map.sigma()(r, c), count(r, c) += 1;
      }
  }
  double ratio_sum = 0;
  int cells = 0;
  for (int r = 0; r < grid.rows; ++r)
    for (int c = 0; c < grid.cols; ++c) {
      if (count(r, c) < n) continue;  // known in every scan
      const double mean = sum(r, c) / n;
      const double spread = std::sqrt(std::max(0.0, (sum2(r, c) / n - mean * mean) * n / (n - 1)));
      ratio_sum += spread / (sigma(r, c) / n);
      ++cells;
    }
  ASSERT_GT(cells, 1000);
  const double ratio = ratio_sum / cells;
  EXPECT_NEAR(ratio, 1.0, 0.1);
  RecordProperty("spread_over_sigma", std::to_string(ratio));
}

// The SIMD lanes (perception/locus_lanes.cpp) repeat the scalar search's operations, so a map
// built with them is the scalar map bit for bit: on Mars-like terrain (rocks, craters, noise,
// quantisation, mixed pixels, GNC edges) from a level and a rolled, yawed sensor, at four cell
// sizes, with the AVX-512 lanes and with the AVX2 ones, as far as the CPU has them. The lanes must
// also have done most of the known cells (else this would compare the scalar search with itself).
TEST(LocusPipeline, LanesGiveTheScalarSearchsBits) {
  terrains::TerrainSpec mars;
  mars.kind = terrains::TerrainKind::Mars;
  const Bench bench(mars, 3);
  perception::SensorModel sensor;  // ERIM defaults: noise, quantisation, wrap, mixed pixels
  for (const Eigen::Vector3d& rpy : {Eigen::Vector3d(0, -30 * kDeg, 0), Eigen::Vector3d(4 * kDeg, -25 * kDeg, 20 * kDeg)}) {
    const sim::Scan scan = sim::ErimScanner(*bench.scene, sensor)
                               .scan(perception::sensorPose({0.5, -6, 3}, rpy), 11);
    MapSpec spec;
    perception::RangeImage image = scan.image;
    perception::unwrapRanges(image, sensor);
    const perception::Raster<std::uint8_t> edges = perception::detectRangeEdges(image, sensor);
    perception::LocusConfig lanes = spec.scanToMapConfig().locus;
    lanes.footprint_sigma = rpy.x() != 0;  // the composite's σ (its own table along scanlines) in one pose
    perception::LocusConfig scalar = lanes;
    scalar.vectorized = false;
    const perception::LocusMapper fast(image, sensor, &edges, lanes), slow(image, sensor, &edges, scalar);
    for (const auto isa : {perception::LaneIsa::Avx512, perception::LaneIsa::Avx2}) {
      const perception::LaneIsaCap cap(isa);
      const auto active = perception::LocusMapper::laneIsa();
      for (const double cell : {0.02, 0.05, 0.10, 0.20}) {
        spec.cell_m = cell;
        const auto grid = spec.grid();
        long by_lanes = -1;
        const auto a = fast.map(grid, &by_lanes), b = slow.map(grid);
        long known = 0, differ = 0;
        for (int r = 0; r < grid.rows; ++r)
          for (int c = 0; c < grid.cols; ++c) {
            const float za = a.elevation()(r, c), zb = b.elevation()(r, c);
            const float sa = a.sigma()(r, c), sb = b.sigma()(r, c);
            const bool same = a.stateAt(r, c) == b.stateAt(r, c) && std::memcmp(&za, &zb, sizeof za) == 0 &&
                              std::memcmp(&sa, &sb, sizeof sa) == 0;
            differ += !same;
            known += a.stateAt(r, c) == perception::CellState::Known;
          }
        const std::string what = "cell " + std::to_string(cell) + " m, lanes " + std::to_string(int(active));
        EXPECT_EQ(differ, 0) << what;
        EXPECT_GT(known, grid.cells() / 3) << what;
        if (active != perception::LaneIsa::None) EXPECT_GT(by_lanes, known / 2) << what;
        else EXPECT_EQ(by_lanes, 0) << what;
      }
    }
  }
}

TEST(LocusPipeline, WrappedFarFieldIsUnwrappedOrUnknown) {
  terrains::TerrainSpec flat;
  flat.kind = terrains::TerrainKind::Fractal;
  flat.size_m = {60, 60};
  flat.cell_m = 0.2;
  flat.relief_m = 0.3;
  const Bench bench(flat, 6);
  perception::SensorModel sensor;
  sensor.mixed_pixels = false;
  ViewSpec view;
  view.xyz_m = {0, -25, 4};
  view.rpy_rad = {0, -12 * kDeg, 0};
  MapSpec map;
  map.cell_m = 0.25;
  map.x_m = {-10, 10};
  map.y_m = {-20, 20};  // ranges from ~7 m out to ~45 m
  perception::ScanMap b;
  const MapMetrics m = bench.run(sensor, view, map, 8, &b);
  EXPECT_LT(m.max_abs_error_m, 1.0) << "a cell was mapped at a wrapped range";
  // Cells beyond the interval that are known are right.
  const auto grid = map.grid();
  const perception::ElevationMap truth_map = bench.truth->elevation(grid);
  const auto& z = truth_map.elevation();
  int far_known = 0;
  for (int r = 0; r < grid.rows; ++r)
    for (int c = 0; c < grid.cols; ++c) {
      const Eigen::Vector2d xy = grid.center(r, c);
      const double range = (Eigen::Vector3d(xy.x(), xy.y(), z(r, c)) - view.xyz_m).norm();
      if (range < 19.5 + 1 || b.map.stateAt(r, c) != perception::CellState::Known) continue;
      ++far_known;
      EXPECT_NEAR(b.map.elevation()(r, c), z(r, c), 0.5);
    }
  RecordProperty("far_known_cells", std::to_string(far_known));
  RecordProperty("unwrapped_pixels", std::to_string(b.unwrapped));
}

}  // namespace
}  // namespace ambler::eval
