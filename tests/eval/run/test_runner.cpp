// `ambler run` as a whole (eval/run/runner.cpp): the same scenario and seed give byte-identical files.
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

// Same scenario, same seed: every file byte-identical (metrics.json after dropping timing_s, the
// one figure that measures the machine rather than the run).
TEST(Run, SameSeedGivesByteIdenticalFiles) {
  const Scenario sc = parseScenario(kScenario, "inline.yaml");
  test::TempDir a, b;
  runScenario(sc, {a.dir, false});
  runScenario(sc, {b.dir, false});
  int files = 0;
  for (const auto& e : fs::recursive_directory_iterator(a.dir)) {
    if (!e.is_regular_file()) continue;
    const fs::path rel = fs::relative(e.path(), a.dir);
    ASSERT_TRUE(fs::exists(b.dir / rel)) << rel;
    if (rel == "metrics.json") {
      auto ja = nlohmann::json::parse(slurp(e.path())), jb = nlohmann::json::parse(slurp(b.dir / rel));
      ja.erase("timing_s"), jb.erase("timing_s");
      EXPECT_EQ(ja.dump(), jb.dump());
    } else {
      EXPECT_EQ(slurp(e.path()), slurp(b.dir / rel)) << rel;
    }
    ++files;
  }
  EXPECT_GT(files, 10);
  Scenario other = sc;
  other.seed = 12;
  test::TempDir c;
  runScenario(other, {c.dir, false});
  EXPECT_NE(slurp(a.dir / "world/terrain.bin"), slurp(c.dir / "world/terrain.bin"));
  EXPECT_NE(slurp(a.dir / "scans/view_0_range.tiff"), slurp(c.dir / "scans/view_0_range.tiff"));
}

}  // namespace
}  // namespace ambler::eval
