#pragma once
// What the stages of one run share (docs/architecture.md): the scenario and where it writes, the
// world and its ground truth, each view's products as the stages make them, and the metrics.
// A stage reads what earlier stages left here and adds its own; it never reaches into another
// stage's code.
#include <Eigen/Geometry>
#include <chrono>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "eval/geo/geotiff.hpp"
#include "eval/run/pair_registration.hpp"
#include "eval/scenario/scenario.hpp"
#include "perception/elevation_map.hpp"
#include "perception/registration.hpp"
#include "perception/scan_to_map.hpp"
#include "base/stopwatch.hpp"
#include "eval/score/footfall_score.hpp"
#include "sim/erim_scanner.hpp"
#include "sim/ground_truth.hpp"
#include "sim/ray_scene.hpp"
#include "sim/world.hpp"

namespace ambler::eval {

// One view's products.
struct ViewState {
  Eigen::Isometry3d T_WS = Eigen::Isometry3d::Identity();  // the true sensor pose
  std::optional<sim::Scan> scan;                            // scan stage
  std::optional<perception::ElevationMap> truth;            // map stage: ground truth on the map grid
  std::optional<perception::Raster<std::uint8_t>> visibility;  // and what the sensor could see of it
  std::optional<perception::ScanMap> locus;                 // map stage: the locus map
};

// One registration's estimate (match stage), for the stages after it.
struct PairEstimate {
  int i = 0, j = 0;
  MatchMethod method = MatchMethod::IconicLm;
  Eigen::Isometry3d T_IJ = Eigen::Isometry3d::Identity();  // sensor J in sensor I's frame, estimated
  perception::PoseVector nu = perception::PoseVector::Zero();  // the correction (registerViews' ν)
  std::optional<perception::Matrix6d> covariance;             // of ν, when the method gives one
  bool covariance_calibrated = false;                          // covarianceCalibrated(method)
  bool accepted = true;                                        // the rover's verdict (perception::Assessment)
  Eigen::Isometry3d T_WS_i = Eigen::Isometry3d::Identity();    // view I as registration had it
  Eigen::Isometry3d believed_WS_j = Eigen::Isometry3d::Identity();  // view J believed, in that frame
};

// One footfall method's choice (footfall stage), for the leg after it.
struct RunState {
  const Scenario& scenario;
  std::filesystem::path out;
  bool progress = true;
  const CustomMethods* custom = nullptr;  // a user's own registration methods (RunOptions::custom)

  std::optional<sim::World> world;  // world stage
  GeoFrame geo;                     // world stage: the CRS of map rasters (a DEM's, or a local frame)
  std::optional<terrains::TerrainSpec> terrain_resolved;  // world stage, a DEM: the terrain with the window
                                                          // centre and vertical offset it read from the file
  std::optional<terrains::Terrain> terrain;  // world stage: the generated terrain (none for an MJCF world)
  std::filesystem::path world_xml;  // world stage: the world's MJCF in the run directory
  std::unique_ptr<sim::RayScene> scene;
  std::unique_ptr<sim::GroundTruth> truth;
  std::vector<ViewState> views;      // one per scenario view
  std::vector<PairEstimate> estimates;  // match stage: per pair and method, in run order
  std::optional<perception::ElevationMap> composite;  // merge stage
  std::vector<FootfallChoice> choices;  // footfall stage: per method, in the scenario's order
  std::optional<perception::ElevationMap> footfall_truth;  // footfall stage: the truth on its map's grid

  nlohmann::ordered_json metrics;    // metrics.json; stages add their keys in stage order
  nlohmann::ordered_json timing;     // metrics.json's timing_s: seconds per stage

  // A progress line on stderr ("ambler: ..."), when progress is on.
  void say(const std::string& line) const;
  // Adds `seconds` to timing_s[key].
  void addTime(const char* key, double seconds);
};

// "view_<k>": the stem of view k's files.
std::string viewName(int k);

}  // namespace ambler::eval
