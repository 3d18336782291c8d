// `ambler run` end to end: every scan file of SCENARIO.md, consistent with itself, and the same
// scenario and seed give byte-identical files.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "eval/io.hpp"
#include "eval/runner.hpp"
#include "eval/scenario.hpp"
#include "test_support.hpp"

namespace ambler::eval {
namespace {

namespace fs = std::filesystem;
using test::slurp;

const char* kScenario = R"(
name: run_test
seed: 11
terrain:
  kind: mars
  size_m: [8, 8]
  cell_m: 0.1
  relief_m: 0.4
  rocks: {abundance_k: 0.1, min_diameter_m: 0.15, max_diameter_m: 0.8}
  craters: {count: 2, min_diameter_m: 1.0, max_diameter_m: 2.0}
sensor:
  rows: 32
  cols: 128
views:
  - {xyz_m: [0, -3.5, 2.0], rpy_deg: [0, -30, 0]}
  - {xyz_m: [0.5, -3.0, 2.0], rpy_deg: [0, -35, 10]}
)";

TEST(Run, WritesEveryScanFileOfTheContract) {
  const Scenario sc = parseScenario(kScenario, "inline.yaml");
  test::TempDir run;
  const auto metrics = runScenario(sc, {run.dir, false});
  for (const char* f : {"metrics.json", "scenario.resolved.yaml", "terrain.png", "world/world.xml", "world/terrain.bin"})
    EXPECT_TRUE(fs::exists(run.dir / f)) << f;
  for (int k = 0; k < 2; ++k) {
    const fs::path base = run.dir / "scans" / ("view_" + std::to_string(k));
    for (const char* suffix : {"_range.tiff", "_meta.json", ".ply", ".png"})
      EXPECT_TRUE(fs::exists(base.string() + suffix)) << base.string() + suffix;
    const perception::Raster<float> range = readTiff(base.string() + "_range.tiff");
    ASSERT_EQ(range.rows(), 32);
    ASSERT_EQ(range.cols(), 128);
    long valid = 0;
    for (long i = 0; i < range.size(); ++i) valid += std::isfinite(range.data()[i]);
    const auto& m = metrics["scan"][k];
    EXPECT_EQ(m["rays"].get<long>(), 32 * 128);
    EXPECT_NEAR(m["valid_fraction"].get<double>(), double(valid) / range.size(), 1e-12);
    // The PLY holds exactly the returns.
    const std::string ply = slurp(base.string() + ".ply");
    EXPECT_NE(ply.find("element vertex " + std::to_string(valid) + "\n"), std::string::npos);
    const auto meta = nlohmann::json::parse(slurp(base.string() + "_meta.json"));
    EXPECT_EQ(meta["phi_rad"].size(), 32u);
    EXPECT_EQ(meta["theta_rad"].size(), 128u);
    EXPECT_GT(meta["phi_rad"][0].get<double>(), meta["phi_rad"][31].get<double>());  // row 0 on top
    // σ = kρ² at ≤ 6 m is ≤ 1 cm, quantisation adds q/√12 = 2.2 cm: RMS well under 5 cm.
    EXPECT_LT(m["range_error_rms_m"].get<double>(), 0.05);
  }
  const auto on_disk = nlohmann::json::parse(slurp(run.dir / "metrics.json"));
  EXPECT_EQ(on_disk["name"], "run_test");
  EXPECT_EQ(on_disk["seed"], 11);
  EXPECT_TRUE(on_disk.contains("timing_s"));
}

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
