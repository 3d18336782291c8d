#pragma once
// A scenario: what one `ambler run` does. Loaded from YAML (docs/scenario.md lists every key and
// default); angles are degrees in the file and radians here.
#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "perception/footfall.hpp"
#include "perception/odometry.hpp"
#include "perception/registration.hpp"
#include "perception/map_grid.hpp"
#include "perception/scan_to_map.hpp"
#include "perception/sensor_model.hpp"
#include "terrains/terrain.hpp"

namespace ambler::eval {

// Bad input in a scenario file: the message names the file and the key.
class ScenarioError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};


struct ViewSpec {
  Eigen::Vector3d xyz_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d rpy_rad = Eigen::Vector3d::Zero();  // roll, pitch, yaw
};

// The map a scenario compares the locus map with.
enum class Baseline : std::uint8_t { None, Cartesian };

// The YAML words of the closed sets (as in docs/scenario.md).
const char* shadowsName(perception::ShadowMethod m);
const char* baselineName(Baseline b);

struct MapSpec {
  double cell_m = 0.10;
  Eigen::Vector2d x_m{-5.0, 5.0};
  Eigen::Vector2d y_m{-3.0, 8.0};
  double epsilon_rad = 1.0e-5;
  perception::ShadowMethod shadows = perception::ShadowMethod::Gnc;  // gnc | gnc_bridge | none
  Baseline baseline = Baseline::Cartesian;                           // cartesian | none

  // The grid of the map region (in the world frame; in a traverse, in each stop's heading frame:
  // docs/scenario.md, "traverse"), and what the map stage asks of scanToMap.
  perception::MapGrid grid() const;
  perception::ScanToMapConfig scanToMapConfig() const;
};

// The registration methods a `matching:` section may name (docs/scenario.md, "matching"): the
// paper's (perception::registerViews) and the Open3D peers (eval/peers/).
enum class MatchMethod : std::uint8_t {
  Features,
  Iconic,           // the paper's descent as printed (eq. 4–8)
  FeaturesIconic,   // the paper's two stages
  IconicRobust,     // our descent (docs/matching.md, "The paper's descent, and ours")
  FeaturesIconicRobust,
  IconicLm,
  IconicWeighted,
  FeaturesLm,       // features, then Levenberg–Marquardt
  IcpPointToPlane,  // peers: Open3D's point-to-plane ICP,
  Gicp,             // generalized ICP,
  Fgr,              // fast global registration on FPFH features, refined by point-to-plane ICP
  FeaturesIconicWeighted,  // features, then the weighted LM
};
// The paper's method behind m, or nullopt for a peer.
std::optional<perception::RegistrationMethod> paperMethod(MatchMethod m);
// The scenario's name of a method ("features+iconic"; in file names, eval/pictures/match_figures.hpp's
// methodFileName).
const char* matchMethodName(MatchMethod m);
// Every method, in the order a refusal lists their names; and a name back to its method.
const std::vector<MatchMethod>& matchMethods();
std::optional<MatchMethod> matchMethodFromName(std::string_view name);
// Whether the method's covariance is calibrated (its mean NEES within [4.5, 7.5] across three
// terrain kinds, tests/integration/test_matching_calibration.cpp; docs/matching.md,
// "Calibration"): iconic_weighted's (and features+iconic_weighted's), with the sensors it was
// measured with: the ERIM's pixel grid and beam (mixed pixels on, no dropouts), its 7.62 cm counts
// and noise from half its own to its own. The merge propagates only calibrated covariances.
bool covarianceCalibrated(MatchMethod m, const perception::SensorModel& sensor);

struct MatchingSpec {
  std::vector<std::pair<int, int>> pairs;  // (I, J): view J registered against view I
  std::vector<MatchMethod> methods{MatchMethod::IconicLm};
  ViewSpec initial_error;                  // the rover's dead-reckoning error E: T_0 = T_IJ·E
  double success_translation_m = 0.05;
  double success_rotation_deg = 0.5;
  // The rover's prior on its dead-reckoning error, as totals: how far the truth may lie from T_0
  // in translation (m) and in turn (degrees). Feature matching searches no further
  // (docs/matching.md). Default: what initial_error's bounds allow, each coordinate within 3 m
  // (the box's diagonal, 3√3 m) and each angle within 30° (their widest composition,
  // acos(9/16) = 55.8°).
  double prior_translation_m = 5.196152422706632;
  double prior_rotation_deg = 55.77113367218742;
  // The rover's verdict (docs/matching.md, "Verification and acceptance") gates the correction by
  // the odometry model at the believed distance between the views (gate odometry), or by the
  // declared prior taken as three σ (gate prior: every correction within it passes; basins).
  perception::OdometryModel odometry;
  bool gate_by_prior = false;

  // draw_initial_error: E is drawn, per pair, from the odometry model (seeded by the scenario's
  // seed and the pair), within its 99 % region (docs/matching.md, "The rover's prior"), instead of
  // initial_error (which must then be absent).
  bool draw_initial_error = false;

  // What the rover believes of sensor J's pose in sensor I's frame, given the truth T_IJ:
  // T_0 = T_IJ·E (E drawn for pair (i, j) under `seed` when draw_initial_error).
  Eigen::Isometry3d initialEstimate(const Eigen::Isometry3d& T_IJ, std::uint64_t seed = 0, int i = 0, int j = 1) const;
};

// The composite map (docs/scenario.md, "merge"): every view's scan mapped on one grid at its pose
// and merged by eq. 9.
enum class MergePoses : std::uint8_t {
  Matched,  // each view placed by the first listed matching method's estimates, chained from view 0
  True,     // the true poses: mapping error alone
};
const char* mergePosesName(MergePoses p);

struct MergeSpec {
  MergePoses poses = MergePoses::Matched;
  double cell_m = 0.10;              // default: map.cell_m
  Eigen::Vector2d x_m{-5.0, 5.0};    // default: map.region
  Eigen::Vector2d y_m{-3.0, 8.0};
  perception::MapGrid grid() const;  // in view 0's world frame
};

// Footfall evaluation (docs/scenario.md, "footfall"; docs/footfall.md): the paper's five
// methods and the uncertainty-aware one over a region of a map.
struct FootfallSpec {
  int map_view = -1;                // the map evaluated: -1 the composite, else view k's map
  Eigen::Vector2d x_m{0.0, 2.0};    // R of §5, in the world frame
  Eigen::Vector2d y_m{1.0, 3.0};
  double foot_diameter_m = 0.30;
  std::vector<perception::FootfallMethod> methods{perception::kFootfallMethods.begin(),
                                                  perception::kFootfallMethods.end()};
  // The candidate centres: the cells of `grid` whose centres lie at least a foot radius inside the
  // region, so that the whole foot B lies in R (§5: B is a subregion of R).
  perception::CellRegion candidates(const perception::MapGrid& grid) const;
};

// The simulated leg (docs/scenario.md, "leg"): steps on each method's choice.
enum class Soil : std::uint8_t { Sand, Rock };
const char* soilName(Soil s);
struct LegSpec {
  Soil soil = Soil::Sand;
  double load_n = 4000;
};

// A traverse (docs/scenario.md, "traverse"; docs/traverse.md): the rover walks a path, stops
// every stop_spacing_m, scans, maps, registers the new view and merges it into a running
// composite. It generates its views: `views:` is refused beside it.
enum class TraverseRegister : std::uint8_t {
  Composite,  // the new view against the running composite (map to model)
  Previous,   // against the previous stop's view
  None,       // no registration: dead reckoning alone
};
const char* traverseRegisterName(TraverseRegister r);

// The simulated odometry's error per step of horizontal length d (docs/traverse.md): each
// horizontal component of the measured displacement is (1 + translation_bias)·true +
// N(0, (translation_sigma_per_m·d)²), the height change true + N(0, (translation_sigma_per_m·d)²),
// the turn true + heading_bias_deg_per_m·d + N(0, (heading_sigma_deg_per_m·d)²). Seeded by the
// scenario's seed and the stop.
struct TraverseOdometry {
  double translation_sigma_per_m = 0.02;
  double heading_sigma_deg_per_m = 0.5;
  double translation_bias = 0.0;        // scale error of the measured displacement (slip: < 0)
  double heading_bias_deg_per_m = 0.0;  // a systematic turn
};

struct TraverseSpec {
  // The path in the terrain's frame: at least two points (path.waypoints_xy_m, or path.start_xy_m,
  // heading_deg and length_m, which make two).
  std::vector<Eigen::Vector2d> waypoints_xy_m;
  double stop_spacing_m = 1.0;
  double footprint_radius_m = 1.0;  // the body's ground plane is fitted over this disk
  perception::Mount mount;
  TraverseOdometry odometry;
  perception::LocalisationDrift drift;  // the rover's belief of its drift: the composite's σ
  TraverseRegister reg = TraverseRegister::Composite;
  MatchMethod method = MatchMethod::FeaturesLm;  // features+iconic_lm; any matching method
};

struct Scenario {
  std::filesystem::path file;       // where it was loaded from (for messages and relative paths)
  std::string name;
  std::string description;          // free text; "" when absent
  std::uint64_t seed = 0;
  terrains::TerrainSpec terrain;
  perception::SensorModel sensor;
  std::vector<ViewSpec> views;
  std::optional<MapSpec> map;       // absent: no maps
  std::optional<MatchingSpec> matching;  // absent: no registration
  std::optional<MergeSpec> merge;        // absent: no composite
  std::optional<FootfallSpec> footfall;  // absent: no footfall evaluation
  std::optional<LegSpec> leg;            // absent: no leg (needs footfall)
  std::optional<TraverseSpec> traverse;  // absent: the views are `views:`
};

// What the matchers are told (docs/matching.md): the locus settings and sensor model of the map
// section, and the rover's prior on its dead-reckoning error (matching.prior; by default what the
// initial_error key's bounds allow: 3√3 m and a 55.8° turn), not the error itself.
perception::RegistrationConfig registrationConfig(const Scenario& sc);
// The locus settings of the map section: how any stage maps a scan (each scan brings its sensor).
perception::LocusConfig locusConfig(const Scenario& sc);

// Loads and validates a scenario. Throws ScenarioError naming the file and the key for a missing
// file, bad YAML, an unknown key, a wrong type or an out-of-range value.
Scenario loadScenario(const std::filesystem::path& file);

// The same from YAML text; `file` is only used in messages and to resolve relative paths.
Scenario parseScenario(const std::string& yaml_text, const std::filesystem::path& file);

// The scenario with every default filled in, as YAML (degrees, as in the input).
// parseScenario(resolvedYaml(s), s.file) gives back s bit for bit when s came from parseScenario;
// an angle set in code as radians may read back one ulp off (no degree double maps onto it).
std::string resolvedYaml(const Scenario& scenario);

// `text` as a double-quoted YAML scalar (backslash escapes for quotes, backslashes and control
// characters), so strings read back exactly.
std::string yamlQuoted(std::string_view text);

}  // namespace ambler::eval
