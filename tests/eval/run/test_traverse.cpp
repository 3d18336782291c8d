// The traverse stage of `ambler run` (eval/run/stages/traverse.cpp), end to end on small scenes:
// the poses it writes against dead reckoning and the truth, and its metrics.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "eval/run/runner.hpp"
#include "eval/scenario/scenario.hpp"
#include "test_support.hpp"

namespace ambler::eval {
namespace {

using test::slurp;

// poses.csv as rows of cells (no cell here holds a comma but reject_reasons, which is last).
std::vector<std::vector<std::string>> readPoses(const std::filesystem::path& file) {
  std::istringstream in(slurp(file));
  std::vector<std::vector<std::string>> rows;
  for (std::string line; std::getline(in, line);) {
    std::vector<std::string> cells;
    std::string cell;
    std::istringstream l(line);
    while (std::getline(l, cell, ',')) cells.push_back(cell);
    rows.push_back(cells);
  }
  return rows;
}

int column(const std::vector<std::string>& header, const std::string& name) {
  for (std::size_t i = 0; i < header.size(); ++i)
    if (header[i] == name) return int(i);
  ADD_FAILURE() << "no column " << name;
  return 0;
}

std::string scene(const std::string& terrain, const std::string& reg, const std::string& odometry,
                  const std::string& sensor = "{rows: 32, cols: 128}") {
  return "name: traverse_test\nseed: 3\nterrain: " + terrain + "\nsensor: " + sensor +
         "\n"
         "map: {cell_m: 0.2, region: {x_m: [-5, 5], y_m: [3, 11]}}\n"
         "traverse:\n  path: {start_xy_m: [-6, 0], heading_deg: 0, length_m: 6}\n  register: " + reg +
         "\n  odometry: " + odometry + "\n";
}

// Without registration the estimate is dead reckoning: the estimated columns equal the believed
// ones as written (the shortest text of the same doubles), and the drift figures are the same.
TEST(Run, TraverseWithoutRegistrationIsDeadReckoning) {
  const Scenario sc = parseScenario(
      scene("{kind: fractal, size_m: [30, 16], cell_m: 0.1, relief_m: 0.3}", "none",
            "{translation_sigma_per_m: 0.05, heading_sigma_deg_per_m: 2}"),
      "inline.yaml");
  test::TempDir run;
  const auto metrics = runScenario(sc, {run.dir, false});
  const auto rows = readPoses(run.dir / "traverse" / "poses.csv");
  ASSERT_EQ(rows.size(), 8u);  // header and 7 stops
  const auto& h = rows[0];
  int moved = 0;
  for (const char* k : {"x_m", "y_m", "z_m", "roll_deg", "pitch_deg", "yaw_deg"})
    for (std::size_t r = 1; r < rows.size(); ++r) {
      EXPECT_EQ(rows[r][column(h, std::string("estimated_") + k)], rows[r][column(h, std::string("believed_") + k)]);
      moved += rows[r][column(h, std::string("believed_") + k)] != rows[r][column(h, std::string("true_") + k)];
    }
  EXPECT_GT(moved, 6);  // the odometry's errors moved the belief off the truth
  const auto& t = metrics["traverse"];
  EXPECT_EQ(t["final_drift_pct"], t["dead_reckoning_drift_pct"]);
  EXPECT_EQ(t["accepted"], 0);
  EXPECT_EQ(t["rejected"], 0);
  EXPECT_TRUE(std::filesystem::exists(run.dir / "traverse" / "paths.png"));
  EXPECT_TRUE(std::filesystem::exists(run.dir / "traverse" / "error.png"));
  EXPECT_TRUE(std::filesystem::exists(run.dir / "maps" / "composite_elevation.tiff"));
}

// A straight traverse over a plane with exact odometry: every pose is the truth (a plane leaves
// registration degenerate, so the rover keeps its exact dead reckoning), the drift is zero and the
// composite is the plane within the exact sensor's millimetre.
TEST(Run, StraightTraverseOnAPlaneWithExactOdometryIsTheTruth) {
  const Scenario sc = parseScenario(
      scene("{kind: plane, size_m: [30, 16], cell_m: 0.1}", "composite",
            "{translation_sigma_per_m: 0, heading_sigma_deg_per_m: 0}",
            "{noise_k: 0, quantization_m: 0, mixed_pixels: false}"),
      "inline.yaml");
  test::TempDir run;
  const auto metrics = runScenario(sc, {run.dir, false});
  const auto rows = readPoses(run.dir / "traverse" / "poses.csv");
  ASSERT_EQ(rows.size(), 8u);
  const auto& h = rows[0];
  for (std::size_t r = 1; r < rows.size(); ++r) {
    for (const char* k : {"x_m", "y_m", "z_m"})
      EXPECT_NEAR(std::stod(rows[r][column(h, std::string("estimated_") + k)]),
                  std::stod(rows[r][column(h, std::string("true_") + k)]), 1e-9)
          << "stop " << r - 1 << " " << k;
    for (const char* k : {"roll_deg", "pitch_deg", "yaw_deg"})
      EXPECT_NEAR(std::stod(rows[r][column(h, std::string("estimated_") + k)]),
                  std::stod(rows[r][column(h, std::string("true_") + k)]), 1e-7)
          << "stop " << r - 1 << " " << k;
  }
  const auto& t = metrics["traverse"];
  EXPECT_LT(t["final_drift_pct"].get<double>(), 1e-7);
  EXPECT_LT(t["ate_max_m"].get<double>(), 1e-9);
  EXPECT_EQ(t["stops"], 7);
  EXPECT_EQ(t["accepted"].get<int>() + t["rejected"].get<int>(), 6);
  // The plane, mapped by an exact 64 × 256 sensor from exact poses: within the 2 mm that bilinear
  // interpolation of ρ between pixels allows where beams meet the plane at 10° or more within
  // 15 m (tests/perception/test_scan_to_map.cpp); here at least 14° within 12 m.
  EXPECT_LT(t["composite"]["max_abs_error_m"].get<double>(), 2e-3);
  EXPECT_GT(t["composite"]["coverage"].get<double>(), 0.95);
}

}  // namespace
}  // namespace ambler::eval
