// Metamorphic tests of the map (issue 30, docs/experiments/metamorphic.md): each step towards a better
// sensor (noise off, quantisation off, mixed pixels off, all three off, 2x and 4x the rows and
// columns) against the ERIM on three terrains (scenarios/demo.yaml, scenarios/mars.yaml,
// scenarios/experiments/acceptance_fractal.yaml), view 0's locus map scored against ground truth
// as the map stage scores it. The relations, each within the noise of a single draw:
//  - coverage does not drop by more than 1 point (the bound; one draw's coverage varies by
//    0.3 points over noise seeds, so a point is over three standard deviations of a difference);
//  - RMS error does not rise by more than 10 % (one draw's RMS varies by about 1 %);
//  - visible cells called shadow, and hidden cells known beyond 3σ_z, do not increase by more than
//    2·√(2n), n the ERIM's count: both counts vary over noise seeds with a standard deviation of
//    about √n (measured, docs/experiments/metamorphic.md), so two draws differ by √(2n) at one σ.
// Not every relation holds: each shadow method asserts those that hold on all three terrains, and
// the page lists every figure, the ones that fail included.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "base/temp_dir.hpp"
#include "eval/run/runner.hpp"
#include "eval/scenario/scenario.hpp"

namespace ambler::eval {
namespace {

namespace fs = std::filesystem;
const fs::path kScenarios = fs::path(AMBLER_SOURCE_DIR) / "scenarios";

struct MapFigures {
  double coverage, rms_m;
  double visible_called_shadow;  // shadow cells that the truth sees: shadow·(1 − precision)
  double hidden_beyond_3sigma;
};

struct Step {
  std::string name;
  std::function<void(perception::SensorModel&)> apply;
};

const std::vector<Step>& steps() {
  static const std::vector<Step> s = {
      {"noise off", [](perception::SensorModel& m) { m.noise_k = 0; }},
      {"quantisation off", [](perception::SensorModel& m) { m.quantization_m = 0; }},
      {"mixed pixels off", [](perception::SensorModel& m) { m.mixed_pixels = false; }},
      {"all off", [](perception::SensorModel& m) { m.noise_k = 0, m.quantization_m = 0, m.mixed_pixels = false; }},
      {"2x", [](perception::SensorModel& m) { m.rows *= 2, m.cols *= 2; }},
      {"4x", [](perception::SensorModel& m) { m.rows *= 4, m.cols *= 4; }},
  };
  return s;
}

// View 0's map figures for `file` with the shadow method and a sensor step (nullptr: the ERIM).
MapFigures figures(const fs::path& file, perception::ShadowMethod shadows, const Step* step) {
  Scenario s = loadScenario(file);
  s.views.resize(1);
  s.matching.reset(), s.merge.reset(), s.footfall.reset(), s.leg.reset();
  s.map->shadows = shadows;
  s.map->baseline = Baseline::None;
  if (step) step->apply(s.sensor);
  const base::TempDir dir("metamorphic");
  RunOptions options;
  options.out = dir.path() / "run";
  options.progress = false;
  const nlohmann::ordered_json m = runScenario(s, options)["map"][0];
  const double precision = m["shadow_precision"].is_null() ? 0.0 : m["shadow_precision"].get<double>();
  return {m["coverage"].get<double>(), m["rms_error_m"].get<double>(), m["shadow"].get<double>() * (1 - precision),
          m["known_in_shadow_above_3sigma"].get<double>()};
}

struct Asserted {
  std::vector<std::string> coverage, rms, visible_called_shadow, hidden_beyond_3sigma;
};

bool listed(const std::vector<std::string>& v, const std::string& name) {
  return std::find(v.begin(), v.end(), name) != v.end();
}

void checkTerrains(perception::ShadowMethod shadows, const Asserted& asserted) {
  for (const char* file : {"demo.yaml", "mars.yaml", "experiments/acceptance_fractal.yaml"}) {
    const MapFigures erim = figures(kScenarios / file, shadows, nullptr);
    const double count_slack_shadow = 2 * std::sqrt(2 * erim.visible_called_shadow);
    const double count_slack_hidden = 2 * std::sqrt(2 * erim.hidden_beyond_3sigma);
    for (const Step& step : steps()) {
      const MapFigures f = figures(kScenarios / file, shadows, &step);
      SCOPED_TRACE(std::string(file) + ", " + step.name);
      ::testing::Test::RecordProperty(std::string(file) + " " + step.name,
                     "coverage " + std::to_string(f.coverage) + " rms " + std::to_string(f.rms_m) + " visible shadow " +
                         std::to_string(f.visible_called_shadow) + " hidden beyond 3 sigma " +
                         std::to_string(f.hidden_beyond_3sigma));
      if (listed(asserted.coverage, step.name)) {
        EXPECT_GE(f.coverage, erim.coverage - 0.01);
      }
      if (listed(asserted.rms, step.name)) {
        EXPECT_LE(f.rms_m, 1.1 * erim.rms_m);
      }
      if (listed(asserted.visible_called_shadow, step.name)) {
        EXPECT_LE(f.visible_called_shadow, erim.visible_called_shadow + count_slack_shadow);
      }
      if (listed(asserted.hidden_beyond_3sigma, step.name)) {
        EXPECT_LE(f.hidden_beyond_3sigma, erim.hidden_beyond_3sigma + count_slack_hidden);
      }
    }
  }
}

const std::vector<std::string> kAll = {"noise off", "quantisation off", "mixed pixels off", "all off", "2x", "4x"};

// The default (shadows: gnc): RMS error at every step; coverage and visible cells called shadow
// at finer resolution. Coverage with noise off or all off, visible cells called shadow without
// mixed pixels or with all off, and hidden cells known beyond 3σ_z at most steps fail.
TEST(Metamorphic, GncHoldsWhatItHolds) {
  checkTerrains(perception::ShadowMethod::Gnc, {{"2x", "4x"}, kAll, {"2x", "4x"}, {}});
}

// shadows: gnc_bridge: RMS error and hidden cells known beyond 3σ_z at every step; coverage at
// finer resolution, visible cells called shadow at 4x. Coverage and visible cells called shadow
// with all off (and without mixed pixels on mars) fail.
TEST(Metamorphic, GncBridgeHoldsWhatItHolds) {
  checkTerrains(perception::ShadowMethod::GncBridge, {{"2x", "4x"}, kAll, {"4x"}, kAll});
}

}  // namespace
}  // namespace ambler::eval
