// The world stage of `ambler run` (eval/run/stages/world.cpp): views it refuses before anything is written.
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

// A view inside a rock, below the ground or off the terrain is refused before the run writes
// anything, in one line naming the view and both heights (docs/errors.md, "Views").
TEST(Run, ViewsInsideARockOrBelowTheGroundAreRefusedBeforeAnythingIsWritten) {
  const Scenario good = parseScenario(kScenario, "inline.yaml");
  const terrains::Terrain terrain = terrains::makeTerrain(good.terrain, good.seed);
  ASSERT_FALSE(terrain.rocks.empty());
  // The highest point of any rock: the surface there is the rock's top, above the ground.
  Eigen::Vector3d apex(0, 0, -1e9);
  for (const auto& rock : terrain.rocks)
    for (const auto& v : rock.vertices)
      if ((rock.center + v).z() > apex.z()) apex = rock.center + v;
  const double ground = *terrain.ground.height(apex.x(), apex.y());
  ASSERT_GT(apex.z() - 0.02, ground);
  test::TempDir tmp;
  const auto refusal = [&](const Eigen::Vector3d& xyz) {
    Scenario sc = good;
    sc.views[1].xyz_m = xyz;
    try {
      runScenario(sc, {tmp.dir / "out", false});
    } catch (const ScenarioError& e) {
      return std::string(e.what());
    }
    return std::string("(no error)");
  };
  const std::string in_rock = refusal({apex.x(), apex.y(), apex.z() - 0.02});
  EXPECT_EQ(in_rock.rfind("inline.yaml: views[1].xyz_m: expected the sensor above the terrain, whose surface is at z = ", 0), 0u)
      << in_rock;
  char top[32];
  std::snprintf(top, sizeof top, "%.3f", apex.z());
  EXPECT_NE(in_rock.find(std::string("z = ") + top + " there"), std::string::npos) << in_rock;
  const std::string below = refusal({0.5, -3.0, ground - 5});
  EXPECT_NE(below.find("views[1].xyz_m: expected the sensor above the terrain"), std::string::npos) << below;
  // Built in code, past the reader's check: off the heightfield, no ground under the sensor.
  EXPECT_EQ(refusal({40, 0, 2}),
            "inline.yaml: views[1].xyz_m: expected a sensor over the terrain, got [40, 0, 2], where there is no ground");
  EXPECT_FALSE(fs::exists(tmp.dir / "out"));
}

}  // namespace
}  // namespace ambler::eval
