// Range shadows behind small rocks, through the whole pipeline (ERIM emulator, unwrapping, GNC edges,
// locus map) against ground truth. Box rocks of 5–40 cm on flat ground, seen from a 3 m mast at
// 5–10.4 m: where the detector's sensitivity ends, in the units it works in (docs/range_edges.md,
// "Small rocks").
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include "eval/score/map_metrics.hpp"
#include "perception/scan_to_map.hpp"
#include "eval/run/runner.hpp"
#include "perception/sensor_geometry.hpp"
#include "sim/erim_scanner.hpp"
#include "sim/fixtures.hpp"
#include "sim/ground_truth.hpp"

namespace ambler::eval {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;
constexpr double kMast = 3.0;  // sensor height above the ground
const std::vector<double> kHeights{0.05, 0.1, 0.2, 0.4};  // rock heights, one per column of rocks
const std::vector<double> kRockX{-2.4, -0.8, 0.8, 2.4};
const std::vector<double> kRockY{4.0, 6.3, 8.5, 10.0};   // slant ranges ≈ 5, 7, 9, 10.4 m
constexpr double kHalfWidth = 0.15;                       // rocks are 0.3 m square

// Flat ground z = 0 and a 4 × 4 grid of box rocks: height by column, distance by row.
std::string rockField() {
  std::ostringstream xml;
  xml << "<mujoco><worldbody>\n<geom type=\"box\" size=\"20 20 0.1\" pos=\"0 0 -0.1\"/>\n";
  for (std::size_t i = 0; i < kRockX.size(); ++i)
    for (double y : kRockY)
      xml << "<geom type=\"box\" size=\"" << kHalfWidth << " " << kHalfWidth << " " << kHeights[i] / 2 << "\" pos=\""
          << kRockX[i] << " " << y << " " << kHeights[i] / 2 << "\"/>\n";
  xml << "</worldbody></mujoco>";
  return xml.str();
}

struct RockScore {
  long hidden = 0, shadow = 0, bad = 0;  // hidden cells behind the rock; of them Shadow; Known > 3σ_z
};

// The jump in inverse range at the rock's occluding edge, in units of the detector's noise σ_u:
// seen from height h, an obstacle of height H multiplies the range ρ of its rim by h/(h − H), so
// Δu = H/(h·ρ), and σ_u = σ_ρ/ρ² (SensorModel::rangeSigma).
double jumpInNoiseUnits(double height, double y) {
  const double rho = std::hypot(y, kMast - height);  // to the rim
  const perception::SensorModel erim;
  return height / (kMast * rho) / (erim.rangeSigma(rho) / (rho * rho));
}

// Without mixed pixels, a rock whose occlusion jumps by at least 2·h0 = 12 noise units (about eight
// σ_τ above the break threshold h0/√2 = 4.2, so the link breaks in every column whatever the
// noise) has no hidden cell reported known with an error above 3σ_z. Smaller rocks and the ERIM's
// mixed pixels are recorded, not asserted: their bridged cells are the limitation measured in
// docs/range_edges.md ("Small rocks"), not a guarantee of the detector.
TEST(RockShadows, DetectorSensitivityAgainstGroundTruth) {
  const test::MjcfWorld w(rockField());
  const sim::GroundTruth& truth = *w.truth;
  MapSpec map;
  map.cell_m = 0.05;
  map.x_m = {-3.5, 3.5};
  map.y_m = {2.5, 11.5};
  map.baseline = Baseline::None;
  const auto grid = map.grid();
  const perception::ElevationMap truth_map = truth.elevation(grid);
  const perception::Raster<float>& z = truth_map.elevation();
  ViewSpec view;
  view.xyz_m = {0, 0, kMast};
  view.rpy_rad = {0, -30 * kDeg, 0};
  const Eigen::Isometry3d pose = perception::sensorPose(view.xyz_m, view.rpy_rad);

  for (const bool mixed : {false, true}) {
    perception::SensorModel sensor;  // the ERIM defaults
    sensor.mixed_pixels = mixed;
    const perception::Raster<std::uint8_t> vis = truth.visibility(truth_map, pose, sensor);
    std::vector<std::vector<RockScore>> score(kRockX.size(), std::vector<RockScore>(kRockY.size()));
    for (std::uint64_t seed = 1; seed <= 3; ++seed) {
      const sim::Scan scan = sim::ErimScanner(*w.scene, sensor).scan(pose, seed);
      const perception::ScanMap b = perception::scanToMap(scan.image, sensor, pose, grid, map.scanToMapConfig());
      for (int r = 0; r < grid.rows; ++r)
        for (int c = 0; c < grid.cols; ++c) {
          if (vis(r, c) != std::uint8_t(sim::Visibility::Hidden)) continue;
          const Eigen::Vector2d p = grid.center(r, c);
          for (std::size_t i = 0; i < kRockX.size(); ++i)
            for (std::size_t j = 0; j < kRockY.size(); ++j) {
              // the rock's shadow falls behind it, inside its width widened by the perspective
              if (std::abs(p.x() - kRockX[i]) > 0.5 || p.y() < kRockY[j] || p.y() > kRockY[j] + 1.5) continue;
              RockScore& s = score[i][j];
              ++s.hidden;
              const auto state = b.map.stateAt(r, c);
              s.shadow += state == perception::CellState::Shadow;
              s.bad += state == perception::CellState::Known &&
                       std::abs(b.map.elevation()(r, c) - z(r, c)) > 3 * b.map.sigma()(r, c);
            }
        }
    }
    for (std::size_t i = 0; i < kRockX.size(); ++i)
      for (std::size_t j = 0; j < kRockY.size(); ++j) {
        const RockScore& s = score[i][j];
        const double jump = jumpInNoiseUnits(kHeights[i], kRockY[j]);
        if (!mixed && jump >= 2 * perception::GncConfig{}.h0) {
          EXPECT_GT(s.hidden, 50) << "H " << kHeights[i] << " y " << kRockY[j] << ": the rock must cast a shadow";
          EXPECT_EQ(s.bad, 0) << "H " << kHeights[i] << " y " << kRockY[j] << ": jump " << jump;
        }
        RecordProperty(std::string(mixed ? "mixed" : "clean") + "_H" + std::to_string(int(100 * kHeights[i])) + "_y" +
                           std::to_string(int(10 * kRockY[j])) + "_bad",
                       std::to_string(s.bad));
        std::printf("%s H %.2f m y %5.2f m: jump %5.1f sigma_u, hidden %3ld, shadow %3ld (recall %.2f), known > 3 sigma_z %3ld\n",
                    mixed ? "mixed   " : "no mixed", kHeights[i], kRockY[j], jump, s.hidden, s.shadow,
                    s.hidden ? double(s.shadow) / s.hidden : 0.0, s.bad);
      }
  }
}

}  // namespace
}  // namespace ambler::eval
