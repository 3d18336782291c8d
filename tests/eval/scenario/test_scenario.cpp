#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <bit>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "eval/scenario/scenario.hpp"
#include "scenario_errors.hpp"
#include "perception/sensor_geometry.hpp"

namespace ambler::eval {
namespace {

namespace fs = std::filesystem;
using terrains::TerrainKind;

const fs::path kScenarios = fs::path(AMBLER_SOURCE_DIR) / "scenarios";
using scenario_test::kFile;
const std::string kMinimal = "name: t\nterrain: {kind: plane}\nviews: [{xyz_m: [0, 0, 1]}]\n";

double deg(double d) { return d * std::numbers::pi / 180.0; }
std::uint64_t bits(double v) { return std::bit_cast<std::uint64_t>(v); }

// Bit-for-bit equality of two doubles (distinguishes -0 from 0).
#define EXPECT_SAME(a, b) EXPECT_EQ(bits(a), bits(b)) << #a << " = " << (a) << " vs " << (b)

void expectSame(const Scenario& a, const Scenario& b) {
  EXPECT_EQ(a.file, b.file);
  EXPECT_EQ(a.name, b.name);
  EXPECT_EQ(a.description, b.description);
  EXPECT_EQ(a.seed, b.seed);
  const auto &ta = a.terrain, &tb = b.terrain;
  EXPECT_EQ(ta.kind, tb.kind);
  for (int i = 0; i < 2; ++i) {
    EXPECT_SAME(ta.size_m[i], tb.size_m[i]);
    EXPECT_SAME(ta.slope_deg[i], tb.slope_deg[i]);
  }
  EXPECT_SAME(ta.cell_m, tb.cell_m);
  EXPECT_SAME(ta.relief_m, tb.relief_m);
  EXPECT_SAME(ta.hurst, tb.hurst);
  ASSERT_EQ(ta.sinusoid.has_value(), tb.sinusoid.has_value());
  if (ta.sinusoid) {
    EXPECT_SAME(ta.sinusoid->amplitude_m, tb.sinusoid->amplitude_m);
    EXPECT_SAME(ta.sinusoid->wavelength_m, tb.sinusoid->wavelength_m);
  }
  ASSERT_EQ(ta.steps.size(), tb.steps.size());
  for (std::size_t i = 0; i < ta.steps.size(); ++i) {
    EXPECT_SAME(ta.steps[i].x_m, tb.steps[i].x_m);
    EXPECT_SAME(ta.steps[i].height_m, tb.steps[i].height_m);
  }
  ASSERT_EQ(ta.rocks.has_value(), tb.rocks.has_value());
  if (ta.rocks) {
    EXPECT_SAME(ta.rocks->abundance_k, tb.rocks->abundance_k);
    EXPECT_SAME(ta.rocks->min_diameter_m, tb.rocks->min_diameter_m);
    EXPECT_SAME(ta.rocks->max_diameter_m, tb.rocks->max_diameter_m);
  }
  ASSERT_EQ(ta.craters.has_value(), tb.craters.has_value());
  if (ta.craters) {
    EXPECT_EQ(ta.craters->count, tb.craters->count);
    EXPECT_SAME(ta.craters->min_diameter_m, tb.craters->min_diameter_m);
    EXPECT_SAME(ta.craters->max_diameter_m, tb.craters->max_diameter_m);
    EXPECT_SAME(ta.craters->sfd_exponent, tb.craters->sfd_exponent);
  }
  EXPECT_EQ(ta.mjcf, tb.mjcf);

  const auto &sa = a.sensor, &sb = b.sensor;
  EXPECT_EQ(sa.rows, sb.rows);
  EXPECT_EQ(sa.cols, sb.cols);
  EXPECT_SAME(sa.fov_v_rad, sb.fov_v_rad);
  EXPECT_SAME(sa.fov_h_rad, sb.fov_h_rad);
  EXPECT_SAME(sa.noise_k, sb.noise_k);
  EXPECT_SAME(sa.quantization_m, sb.quantization_m);
  EXPECT_SAME(sa.ambiguity_m, sb.ambiguity_m);
  EXPECT_EQ(sa.mixed_pixels, sb.mixed_pixels);
  EXPECT_SAME(sa.max_range_m, sb.max_range_m);
  EXPECT_SAME(sa.beam_divergence_rad, sb.beam_divergence_rad);
  EXPECT_SAME(sa.dropout, sb.dropout);

  ASSERT_EQ(a.views.size(), b.views.size());
  for (std::size_t v = 0; v < a.views.size(); ++v) {
    for (int i = 0; i < 3; ++i) {
      EXPECT_SAME(a.views[v].xyz_m[i], b.views[v].xyz_m[i]);
      EXPECT_SAME(a.views[v].rpy_rad[i], b.views[v].rpy_rad[i]);
    }
  }

  ASSERT_EQ(a.map.has_value(), b.map.has_value());
  if (a.map) {
    EXPECT_SAME(a.map->cell_m, b.map->cell_m);
    for (int i = 0; i < 2; ++i) {
      EXPECT_SAME(a.map->x_m[i], b.map->x_m[i]);
      EXPECT_SAME(a.map->y_m[i], b.map->y_m[i]);
    }
    EXPECT_SAME(a.map->epsilon_rad, b.map->epsilon_rad);
    EXPECT_EQ(a.map->shadows, b.map->shadows);
    EXPECT_EQ(a.map->baseline, b.map->baseline);
  }
  ASSERT_EQ(a.matching.has_value(), b.matching.has_value());
  if (a.matching) {
    EXPECT_EQ(a.matching->pairs, b.matching->pairs);
    EXPECT_EQ(a.matching->methods, b.matching->methods);
    for (int i = 0; i < 3; ++i) {
      EXPECT_SAME(a.matching->initial_error.xyz_m[i], b.matching->initial_error.xyz_m[i]);
      EXPECT_SAME(a.matching->initial_error.rpy_rad[i], b.matching->initial_error.rpy_rad[i]);
    }
    EXPECT_SAME(a.matching->success_translation_m, b.matching->success_translation_m);
    EXPECT_SAME(a.matching->success_rotation_deg, b.matching->success_rotation_deg);
    EXPECT_SAME(a.matching->prior_translation_m, b.matching->prior_translation_m);
    EXPECT_SAME(a.matching->prior_rotation_deg, b.matching->prior_rotation_deg);
  }
  ASSERT_EQ(a.traverse.has_value(), b.traverse.has_value());
  if (a.traverse) {
    const TraverseSpec &ta = *a.traverse, &tb = *b.traverse;
    ASSERT_EQ(ta.waypoints_xy_m.size(), tb.waypoints_xy_m.size());
    for (std::size_t k = 0; k < ta.waypoints_xy_m.size(); ++k)
      for (int i = 0; i < 2; ++i) EXPECT_SAME(ta.waypoints_xy_m[k][i], tb.waypoints_xy_m[k][i]);
    EXPECT_SAME(ta.stop_spacing_m, tb.stop_spacing_m);
    EXPECT_SAME(ta.footprint_radius_m, tb.footprint_radius_m);
    EXPECT_SAME(ta.mount.height_m, tb.mount.height_m);
    EXPECT_SAME(ta.mount.pitch_rad, tb.mount.pitch_rad);
    EXPECT_SAME(ta.odometry.translation_sigma_per_m, tb.odometry.translation_sigma_per_m);
    EXPECT_SAME(ta.odometry.heading_sigma_deg_per_m, tb.odometry.heading_sigma_deg_per_m);
    EXPECT_SAME(ta.odometry.translation_bias, tb.odometry.translation_bias);
    EXPECT_SAME(ta.odometry.heading_bias_deg_per_m, tb.odometry.heading_bias_deg_per_m);
    EXPECT_EQ(ta.reg, tb.reg);
    EXPECT_EQ(ta.method, tb.method);
  }
}

// parseScenario(resolvedYaml(s)) == s, and resolving again changes nothing.
void expectRoundTrip(const Scenario& s) {
  const std::string resolved = resolvedYaml(s);
  SCOPED_TRACE(resolved);
  const Scenario back = parseScenario(resolved, s.file);
  expectSame(s, back);
  EXPECT_EQ(resolvedYaml(back), resolved);
}

using scenario_test::errorOf;
using scenario_test::expectError;

// A scratch directory removed at the end of the test.
struct TempDir {
  fs::path path;
  TempDir() {
    path = fs::temp_directory_path() /
           ("ambler_test_scenario_" + std::to_string(std::random_device{}()));
    fs::create_directories(path);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};

// ---------------------------------------------------------------------------------------------
// The example scenarios

TEST(ScenarioExamples, EveryExampleLoadsAndRoundTrips) {
  std::set<std::string> names;
  for (const auto& entry : fs::directory_iterator(kScenarios)) {
    // Sweep files may live beside the scenarios; they are not scenarios.
    const std::string filename = entry.path().filename().string();
    if (entry.path().extension() != ".yaml" || filename.find("sweep") != std::string::npos)
      continue;
    SCOPED_TRACE(entry.path().string());
    const Scenario s = loadScenario(entry.path());
    EXPECT_EQ(s.file, entry.path());
    names.insert(entry.path().stem().string());
    expectRoundTrip(s);
  }
  for (const char* name : {"demo", "plane", "ledge", "mars", "dem", "traverse"})
    EXPECT_TRUE(names.count(name)) << name;
}

TEST(ScenarioExamples, DemoIsTheDocumentedOne) {
  const Scenario s = loadScenario(kScenarios / "demo.yaml");
  EXPECT_EQ(s.terrain.kind, TerrainKind::Mars);
  EXPECT_EQ(s.terrain.size_m, Eigen::Vector2d(20, 20));
  EXPECT_EQ(s.terrain.cell_m, 0.05);
  ASSERT_TRUE(s.terrain.rocks);
  EXPECT_EQ(s.terrain.rocks->abundance_k, 0.08);
  ASSERT_TRUE(s.terrain.craters);
  EXPECT_EQ(s.terrain.craters->count, 4);
  ASSERT_EQ(s.views.size(), 2u);
  EXPECT_EQ(s.views[0].xyz_m, Eigen::Vector3d(0, -6, 3));
  EXPECT_EQ(s.views[0].rpy_rad, Eigen::Vector3d(0, deg(-30), 0));
  EXPECT_EQ(s.views[1].xyz_m, Eigen::Vector3d(0, -5, 3));
  EXPECT_EQ(s.views[1].rpy_rad, Eigen::Vector3d(0, deg(-30), deg(5)));
  ASSERT_TRUE(s.map);
  EXPECT_EQ(s.map->cell_m, 0.10);
  EXPECT_EQ(s.map->x_m, Eigen::Vector2d(-5, 5));
  EXPECT_EQ(s.map->y_m, Eigen::Vector2d(-3, 8));
  EXPECT_EQ(s.map->epsilon_rad, 1.0e-5);
  EXPECT_EQ(s.map->shadows, perception::ShadowMethod::Gnc);
  EXPECT_EQ(s.map->baseline, Baseline::Cartesian);
  // The sensor block is the ERIM defaults written out.
  const perception::SensorModel erim;
  EXPECT_EQ(s.sensor.rows, erim.rows);
  EXPECT_EQ(s.sensor.cols, erim.cols);
  EXPECT_EQ(s.sensor.fov_v_rad, erim.fov_v_rad);
  EXPECT_EQ(s.sensor.fov_h_rad, erim.fov_h_rad);
  EXPECT_EQ(s.sensor.noise_k, erim.noise_k);
  EXPECT_EQ(s.sensor.quantization_m, erim.quantization_m);
  EXPECT_EQ(s.sensor.ambiguity_m, erim.ambiguity_m);
  EXPECT_EQ(s.sensor.mixed_pixels, erim.mixed_pixels);
  EXPECT_EQ(s.sensor.max_range_m, erim.max_range_m);
}

// The ledge example must show a shadow: the sight line over the edge is inside the field of view
// and lands on the low ground inside the map region, leaving a strip behind the edge hidden.
TEST(ScenarioExamples, LedgeEdgeCastsAShadowInsideTheMap) {
  const Scenario s = loadScenario(kScenarios / "ledge.yaml");
  ASSERT_EQ(s.terrain.kind, TerrainKind::Steps);
  ASSERT_EQ(s.terrain.steps.size(), 1u);
  const double edge_x = s.terrain.steps[0].x_m;
  const double height = s.terrain.steps[0].height_m;
  EXPECT_EQ(height, 0.4);
  const Eigen::Vector3d p = s.views[0].xyz_m;
  const Eigen::Vector3d rpy = s.views[0].rpy_rad;
  ASSERT_GT(p.x(), edge_x);  // on the top, looking back over the edge
  // R = Rz(yaw)·Ry(roll)·Rx(pitch), docs/scenario.md ("views").
  const Eigen::Matrix3d r = (Eigen::AngleAxisd(rpy.z(), Eigen::Vector3d::UnitZ()) *
                             Eigen::AngleAxisd(rpy.x(), Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(rpy.y(), Eigen::Vector3d::UnitX()))
                                .toRotationMatrix();
  const Eigen::Vector3d edge(edge_x, 0.0, height);
  const Eigen::Vector3d d = r.transpose() * (edge - p);  // sensor frame: x right, y forward, z up
  const double theta = std::asin(d.x() / d.norm());      // eq. 1
  const double phi = std::atan2(d.z(), d.y());
  EXPECT_GT(d.y(), 0.0);
  EXPECT_LT(std::abs(phi), s.sensor.fov_v_rad / 2);
  EXPECT_LT(std::abs(theta), s.sensor.fov_h_rad / 2);
  // The grazing ray continues to z = 0 at x = edge − height·(p.x − edge)/(p.z − height).
  const double shadow_end = edge_x - height * (p.x() - edge_x) / (p.z() - height);
  EXPECT_NEAR(shadow_end, -0.4 * 5.0 / 3.0, 1e-12);
  ASSERT_TRUE(s.map);
  EXPECT_LT(s.map->x_m[0], shadow_end);
  EXPECT_GT(s.map->x_m[1], edge_x);
  EXPECT_GT(edge_x - shadow_end, 10 * s.map->cell_m);  // many cells deep
}

// ---------------------------------------------------------------------------------------------
// Defaults

TEST(ScenarioDefaults, SensorDefaultsAreTheErimValues) {
  for (const std::string extra : {"", "sensor: {}\n"}) {
    const Scenario s = parseScenario(kMinimal + extra, kFile);
    EXPECT_EQ(s.sensor.rows, 64);
    EXPECT_EQ(s.sensor.cols, 256);
    EXPECT_SAME(s.sensor.fov_v_rad, 30.0 * std::numbers::pi / 180.0);
    EXPECT_SAME(s.sensor.fov_h_rad, 80.0 * std::numbers::pi / 180.0);
    EXPECT_EQ(s.sensor.noise_k, 0.0003);
    EXPECT_EQ(s.sensor.quantization_m, 0.0762);
    EXPECT_EQ(s.sensor.ambiguity_m, 19.5);
    EXPECT_TRUE(s.sensor.mixed_pixels);
    EXPECT_EQ(s.sensor.max_range_m, 40.0);
    EXPECT_EQ(s.sensor.beam_divergence_rad, 0.0);
    EXPECT_EQ(s.sensor.dropout, 0.0);
  }
  // Writing the defaults out gives the same radians as leaving them out.
  const Scenario written = parseScenario(kMinimal + "sensor: {fov_deg: [30, 80]}\n", kFile);
  EXPECT_SAME(written.sensor.fov_v_rad, perception::SensorModel{}.fov_v_rad);
  EXPECT_SAME(written.sensor.fov_h_rad, perception::SensorModel{}.fov_h_rad);
}

// The rover's prior by default (matching.prior absent), which feature matching's search is held
// to, covers every error the scenario allows: each coordinate within 3 m (the box's diagonal,
// 3√3 m) and each angle within 30°, whose rotation is R = Rz(yaw)·Ry(roll)·Rx(pitch) with trace
// ca·cb + ca·cc + cb·cc + sa·sb·sc; at a corner with an odd number of −30° that is 3·(3/4) − 1/8,
// so the widest turn is acos((2.125 − 1)/2) = acos(9/16) = 55.77°, not 30°. Sampled errors inside
// the box never turn further, and the corners reach it.
TEST(ScenarioDefaults, RegistrationPriorCoversEveryAllowedError) {
  const perception::RegistrationConfig c = registrationConfig(parseScenario(kMinimal, kFile));
  const double widest_deg = std::acos(9.0 / 16.0) * 180 / std::numbers::pi;
  EXPECT_NEAR(c.prior_rotation_deg, widest_deg, 1e-9);
  EXPECT_NEAR(c.prior_translation_m, 3 * std::sqrt(3.0), 1e-12);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> angle(-30, 30);
  double most = 0;
  for (int k = 0; k < 20000; ++k) {
    const Eigen::Vector3d rpy(angle(rng), angle(rng), angle(rng));
    const double turn =
        Eigen::AngleAxisd(perception::sensorPose(Eigen::Vector3d::Zero(), rpy * std::numbers::pi / 180).linear()).angle();
    most = std::max(most, turn * 180 / std::numbers::pi);
  }
  EXPECT_LE(most, c.prior_rotation_deg + 1e-9);
  EXPECT_GT(most, 45.0);  // sampled errors turn well past 30°: a prior of 30° would not cover them
  const double corner = Eigen::AngleAxisd(perception::sensorPose(Eigen::Vector3d::Zero(),
                                                                 Eigen::Vector3d(-30, -30, -30) * std::numbers::pi / 180)
                                              .linear())
                            .angle();
  EXPECT_NEAR(corner * 180 / std::numbers::pi, widest_deg, 1e-9);
}

TEST(ScenarioDefaults, OtherDefaultsAreTheDocumentedOnes) {
  const Scenario s = parseScenario(kMinimal, kFile);
  EXPECT_EQ(s.seed, 0u);
  EXPECT_EQ(s.description, "");
  EXPECT_FALSE(s.map);  // no map: section, no maps
  EXPECT_EQ(s.views[0].rpy_rad, Eigen::Vector3d::Zero());
  const terrains::TerrainSpec t;
  EXPECT_EQ(s.terrain.size_m, Eigen::Vector2d(20, 20));
  EXPECT_EQ(s.terrain.size_m, t.size_m);
  EXPECT_EQ(s.terrain.cell_m, 0.05);
  EXPECT_EQ(s.terrain.relief_m, 0.6);
  EXPECT_EQ(s.terrain.hurst, 0.7);
  EXPECT_EQ(s.terrain.slope_deg, Eigen::Vector2d::Zero());
  EXPECT_FALSE(s.terrain.sinusoid);
  EXPECT_TRUE(s.terrain.steps.empty());
  EXPECT_FALSE(s.terrain.rocks);
  EXPECT_FALSE(s.terrain.craters);

  const Scenario m = parseScenario(kMinimal + "map: {}\n", kFile);
  ASSERT_TRUE(m.map);
  EXPECT_EQ(m.map->cell_m, 0.10);
  EXPECT_EQ(m.map->x_m, Eigen::Vector2d(-5, 5));
  EXPECT_EQ(m.map->y_m, Eigen::Vector2d(-3, 8));
  EXPECT_EQ(m.map->epsilon_rad, 1.0e-5);
  EXPECT_EQ(m.map->shadows, perception::ShadowMethod::Gnc);
  EXPECT_EQ(m.map->baseline, Baseline::Cartesian);
  // gnc leaves the detector's and the mapper's defaults; gnc_bridge sets its three settings.
  const perception::ScanToMapConfig plain = m.map->scanToMapConfig();
  EXPECT_EQ(plain.gnc.occlusion_depth_k, 0.0);
  EXPECT_FALSE(plain.locus.bridge_sigma);
  EXPECT_EQ(plain.locus.far_gap_scanlines, 0.5);
  const Scenario b = parseScenario(kMinimal + "map: {shadows: gnc_bridge}\n", kFile);
  EXPECT_EQ(b.map->shadows, perception::ShadowMethod::GncBridge);
  const perception::ScanToMapConfig bridged = b.map->scanToMapConfig();
  EXPECT_EQ(bridged.shadows, perception::ShadowMethod::GncBridge);
  EXPECT_EQ(bridged.gnc.occlusion_depth_k, perception::kBridgeDepthK);
  EXPECT_TRUE(bridged.locus.bridge_sigma);
  EXPECT_EQ(bridged.locus.far_gap_scanlines, 1.0);
  EXPECT_TRUE(locusConfig(b).bridge_sigma) << "the match and merge stages map with the same σ";

  const Scenario r = parseScenario(
      "name: t\nterrain: {kind: mars, rocks: {}, craters: {}}\nviews: [{xyz_m: [0, 0, 1]}]\n",
      kFile);
  ASSERT_TRUE(r.terrain.rocks && r.terrain.craters);
  EXPECT_EQ(r.terrain.rocks->abundance_k, 0.10);
  EXPECT_EQ(r.terrain.rocks->min_diameter_m, 0.1);
  EXPECT_EQ(r.terrain.rocks->max_diameter_m, 1.0);
  EXPECT_EQ(r.terrain.craters->count, 4);
  EXPECT_EQ(r.terrain.craters->min_diameter_m, 1.0);
  EXPECT_EQ(r.terrain.craters->max_diameter_m, 5.0);
  EXPECT_EQ(r.terrain.craters->sfd_exponent, 2.0);
}

// A kind that needs a section gets the default one, so the terrain builder never guesses and the
// resolved file shows what is built.
TEST(ScenarioDefaults, KindsFillInTheSectionTheyNeed) {
  const Scenario mars =
      parseScenario("name: t\nterrain: {kind: mars}\nviews: [{xyz_m: [0, 0, 1]}]\n", kFile);
  ASSERT_TRUE(mars.terrain.rocks && mars.terrain.craters);
  EXPECT_EQ(mars.terrain.rocks->abundance_k, 0.10);
  EXPECT_EQ(mars.terrain.craters->count, 4);
  const Scenario fractal =
      parseScenario("name: t\nterrain: {kind: fractal}\nviews: [{xyz_m: [0, 0, 1]}]\n", kFile);
  EXPECT_FALSE(fractal.terrain.rocks || fractal.terrain.craters);
  expectRoundTrip(mars);
  const Scenario sin =
      parseScenario("name: t\nterrain: {kind: sinusoid}\nviews: [{xyz_m: [0, 0, 1]}]\n", kFile);
  ASSERT_TRUE(sin.terrain.sinusoid);
  EXPECT_EQ(sin.terrain.sinusoid->amplitude_m, 0.05);
  EXPECT_EQ(sin.terrain.sinusoid->wavelength_m, 0.4);
  const Scenario steps =
      parseScenario("name: t\nterrain: {kind: steps}\nviews: [{xyz_m: [0, 0, 1]}]\n", kFile);
  ASSERT_EQ(steps.terrain.steps.size(), 1u);
  EXPECT_EQ(steps.terrain.steps[0].x_m, 2.0);
  EXPECT_EQ(steps.terrain.steps[0].height_m, 0.4);
  expectRoundTrip(sin);
  expectRoundTrip(steps);
}

TEST(ScenarioDefaults, ResolvedYamlWritesEveryKey) {
  const std::string y = resolvedYaml(parseScenario(kMinimal + "map: {}\n", kFile));
  for (const char* key : {"name: \"t\"",
                          "description: \"\"",
                          "seed: 0",
                          "kind: plane",
                          "size_m: [20, 20]",
                          "cell_m: 0.05",
                          "relief_m: 0.6",
                          "hurst: 0.7",
                          "slope_deg: [0, 0]",
                          "steps: []",
                          "rows: 64",
                          "cols: 256",
                          "fov_deg: [30, 80]",
                          "noise_k: 0.0003",
                          "quantization_m: 0.0762",
                          "ambiguity_m: 19.5",
                          "mixed_pixels: true",
                          "max_range_m: 40",
                          "beam_divergence_deg: 0",
                          "dropout: 0",
                          "- {xyz_m: [0, 0, 1], rpy_deg: [0, 0, 0]}",
                          "cell_m: 0.1",
                          "region: {x_m: [-5, 5], y_m: [-3, 8]}",
                          "epsilon_rad: 1e-05",
                          "shadows: gnc",
                          "baseline: cartesian"}) {
    EXPECT_NE(y.find(key), std::string::npos) << key << "\n" << y;
  }
}

// ---------------------------------------------------------------------------------------------
// Round trips of values

// Degrees become radians once (deg·π/180); the resolved file must write degree text that gives
// the very same radians back, and the text the user wrote when it was short.
TEST(ScenarioRoundTrip, DegreesReadBackBitForBit) {
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> angle(-360.0, 360.0), fov(1e-3, 179.999);
  std::uniform_int_distribution<int> tenths(-3600, 3600);
  for (int i = 0; i < 2000; ++i) {
    char text[64];
    if (i % 2 == 0) {
      std::snprintf(text, sizeof text, "%.17g", angle(rng));
    } else {
      std::snprintf(text, sizeof text, "%g", tenths(rng) / 10.0);
    }
    const std::string yaml = "name: t\nterrain: {kind: plane}\nsensor: {fov_deg: [" +
                             std::to_string(fov(rng)) + ", 80], beam_divergence_deg: 0.3}\n" +
                             "views: [{xyz_m: [0, 0, 1], rpy_deg: [0, " + text + ", -0]}]\n";
    const Scenario s = parseScenario(yaml, kFile);
    expectRoundTrip(s);
    if (i % 2 == 1) {
      EXPECT_NE(resolvedYaml(s).find(std::string("rpy_deg: [0, ") + text + ", -0]"),
                std::string::npos)
          << text;
    }
    if (HasFailure()) break;
  }
}

// Radians set in code (not from a degree in a file) have no exact degree text in general; the
// resolved file then writes the nearest, which reads back within one ulp.
TEST(ScenarioRoundTrip, RadiansSetInCodeReadBackWithinOneUlp) {
  Scenario s = parseScenario(kMinimal, kFile);
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> angle(-6.0, 6.0);
  for (int i = 0; i < 1000; ++i) {
    s.views[0].rpy_rad = {angle(rng), angle(rng), angle(rng)};
    const Scenario back = parseScenario(resolvedYaml(s), kFile);
    for (int k = 0; k < 3; ++k) {
      const double a = s.views[0].rpy_rad[k], b = back.views[0].rpy_rad[k];
      EXPECT_LE(std::abs(a - b), std::nextafter(std::abs(a), 10.0) - std::abs(a)) << a;
    }
  }
}

TEST(ScenarioRoundTrip, NumbersReadBackBitForBit) {
  std::mt19937_64 rng(3);
  Scenario s = parseScenario(kMinimal + "map: {}\n", kFile);
  for (int i = 0; i < 500; ++i) {
    // Any finite double survives, including subnormals and -0.
    const std::uint64_t raw = rng();
    double any = std::bit_cast<double>(raw);
    if (!std::isfinite(any)) any = -0.0;
    // x and y must lie over the terrain (the reader refuses a view outside it); z is free.
    s.views[0].xyz_m = {std::ldexp(double(rng() % 1000), -1070), -0.0, any};
    s.seed = rng();
    s.terrain.cell_m = std::uniform_real_distribution<double>(0.01, 1.0)(rng);
    s.map->epsilon_rad = std::uniform_real_distribution<double>(1e-12, 1e-3)(rng);
    expectRoundTrip(s);
    if (HasFailure()) break;
  }
}

TEST(ScenarioRoundTrip, StringsSurviveQuoting) {
  Scenario s = parseScenario(kMinimal, kFile);
  for (const std::string& text : std::vector<std::string>{
           "plain", "with: colon # and hash", "quote \" backslash \\ tab \t newline \n end", "null",
           "true", "- dash", "Mars ~ ünïcödé °", std::string("nul\0byte", 8), "\x7f\x01"}) {
    s.description = text;
    expectRoundTrip(s);
  }
  for (const char* name : {"null", "true", "123", "-", "a-b_c"}) {
    s.name = name;
    expectRoundTrip(s);
  }
}

TEST(ScenarioRoundTrip, MjcfPathIsResolvedAgainstTheScenarioDirectory) {
  const TempDir dir;
  fs::create_directories(dir.path / "worlds");
  std::ofstream(dir.path / "worlds" / "lab.xml") << "<mujoco/>\n";
  const fs::path file = dir.path / "lab.yaml";
  std::ofstream(file) << "name: lab\nterrain: {kind: mjcf, mjcf: worlds/../worlds/lab.xml}\n"
                         "views: [{xyz_m: [0, 0, 1]}]\n";
  const Scenario s = loadScenario(file);
  EXPECT_EQ(fs::path(s.terrain.mjcf),
            (fs::absolute(dir.path) / "worlds" / "lab.xml").lexically_normal());
  expectRoundTrip(s);
}

TEST(ScenarioRoundTrip, DemPathAndKeysReadBack) {
  const TempDir dir;
  fs::create_directories(dir.path / "dems");
  std::ofstream(dir.path / "dems" / "a.tif") << "not read by the scenario reader\n";
  const fs::path file = dir.path / "d.yaml";
  // window_m and resample_m are the DEM-side names of size_m and cell_m.
  std::ofstream(file) << "name: d\nterrain: {kind: dem, dem: dems/../dems/a.tif, window_m: [12, 8], resample_m: 0.1}\n"
                         "views: [{xyz_m: [0, 0, 1]}]\n";
  const Scenario s = loadScenario(file);
  EXPECT_EQ(fs::path(s.terrain.dem), (fs::absolute(dir.path) / "dems" / "a.tif").lexically_normal());
  EXPECT_EQ(s.terrain.size_m, Eigen::Vector2d(12, 8));
  EXPECT_EQ(s.terrain.cell_m, 0.1);
  EXPECT_FALSE(s.terrain.dem_centre_m);
  EXPECT_FALSE(s.terrain.dem_vertical_offset_m);
  const std::string resolved = resolvedYaml(s);
  EXPECT_NE(resolved.find("  window_m: [12, 8]\n  resample_m: 0.1\n"), std::string::npos) << resolved;
  expectRoundTrip(s);
  // The same from another directory: the stored path is absolute.
  EXPECT_EQ(parseScenario(resolved, "elsewhere/r.yaml").terrain.dem, s.terrain.dem);
  std::ofstream(file) << "name: d\nterrain: {kind: dem, dem: dems/a.tif, size_m: [12, 8], window_m: [12, 8], "
                         "centre_m: [4000.5, 1093000.25], vertical_offset_m: -2560.125}\nviews: [{xyz_m: [0, 0, 1]}]\n";
  const Scenario c = loadScenario(file);
  EXPECT_EQ(*c.terrain.dem_centre_m, Eigen::Vector2d(4000.5, 1093000.25));
  EXPECT_EQ(*c.terrain.dem_vertical_offset_m, -2560.125);
  expectRoundTrip(c);
}

TEST(ScenarioErrors, DemKeysAndTheirTwins) {
  const TempDir dir;
  std::ofstream(dir.path / "a.tif") << "x\n";
  const auto error = [&](const std::string& terrain) {
    try {
      parseScenario("name: t\nterrain: " + terrain + "\nviews: [{xyz_m: [0, 0, 1]}]\n", dir.path / "x.yaml");
    } catch (const ScenarioError& e) {
      std::string m = e.what();
      return m.substr(m.find(": ") + 2);
    }
    return std::string("(accepted)");
  };
  EXPECT_EQ(error("{kind: plane, window_m: [3, 3]}"), "terrain.window_m: only allowed with kind: dem (kind is plane)");
  EXPECT_EQ(error("{kind: mars, dem: a.tif}"), "terrain.dem: only allowed with kind: dem (kind is mars)");
  EXPECT_EQ(error("{kind: dem}"), "terrain.dem: missing required key");
  EXPECT_EQ(error("{kind: dem, dem: ''}"), "terrain.dem: expected the path of a GeoTIFF DEM, got ''");
  EXPECT_EQ(error("{kind: dem, dem: a.tif, size_m: [20, 20], window_m: [30, 20]}"),
            "terrain.window_m: expected size_m ([20, 20]) or nothing: the DEM window is the terrain's extent, got "
            "[30, 20]");
  EXPECT_EQ(error("{kind: dem, dem: a.tif, cell_m: 0.05, resample_m: 0.1}"),
            "terrain.resample_m: expected cell_m (0.05) or nothing: the DEM is resampled at the heightfield's "
            "spacing, got 0.1");
  EXPECT_EQ(error("{kind: dem, dem: a.tif, resample_m: 2}"), "terrain.resample_m: expected a number in (0, 1], got 2");
  EXPECT_EQ(error("{kind: dem, dem: a.tif, centre_m: [1, .nan]}"),
            "terrain.centre_m[1]: expected a finite number, got .nan");
  EXPECT_EQ(error("{kind: dem, dem: a.tif, size_m: [20, 20], window_m: [20, 20], cell_m: 0.1, resample_m: 0.1}"),
            "(accepted)");
  // Views stand over the window, as over any generated terrain.
  try {
    parseScenario("name: t\nterrain: {kind: dem, dem: a.tif, window_m: [6, 6]}\nviews: [{xyz_m: [4, 0, 1]}]\n",
                  dir.path / "x.yaml");
    ADD_FAILURE() << "accepted";
  } catch (const ScenarioError& e) {
    EXPECT_NE(std::string(e.what()).find("views[0].xyz_m: expected x in [-3, 3] and y in [-3, 3]"), std::string::npos)
        << e.what();
  }
}

// ---------------------------------------------------------------------------------------------
// Errors: one line, "<file>: <key path>: <what is wrong>"

TEST(ScenarioErrors, MissingFile) {
  const fs::path missing = "/nonexistent_ambler_dir/x.yaml";
  try {
    loadScenario(missing);
    FAIL() << "no error";
  } catch (const ScenarioError& e) {
    EXPECT_EQ(std::string(e.what()), missing.string() + ": cannot open file");
  }
  const TempDir dir;
  try {
    loadScenario(dir.path);
    FAIL() << "no error";
  } catch (const ScenarioError& e) {
    EXPECT_EQ(std::string(e.what()), dir.path.string() + ": cannot open file");
  }
}

TEST(ScenarioErrors, YamlSyntaxNamesTheLine) {
  expectError("name: t\nterrain: {kind: plane\nviews: []\n", "line 3, column 6",
              "YAML syntax error: end of map flow not found");
  expectError("name: t\n  bad: indent\n", "line 2, column 6",
              "YAML syntax error: illegal map value");
}

TEST(ScenarioErrors, UnknownKeysEverywhere) {
  expectError("name: t\nterrain: {kind: plane, relif_m: 1}\nviews: [{xyz_m: [0, 0, 1]}]\n",
              "terrain.relif_m", "unknown key (did you mean relief_m?)");
  expectError(kMinimal + "sensor: {max_range: 30}\n", "sensor.max_range",
              "unknown key (did you mean max_range_m?)");
  expectError("name: t\nterrain: {kind: plane}\nviews: [{xyz_m: [0, 0, 1], rpy_rad: [0, 0, 0]}]\n",
              "views[0].rpy_rad", "unknown key (did you mean rpy_deg?)");
  expectError(kMinimal + "map: {region: {x_m: [0, 1], z_m: [0, 1]}}\n", "map.region.z_m",
              "unknown key");
  expectError(kMinimal + "colour: red\n", "colour",
              "unknown key (allowed: name, description, seed, terrain, sensor, views, traverse, map, matching, merge, footfall, "
              "leg)");
  expectError(
      "name: t\nterrain: {kind: plane, rocks: {abundance: 0.1}}\nviews: [{xyz_m: [0, 0, 1]}]\n",
      "terrain.rocks.abundance", "did you mean abundance_k?");
  expectError(
      "name: t\nterrain: {kind: steps, steps: [{x_m: 1, h: 2}]}\nviews: [{xyz_m: [0, 0, 1]}]\n",
      "terrain.steps[0].h", "unknown key");
}

TEST(ScenarioErrors, MissingRequiredKeys) {
  expectError("name: t\nterrain: {size_m: [1, 1]}\nviews: [{xyz_m: [0, 0, 1]}]\n", "terrain.kind",
              "missing required key");
  expectError("terrain: {kind: plane}\nviews: [{xyz_m: [0, 0, 1]}]\n", "name",
              "missing required key");
  expectError("name: t\nviews: [{xyz_m: [0, 0, 1]}]\n", "terrain", "missing required key");
  expectError("name: t\nterrain: {kind: plane}\n", "views", "missing required key");
  expectError(
      "name: t\nterrain: {kind: plane}\nviews: [{xyz_m: [0, 0, 1]}, {rpy_deg: [0, 0, 0]}]\n",
      "views[1].xyz_m", "missing required key");
  expectError("name: t\nterrain: {kind: mjcf}\nviews: [{xyz_m: [0, 0, 1]}]\n", "terrain.mjcf",
              "missing required key");
}

TEST(ScenarioErrors, WrongTypes) {
  expectError(kMinimal + "sensor: {mixed_pixels: maybe}\n", "sensor.mixed_pixels",
              "expected true or false, got 'maybe'");
  expectError(kMinimal + "sensor: {noise_k: low}\n", "sensor.noise_k",
              "expected a number >= 0, got 'low'");
  expectError(kMinimal + "sensor: {max_range_m: \"40\"}\n", "sensor.max_range_m",
              "expected a number > 0, got the string '40'");
  expectError(kMinimal + "sensor: [64, 256]\n", "sensor", "expected a mapping, got a list of 2");
  expectError(kMinimal + "sensor:\n", "sensor", "expected a mapping, got nothing");
  expectError(kMinimal + "map: {shadows: yes}\n", "map.shadows",
              "expected one of gnc, gnc_bridge, none, got 'yes'");
  expectError("name: t\nterrain: {kind: fractl}\nviews: [{xyz_m: [0, 0, 1]}]\n", "terrain.kind",
              "expected one of plane, fractal, sinusoid, steps, mars, mjcf, dem, got 'fractl' (did you "
              "mean fractal?)");
  expectError("name: t\nterrain: {kind: plane}\nviews: {xyz_m: [0, 0, 1]}\n", "views",
              "expected a non-empty list of views, got a mapping");
  expectError("name: [t]\nterrain: {kind: plane}\nviews: [{xyz_m: [0, 0, 1]}]\n", "name",
              "expected a string, got a list of 1");
}

TEST(ScenarioErrors, IntegersMustBeIntegers) {
  expectError(kMinimal + "sensor: {rows: 2.5}\n", "sensor.rows",
              "expected an integer in [1, 4096], got 2.5");
  expectError(
      "name: t\nterrain: {kind: mars, craters: {count: 1e2}}\nviews: [{xyz_m: [0, 0, 1]}]\n",
      "terrain.craters.count", "expected an integer in [0, 1000], got 1e2");
  expectError(kMinimal + "seed: -1\n", "seed", "expected an integer in [0, 2^64 - 1], got -1");
  expectError(kMinimal + "seed: 7.0\n", "seed", "expected an integer");
  EXPECT_EQ(parseScenario(kMinimal + "seed: 18446744073709551615\n", kFile).seed,
            18446744073709551615u);
}

TEST(ScenarioErrors, OutOfRange) {
  EXPECT_EQ(errorOf(kMinimal + "sensor: {rows: 0}\n"),
            "scenarios/x.yaml: sensor.rows: expected an integer in [1, 4096], got 0");
  expectError(kMinimal + "sensor: {cols: 16385}\n", "sensor.cols",
              "expected an integer in [1, 16384]");
  EXPECT_EQ(parseScenario(kMinimal + "sensor: {rows: 4096, cols: 16384}\n", kFile).sensor.cols,
            16384);
  expectError(kMinimal + "sensor: {fov_deg: [30, 180]}\n", "sensor.fov_deg[1]",
              "expected a number in (0, 180), got 180");
  expectError(kMinimal + "sensor: {dropout: 1}\n", "sensor.dropout",
              "expected a number in [0, 1), got 1");
  expectError(kMinimal + "sensor: {beam_divergence_deg: -0.1}\n", "sensor.beam_divergence_deg",
              "expected a number in [0, 180)");
  expectError("name: t\nterrain: {kind: plane, size_m: [20, 501]}\nviews: [{xyz_m: [0, 0, 1]}]\n",
              "terrain.size_m[1]", "expected a number in (0, 500], got 501");
  expectError("name: t\nterrain: {kind: plane, cell_m: 0}\nviews: [{xyz_m: [0, 0, 1]}]\n",
              "terrain.cell_m", "expected a number in (0, 1], got 0");
  expectError("name: t\nterrain: {kind: fractal, hurst: 1}\nviews: [{xyz_m: [0, 0, 1]}]\n",
              "terrain.hurst", "expected a number in (0, 1), got 1");
  expectError("name: t\nterrain: {kind: plane, slope_deg: [0, -60]}\nviews: [{xyz_m: [0, 0, 1]}]\n",
              "terrain.slope_deg[1]", "expected a number in (-60, 60), got -60");
  expectError(
      "name: t\nterrain: {kind: mars, rocks: {abundance_k: 0.6}}\nviews: [{xyz_m: [0, 0, 1]}]\n",
      "terrain.rocks.abundance_k", "expected a number in (0, 0.5], got 0.6");
  expectError(
      "name: t\nterrain: {kind: mars, craters: {count: 1001}}\nviews: [{xyz_m: [0, 0, 1]}]\n",
      "terrain.craters.count", "expected an integer in [0, 1000], got 1001");
  expectError(
      "name: t\nterrain: {kind: plane}\nviews: [{xyz_m: [0, 0, 1], rpy_deg: [0, 0, 361]}]\n",
      "views[0].rpy_deg[2]", "expected a number in [-360, 360], got 361");
  expectError(kMinimal + "map: {epsilon_rad: 0}\n", "map.epsilon_rad",
              "expected a number > 0, got 0");
  expectError("name: T-1\nterrain: {kind: plane}\nviews: [{xyz_m: [0, 0, 1]}]\n", "name",
              "expected lowercase letters, digits, '_' and '-' only, got 'T-1'");
}

TEST(ScenarioErrors, NumbersMustBeFinite) {
  expectError("name: t\nterrain: {kind: plane, cell_m: .nan}\nviews: [{xyz_m: [0, 0, 1]}]\n",
              "terrain.cell_m", "expected a finite number in (0, 1], got .nan");
  expectError("name: t\nterrain: {kind: plane}\nviews: [{xyz_m: [0, -.inf, 1]}]\n",
              "views[0].xyz_m[1]", "expected a finite number, got -.inf");
  expectError(kMinimal + "sensor: {max_range_m: 1e999}\n", "sensor.max_range_m",
              "expected a number > 0, got 1e999, beyond the range of a double");
  expectError(kMinimal + "sensor: {noise_k: nan}\n", "sensor.noise_k", "expected a finite number");
  expectError(kMinimal + "sensor: {noise_k: 1e-400}\n", "sensor.noise_k",
              "expected a number >= 0, got 1e-400, beyond the range of a double");
}

TEST(ScenarioErrors, ListsHaveTheirExactLength) {
  expectError("name: t\nterrain: {kind: plane}\nviews: [{xyz_m: [0, 0, 1]}, {xyz_m: [0, 1]}]\n",
              "views[1].xyz_m", "expected a list of 3 numbers, got a list of 2");
  expectError("name: t\nterrain: {kind: plane, size_m: 20}\nviews: [{xyz_m: [0, 0, 1]}]\n",
              "terrain.size_m", "expected a list of 2 numbers, got 20");
  expectError("name: t\nterrain: {kind: plane}\nviews: []\n", "views",
              "expected a non-empty list of views, got a list of 0");
  expectError("name: t\nterrain: {kind: steps, steps: []}\nviews: [{xyz_m: [0, 0, 1]}]\n",
              "terrain.steps", "expected a non-empty list of steps");
}

TEST(ScenarioErrors, RelationsBetweenKeys) {
  expectError(
      "name: t\nterrain: {kind: mars, rocks: {min_diameter_m: 0.5, max_diameter_m: 0.5}}\n"
      "views: [{xyz_m: [0, 0, 1]}]\n",
      "terrain.rocks.max_diameter_m", "expected a number > min_diameter_m (0.5), got 0.5");
  expectError(
      "name: t\nterrain: {kind: mars, craters: {min_diameter_m: 6}}\nviews: [{xyz_m: [0, 0, 1]}]\n",
      "terrain.craters.max_diameter_m", "got 5 (the default)");
  expectError(kMinimal + "map: {region: {x_m: [5, -5]}}\n", "map.region.x_m",
              "expected [lo, hi] with lo < hi, got [5, -5]");
  expectError(
      "name: t\nterrain: {kind: plane, size_m: [500, 500], cell_m: 0.05}\n"
      "views: [{xyz_m: [0, 0, 1]}]\n",
      "terrain.cell_m", "expected at most 25000000 grid points, got 10001 x 10001");
  expectError(
      "name: t\nterrain: {kind: plane, size_m: [0.4, 20], cell_m: 1}\n"
      "views: [{xyz_m: [0, 0, 1]}]\n",
      "terrain.cell_m",
      "expected at most twice the smaller side of size_m (0.8) for two samples per side, "
      "got 1");
  expectError("name: t\nterrain: {kind: mars, size_m: [1.5, 20]}\nviews: [{xyz_m: [0, 0, 1]}]\n",
              "terrain.rocks.max_diameter_m",
              "expected at most half the smaller side of size_m (0.75), got 1 (the default)");
  expectError(kMinimal + "map: {cell_m: 0.001}\n", "map.cell_m",
              "expected at most 25000000 grid points");
  expectError("name: t\nterrain: {kind: plane, mjcf: w.xml}\nviews: [{xyz_m: [0, 0, 1]}]\n",
              "terrain.mjcf", "only allowed with kind: mjcf");
}

// A view must stand over the generated terrain: its heightfield spans round(size / cell) cells,
// centred on the origin. (Below the surface is a run-time check: test_run.cpp.)
TEST(ScenarioErrors, ViewsStandOverTheTerrain) {
  EXPECT_EQ(errorOf("name: t\nterrain: {kind: plane}\nviews: [{xyz_m: [0, 0, 1]}, {xyz_m: [12, 0, 3]}]\n"),
            kFile + ": views[1].xyz_m: expected x in [-10, 10] and y in [-10, 10] (over the terrain), got [12, 0, 3]");
  expectError("name: t\nterrain: {kind: plane, size_m: [20, 6]}\nviews: [{xyz_m: [0, -3.5, 1]}]\n", "views[0].xyz_m",
              "expected x in [-10, 10] and y in [-3, 3] (over the terrain), got [0, -3.5, 1]");
  // 1.04 m at 0.1 m cells is 10 cells (round(10.4)): the terrain is 1 m wide, so x = 0.52 is off it.
  expectError("name: t\nterrain: {kind: plane, size_m: [1.04, 4], cell_m: 0.1}\nviews: [{xyz_m: [0.52, 0, 1]}]\n",
              "views[0].xyz_m", "expected x in [-0.5, 0.5] and y in [-2, 2]");
  // The edges themselves are over the terrain.
  EXPECT_EQ(parseScenario("name: t\nterrain: {kind: plane}\nviews: [{xyz_m: [-10, 10, 1]}]\n", kFile).views.size(), 1u);
}

TEST(ScenarioErrors, MjcfFileMustExist) {
  const std::string message = errorOf(
      "name: t\nterrain: {kind: mjcf, mjcf: worlds/none.xml}\nviews: [{xyz_m: [0, 0, 1]}]\n");
  EXPECT_EQ(message.rfind(kFile + ": terrain.mjcf: cannot find the MJCF file 'worlds/none.xml'", 0),
            0u)
      << message;
  EXPECT_NE(message.find((fs::absolute("scenarios") / "worlds" / "none.xml").string()),
            std::string::npos)
      << message;
}

TEST(ScenarioErrors, DocumentShape) {
  expectError(kMinimal + "seed: 1\nseed: 2\n", "seed", "duplicate key");
  EXPECT_EQ(errorOf(""), kFile + ": expected a mapping of scenario keys, got nothing");
  EXPECT_EQ(errorOf("# only a comment\n"),
            kFile + ": expected a mapping of scenario keys, got nothing");
  EXPECT_EQ(errorOf(kMinimal + "---\n" + kMinimal), kFile + ": expected one YAML document, got 2");
  EXPECT_EQ(errorOf("- a\n- b\n"),
            kFile + ": expected a mapping of scenario keys, got a list of 2");
  expectError(kMinimal + "[a]: 1\n", "", "expected plain names as keys");
}

}  // namespace
}  // namespace ambler::eval

namespace ambler::eval {
namespace {

const std::string kThreeViews =
    "name: t\nterrain: {kind: plane}\nviews: [{xyz_m: [0, 0, 1]}, {xyz_m: [1, 0, 1]}, {xyz_m: [2, 0, 1]}]\nmap: {}\n";

// matching: {} registers each view against the one before with Levenberg-Marquardt from no error;
// every key read back bit for bit.
TEST(ScenarioMatching, DefaultsAndRoundTrip) {
  const Scenario d = parseScenario(kThreeViews + "matching: {}\n", kFile);
  ASSERT_TRUE(d.matching.has_value());
  EXPECT_EQ(d.matching->pairs, (std::vector<std::pair<int, int>>{{0, 1}, {1, 2}}));
  EXPECT_EQ(d.matching->methods, std::vector<MatchMethod>{MatchMethod::IconicLm});
  EXPECT_EQ(d.matching->initial_error.xyz_m, Eigen::Vector3d::Zero());
  EXPECT_EQ(d.matching->success_translation_m, 0.05);
  EXPECT_EQ(d.matching->success_rotation_deg, 0.5);
  EXPECT_EQ(registrationConfig(d).prior_rotation_deg, d.matching->prior_rotation_deg);  // the box's widest turn
  expectRoundTrip(d);
  const Scenario full = parseScenario(kThreeViews + "matching: {pairs: [[0, 2], [2, 1]], methods: [iconic, iconic_lm], "
                                                    "initial_error: {xyz_m: [0.5, -0.3, 0.1], rpy_deg: [1, -2, 5]}, "
                                                    "success: {translation_m: 0.1, rotation_deg: 1}, "
                                                    "prior: {translation_m: 2.5, rotation_deg: 12}}\n",
                                      kFile);
  EXPECT_EQ(full.matching->pairs, (std::vector<std::pair<int, int>>{{0, 2}, {2, 1}}));
  EXPECT_EQ(full.matching->prior_translation_m, 2.5);
  EXPECT_EQ(full.matching->prior_rotation_deg, 12.0);
  EXPECT_EQ(registrationConfig(full).prior_translation_m, 2.5);  // what feature matching is held to
  EXPECT_EQ(registrationConfig(full).prior_rotation_deg, 12.0);
  EXPECT_EQ(full.matching->methods, (std::vector<MatchMethod>{MatchMethod::Iconic, MatchMethod::IconicLm}));
  EXPECT_NEAR(full.matching->initial_error.rpy_rad.z(), 5 * std::numbers::pi / 180, 1e-15);
  expectRoundTrip(full);
}

// Bad matching sections: one line naming the file and the key, as everywhere.
TEST(ScenarioMatching, RefusesBadInput) {
  expectError(kThreeViews + "matching: {pairs: [[0, 3]]}\n", "matching.pairs[0]", "view indices in [0, 2]");
  expectError(kThreeViews + "matching: {pairs: [[1, 1]]}\n", "matching.pairs[0]", "against itself");
  expectError(kThreeViews + "matching: {pairs: [[0, 1.5]]}\n", "matching.pairs[0]", "view indices");
  expectError(kThreeViews + "matching: {methods: [iconik]}\n", "matching.methods[0]", "did you mean iconic");
  // An unknown peer.
  expectError(kThreeViews + "matching: {methods: [features, icp_point_to_point]}\n", "matching.methods[1]",
              "did you mean icp_point_to_plane");
  expectError(kThreeViews + "matching: {initial_error: {xyz_m: [5, 0, 0]}}\n", "matching.initial_error.xyz_m[0]",
              "in [-3, 3]");
  expectError(kThreeViews + "matching: {initial_error: {rpy_deg: [0, 0, 40]}}\n", "matching.initial_error.rpy_deg[2]",
              "in [-30, 30]");
  expectError(kThreeViews + "matching: {success: {translation_m: 0}}\n", "matching.success.translation_m", "> 0");
  expectError(kThreeViews + "matching: {prior: {translation_m: -1}}\n", "matching.prior.translation_m", "> 0");
  expectError(kThreeViews + "matching: {prior: {rotation_deg: 190}}\n", "matching.prior.rotation_deg", "in (0, 180]");
  expectError(kThreeViews + "matching: {prior: {rotation: 10}}\n", "matching.prior.rotation", "unknown key");
  expectError(kThreeViews + "matching: {pair: [[0, 1]]}\n", "matching.pair", "unknown key (did you mean pairs?)");
  expectError(kMinimal + "map: {}\nmatching: {}\n", "matching", "at least two views");
  expectError("name: t\nterrain: {kind: plane}\nviews: [{xyz_m: [0, 0, 1]}, {xyz_m: [1, 0, 1]}]\nmatching: {}\n",
              "matching", "needs a map section");
}

// merge: {} takes the map's grid and matched poses; every key read back bit for bit.
TEST(ScenarioMerge, DefaultsAndRoundTrip) {
  const Scenario d = parseScenario(kThreeViews + "matching: {}\nmerge: {}\n", kFile);
  ASSERT_TRUE(d.merge.has_value());
  EXPECT_EQ(d.merge->poses, MergePoses::Matched);
  EXPECT_EQ(d.merge->cell_m, d.map->cell_m);
  EXPECT_EQ(d.merge->x_m, d.map->x_m);
  EXPECT_EQ(d.merge->y_m, d.map->y_m);
  const Scenario full = parseScenario(kThreeViews + "merge: {poses: true, cell_m: 0.2, region: {x_m: [-1, 2], y_m: [0, 3]}}\n", kFile);
  EXPECT_EQ(full.merge->poses, MergePoses::True);
  EXPECT_EQ(full.merge->cell_m, 0.2);
  EXPECT_EQ(full.merge->x_m, Eigen::Vector2d(-1, 2));
  const Scenario back = parseScenario(resolvedYaml(full), kFile);
  ASSERT_TRUE(back.merge.has_value());
  EXPECT_EQ(back.merge->poses, full.merge->poses);
  EXPECT_EQ(back.merge->cell_m, full.merge->cell_m);
  EXPECT_EQ(back.merge->x_m, full.merge->x_m);
  EXPECT_EQ(back.merge->y_m, full.merge->y_m);
}

TEST(ScenarioMerge, RefusesBadInput) {
  expectError(kMinimal + "map: {}\nmerge: {poses: true}\n", "merge", "at least two views");
  expectError(kThreeViews + "merge: {}\n", "merge.poses", "needs a matching section");
  expectError(kThreeViews + "matching: {pairs: [[0, 1]]}\nmerge: {}\n", "merge.poses", "view 2 is not linked to view 0");
  expectError(kThreeViews + "merge: {poses: guessed}\n", "merge.poses", "matched");
  expectError(kThreeViews + "merge: {poses: true, cell_m: -1}\n", "merge.cell_m", "> 0");
  expectError("name: t\nterrain: {kind: plane}\nviews: [{xyz_m: [0, 0, 1]}, {xyz_m: [1, 0, 1]}]\nmerge: {poses: true}\n",
              "merge", "needs a map section");
}

}  // namespace
}  // namespace ambler::eval

namespace ambler::eval {
namespace {

// footfall: {} evaluates every method on view 0's map over the contract's default region; a
// composite is the default when there is one; every key reads back.
TEST(ScenarioFootfall, DefaultsAndRoundTrip) {
  const Scenario d = parseScenario(kThreeViews + "footfall: {}\n", kFile);
  ASSERT_TRUE(d.footfall.has_value());
  EXPECT_EQ(d.footfall->map_view, 0);
  EXPECT_EQ(d.footfall->x_m, Eigen::Vector2d(0, 2));
  EXPECT_EQ(d.footfall->y_m, Eigen::Vector2d(1, 3));
  EXPECT_EQ(d.footfall->foot_diameter_m, 0.30);
  EXPECT_EQ(d.footfall->methods.size(), 6u);
  EXPECT_FALSE(d.leg.has_value());
  expectRoundTrip(d);
  const Scenario full = parseScenario(kThreeViews + "merge: {poses: true}\nfootfall: {region: {x_m: [-1, 0.5], y_m: [0, 2]}, "
                                                   "foot_diameter_m: 0.4, methods: [equilibrium, max_min]}\n"
                                                   "leg: {soil: rock, load_n: 2500}\n",
                                      kFile);
  EXPECT_EQ(full.footfall->map_view, -1);
  EXPECT_EQ(full.footfall->methods,
            (std::vector<perception::FootfallMethod>{perception::FootfallMethod::Equilibrium, perception::FootfallMethod::MaxMin}));
  ASSERT_TRUE(full.leg.has_value());
  EXPECT_EQ(full.leg->soil, Soil::Rock);
  EXPECT_EQ(full.leg->load_n, 2500);
  expectRoundTrip(full);
}

// Bad footfall and leg sections: one line naming the file and the key.
TEST(ScenarioFootfall, RefusesBadInput) {
  expectError(kThreeViews + "footfall: {region: {x_m: [4, 6], y_m: [0, 1]}}\n", "footfall.region", "is not inside view_0's map");
  expectError(kThreeViews + "footfall: {region: {x_m: [0, 0.2], y_m: [0, 1]}}\n", "footfall.foot_diameter_m",
              "larger than the region");
  expectError(kThreeViews + "footfall: {methods: [max_min, max_mid]}\n", "footfall.methods[1]", "did you mean max_min");
  expectError(kThreeViews + "footfall: {map: composite}\n", "footfall.map", "needs a merge section");
  expectError(kThreeViews + "footfall: {map: view_7}\n", "footfall.map", "view_K with K in [0, 2]");
  expectError(kThreeViews + "footfall: {}\nleg: {load_n: -4000}\n", "leg.load_n", "");
  expectError(kThreeViews + "leg: {soil: sand}\n", "leg", "needs a footfall section");
  expectError(kThreeViews + "footfall: {}\nleg: {soil: mud}\n", "leg.soil", "expected one of");
}

}  // namespace
}  // namespace ambler::eval
