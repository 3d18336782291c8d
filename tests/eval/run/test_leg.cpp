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

#include "eval/pictures/figures.hpp"
#include "eval/scenario/io.hpp"
#include "eval/run/runner.hpp"
#include "eval/scenario/scenario.hpp"
#include "perception/sensor_geometry.hpp"
#include "eval/picture_checks.hpp"
#include "sim/ground_truth.hpp"
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

}  // namespace
}  // namespace ambler::eval
