// The leg stage of `ambler run` (eval/run/stages/leg.cpp).
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <numbers>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "eval/geo/dem.hpp"
#include "eval/pictures/figures.hpp"
#include "eval/scenario/io.hpp"
#include "eval/run/runner.hpp"
#include "eval/run/stages.hpp"
#include "eval/scenario/scenario.hpp"
#include "perception/sensor_geometry.hpp"
#include "eval/picture_checks.hpp"
#include "sim/ground_truth.hpp"
#include "sim/leg.hpp"
#include "sim/ray_scene.hpp"
#include "sim/world.hpp"
#include "terrains/terrain.hpp"
#include "test_support.hpp"
#include "run_scenes.hpp"

namespace ambler::eval {
namespace {

namespace fs = std::filesystem;
using namespace run_test;
using test::slurp;

// The leg stage on flat ground: on rock the foot settles level (tilt < 0.1°, slip < 1 mm, sink
// < 1 mm); on sand it sinks by Bekker's law for the load (within 10 %), docs/leg.md.
TEST(Run, LegStageStepsOnEachChoice) {
  for (const char* soil : {"rock", "sand"}) {
    const Scenario sc = parseScenario(std::string(R"(name: leg_test
seed: 1
terrain: {kind: plane, size_m: [8, 8], cell_m: 0.05}
sensor: {noise_k: 0, quantization_m: 0, mixed_pixels: false}
views: [{xyz_m: [0, -3, 2.0], rpy_deg: [0, -35, 0]}]
map: {cell_m: 0.1, region: {x_m: [-2, 2], y_m: [-1, 3]}, baseline: none}
footfall: {region: {x_m: [-0.5, 0.5], y_m: [0.5, 1.5]}, methods: [max_min, equilibrium]}
leg: {soil: )") + soil + ", load_n: 3000}\n",
                                      "inline.yaml");
    test::TempDir run;
    const auto metrics = runScenario(sc, {run.dir, false});
    EXPECT_TRUE(std::filesystem::exists(run.dir / "world" / "leg.xml"));
    ASSERT_EQ(metrics["footfall"].size(), 2u);
    // A rigid disk rests level on flat ground at every candidate of the region: the cells whose
    // centres lie a foot radius inside the 1 × 1 m region, 8 × 8 at 10 cm.
    const cv::Mat predicted = cv::imread((run.dir / "leg" / "predicted_tilt.tiff").string(), cv::IMREAD_UNCHANGED);
    ASSERT_FALSE(predicted.empty());
    int candidates = 0;
    for (int r = 0; r < predicted.rows; ++r)
      for (int c = 0; c < predicted.cols; ++c)
        if (std::isfinite(predicted.at<float>(r, c))) {
          ++candidates;
          EXPECT_LT(std::abs(predicted.at<float>(r, c)), 0.01);
        }
    EXPECT_EQ(candidates, 64);
    // Bekker's law by hand for the scenario's 3 kN on the 30 cm foot in dry sand (the working is in
    // tests/sim/test_leg.cpp): z = (W/(π·b²)/(k_c/b + k_φ))^(1/n) = 38.31 mm.
    const double b = 0.15, n = 1.1, k_c = 0.99e3, k_phi = 1528.43e3;
    const double bekker = std::pow(3000 / (std::numbers::pi * b * b) / (k_c / b + k_phi), 1.0 / n);
    const double expected_sink = std::string(soil) == "sand" ? bekker : 0.0;
    for (const auto& f : metrics["footfall"]) {
      const auto& leg = f["leg"];
      SCOPED_TRACE(std::string(soil) + " " + f["method"].get<std::string>());
      EXPECT_TRUE(leg["settled"].get<bool>());
      EXPECT_LT(leg["tilt_deg"].get<double>(), 0.1);
      EXPECT_LT(leg["slip_m"].get<double>(), 0.001);
      if (expected_sink > 0)
        EXPECT_NEAR(leg["sink_m"].get<double>(), expected_sink, 0.1 * expected_sink);
      else
        EXPECT_LT(leg["sink_m"].get<double>(), 0.001);
      EXPECT_TRUE(std::filesystem::exists(run.dir / "leg" / (f["method"].get<std::string>() + ".json")));
    }
  }
}

// The leg built once per run, as the leg stage builds it (sim::Leg on the world cropped to the footfall
// region, no hold), against sim::stepLeg (the whole world, built for the step) on the world of the
// sandbox experiment (scenarios/experiments/sandbox.yaml, seed 1): the footfalls its methods chose
// on sand, one of them on rock soil, and a foot on the rock nearest the region's centre.
//
// What the leg stage needs is agreement within what the settle rule cannot tell apart: in one
// window w = 50 ms at speeds under v = 2 mm/s and ω = 0.02 rad/s a foot turns ω·w = 1 mrad
// (0.0573°), its sole centre (t = 5 cm below the ankle whose speed is measured) moves
// (v + ω·t)·w = 0.10005 mm and its sole at the rim (√(r² + t²) = 0.158 m from the ankle)
// (v + ω·0.158)·w = 0.10016 mm; on sand one more 0.1 mm yield step. The crop is built to be
// tighter than that: the heightfield whole at its place, the kept rocks' compiled meshes and frames
// copied from the world's model, the probe's rays cast from the same height, so every contact is
// computed as in the whole world and in the same order. The test holds it to the bit; a difference
// within the bounds above would still be a correct leg, but no longer this crop.
TEST(Run, LegBuiltOnceMatchesStepLegOnTheSandbox) {
  const Scenario sc = loadScenario(fs::path(AMBLER_SOURCE_DIR) / "scenarios" / "experiments" / "sandbox.yaml");
  const terrains::Terrain terrain = scenarioTerrain(sc);
  test::TempDir dir;
  const fs::path world = sim::writeWorld(terrain, dir.path(), "sandbox");
  const sim::LegConfig sand = legConfig(sc);
  ASSERT_EQ(sand.soil, sim::Soil::Sand);
  sim::LegConfig rock = sand;
  rock.soil = sim::Soil::Rock;
  const sim::LegRegion region = legRegion(sc);
  // The rock nearest the region's centre, stepped on at the region's point nearest to it.
  const Eigen::Vector2d centre(0.5 * (region.x_min + region.x_max), 0.5 * (region.y_min + region.y_max));
  const auto nearest = std::min_element(terrain.rocks.begin(), terrain.rocks.end(), [&](const auto& a, const auto& b) {
    return (a.center.template head<2>() - centre).norm() < (b.center.template head<2>() - centre).norm();
  });
  ASSERT_NE(nearest, terrain.rocks.end());
  const Eigen::Vector2d on_rock(std::clamp(nearest->center.x(), region.x_min, region.x_max),
                                std::clamp(nearest->center.y(), region.y_min, region.y_max));
  struct Case {
    const char* what;
    Eigen::Vector2d at;
    bool sand;
  };
  // The choices of `ambler run scenarios/experiments/sandbox.yaml` (cell centres of its 5 cm map).
  const std::vector<Case> cases{{"max_min, free_volume, equilibrium", {0.275, 0.825}, true},
                                {"planar_fit", {0.325, 0.625}, true},
                                {"support_area", {-0.125, 0.825}, true},
                                {"equilibrium_uncertain", {0.325, 0.775}, true},
                                {"support_area on rock soil", {-0.125, 0.825}, false},
                                {"the rock nearest the centre", on_rock, true}};
  sim::Leg leg_sand(world, region, sand), leg_rock(world, region, rock);
  EXPECT_TRUE(leg_sand.cropped());
  EXPECT_GT(leg_sand.droppedGeoms(), 0);
  std::vector<sim::LegOutcome> first;
  for (const Case& c : cases) {
    SCOPED_TRACE(c.what);
    const sim::LegOutcome fast = (c.sand ? leg_sand : leg_rock).step(c.at.x(), c.at.y());
    const sim::LegOutcome ref = sim::stepLeg(world, c.at.x(), c.at.y(), c.sand ? sand : rock);
    std::printf("%-34s tilt %.4f deg (%+.2g), sink %.3f mm (%+.2g), slip %.3f mm (%+.2g), settled at %.3f s (%+.3f)\n",
                c.what, fast.tilt_deg, fast.tilt_deg - ref.tilt_deg, 1e3 * fast.sink_m, 1e3 * (fast.sink_m - ref.sink_m),
                1e3 * fast.slip_m, 1e3 * (fast.slip_m - ref.slip_m), fast.time_s, fast.time_s - ref.time_s);
    EXPECT_TRUE(ref.settled);
    EXPECT_EQ(fast.settled, ref.settled);
    EXPECT_EQ(fast.contact_cap_reached, ref.contact_cap_reached);
    EXPECT_EQ(fast.tilt_deg, ref.tilt_deg);
    EXPECT_EQ(fast.sink_m, ref.sink_m);
    EXPECT_EQ(fast.slip_m, ref.slip_m);
    EXPECT_EQ(fast.time_s, ref.time_s);
    EXPECT_TRUE(std::isnan(fast.drift_m));  // no hold
    first.push_back(fast);
  }
  EXPECT_EQ(leg_sand.fallbacks(), 0);
  // Steps are independent: the first again, after the others lowered the sand elsewhere, is the
  // same to the bit.
  const sim::LegOutcome again = leg_sand.step(cases[0].at.x(), cases[0].at.y());
  EXPECT_EQ(again.tilt_deg, first[0].tilt_deg);
  EXPECT_EQ(again.sink_m, first[0].sink_m);
  EXPECT_EQ(again.slip_m, first[0].slip_m);
  EXPECT_EQ(again.time_s, first[0].time_s);
  EXPECT_THROW(leg_sand.step(region.x_max + 0.01, centre.y()), std::invalid_argument);
}

// Issue 28: the leg's culled heightfield collision (sim::LegConfig::cull_prisms, the default) against
// MuJoCo 2.2.2's own (cull_prisms = false: the leg before the speed-up), as the leg stage steps:
// on the world cropped to the footfall region, no hold. Terrains of the footfall experiment
// (scenarios/experiments/footfall_trials.yaml: the sandbox with other seeds, regions and rock
// abundances), sand and rock soil, 3 × 3 footfalls over each region's candidate centres (a foot
// radius inside it, as `ambler bench leg` places them): 36 footfalls.
//
// The outcomes must agree within what the settle rule cannot tell apart (above, derived here from
// the config): one window w at speeds under v and ω, ω·w of tilt, (v + ω·t)·w of slip,
// (v + ω·√(r² + t²))·w of sink, and on sand one more 0.1 mm yield step of sink. The culling skips
// only prisms where MPR finds no contact, so they agree to the bit; the test prints how many did.
TEST(Run, LegCulledCollisionMatchesMuJoCosOnTheFootfallTerrains) {
  struct Variant {
    std::uint64_t seed;
    Eigen::Vector2d x, y;
    double abundance;
    bool sand;
  };
  const std::vector<Variant> variants{{2, {-1.5, -0.5}, {0.0, 1.0}, 0.16, true},
                                      {9, {0.5, 1.5}, {1.0, 2.0}, 0.16, true},
                                      {13, {-1.0, 0.0}, {1.5, 2.5}, 0.08, true},
                                      {7, {-0.5, 0.5}, {0.5, 1.5}, 0.08, false}};
  const Scenario base = loadScenario(fs::path(AMBLER_SOURCE_DIR) / "scenarios" / "experiments" / "sandbox.yaml");
  int footfalls = 0, identical = 0;
  double d_tilt = 0, d_sink = 0, d_slip = 0;
  for (const Variant& v : variants) {
    Scenario sc = base;
    sc.seed = v.seed;
    sc.terrain.rocks->abundance_k = v.abundance;
    sc.footfall->x_m = v.x;
    sc.footfall->y_m = v.y;
    test::TempDir dir;
    const fs::path world = sim::writeWorld(scenarioTerrain(sc), dir.path(), "sandbox");
    sim::LegConfig culled = legConfig(sc);
    culled.soil = v.sand ? sim::Soil::Sand : sim::Soil::Rock;
    ASSERT_TRUE(culled.cull_prisms);  // the default
    sim::LegConfig mujoco = culled;
    mujoco.cull_prisms = false;
    const sim::LegRegion region = legRegion(sc);
    sim::Leg fast(world, region, culled), before(world, region, mujoco);
    // The settle rule's window (docs/leg.md, "A step"), and the sand's yield step.
    const double w = culled.settle_window_s, speed = culled.settle_speed_m_s;
    const double omega = culled.settle_angular_speed_rad_s, t = culled.foot_thickness_m;
    const double r = 0.5 * culled.foot_diameter_m, yield = v.sand ? 1e-4 : 0.0;
    const double tilt_tol = omega * w * 180 / std::numbers::pi;
    const double slip_tol = (speed + omega * t) * w + yield;
    const double sink_tol = (speed + omega * std::hypot(r, t)) * w + yield;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        const auto lerp = [r](double lo, double hi, int k) { return lo + r + 0.5 * k * (hi - lo - 2 * r); };
        const double x = lerp(region.x_min, region.x_max, j), y = lerp(region.y_min, region.y_max, i);
        SCOPED_TRACE("seed " + std::to_string(v.seed) + " at (" + std::to_string(x) + ", " + std::to_string(y) + ")" +
                     (v.sand ? " sand" : " rock"));
        const sim::LegOutcome a = fast.step(x, y), b = before.step(x, y);
        std::printf("seed %2d (%6.3f, %6.3f) %s: tilt %.4f deg (%+.2g), sink %.3f mm (%+.2g), slip %.3f mm (%+.2g), "
                    "settled at %.3f s (%+.3f)\n",
                    int(v.seed), x, y, v.sand ? "sand" : "rock", a.tilt_deg, a.tilt_deg - b.tilt_deg, 1e3 * a.sink_m,
                    1e3 * (a.sink_m - b.sink_m), 1e3 * a.slip_m, 1e3 * (a.slip_m - b.slip_m), a.time_s,
                    a.time_s - b.time_s);
        EXPECT_EQ(a.settled, b.settled);
        EXPECT_EQ(a.contact_cap_reached, b.contact_cap_reached);
        EXPECT_LE(std::abs(a.tilt_deg - b.tilt_deg), tilt_tol);
        EXPECT_LE(std::abs(a.sink_m - b.sink_m), sink_tol);
        EXPECT_LE(std::abs(a.slip_m - b.slip_m), slip_tol);
        d_tilt = std::max(d_tilt, std::abs(a.tilt_deg - b.tilt_deg));
        d_sink = std::max(d_sink, std::abs(a.sink_m - b.sink_m));
        d_slip = std::max(d_slip, std::abs(a.slip_m - b.slip_m));
        ++footfalls;
        identical += a.tilt_deg == b.tilt_deg && a.sink_m == b.sink_m && a.slip_m == b.slip_m && a.time_s == b.time_s;
      }
    EXPECT_EQ(fast.fallbacks(), 0);
  }
  std::printf("%d footfalls, %d identical to the bit; largest difference: tilt %.2g deg, sink %.2g m, slip %.2g m\n",
              footfalls, identical, d_tilt, d_sink, d_slip);
  EXPECT_EQ(footfalls, 36);
}

}  // namespace
}  // namespace ambler::eval
