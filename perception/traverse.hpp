#pragma once
// The rover's side of a traverse (docs/traverse.md): at each stop it maps its scan from the pose
// odometry predicts, registers the new view against the running composite (or the previous
// view), accepts or rejects the correction by its own verdict, merges the view into a composite
// that covers the whole corridor, and carries the corrected pose to the next stop. Onboard code:
// it sees scans, odometry steps and inclinometer tilts, never the truth.
#include <Eigen/Geometry>
#include <functional>
#include <optional>
#include <vector>

#include "perception/elevation_map.hpp"
#include "perception/map_grid.hpp"
#include "perception/odometry.hpp"
#include "perception/range_image.hpp"
#include "perception/registration.hpp"
#include "perception/scan_to_map.hpp"
#include "perception/sensor_model.hpp"

namespace ambler::perception {

// What a new view is registered against.
enum class TraverseReference : std::uint8_t {
  Composite,  // the running composite over the previous stop's window (map to model)
  Previous,   // the previous stop's view alone
  None,       // nothing: dead reckoning alone
};

// A stop's part of the corridor: a world-aligned grid on the corridor's lattice (row0, col0 its
// first cell in the corridor).
struct CorridorWindow {
  MapGrid grid;
  int row0 = 0, col0 = 0;
};

struct LocaliserConfig {
  TraverseReference reference = TraverseReference::Composite;
  Mount mount;
  // The composite's grid: world-aligned (T_WM the identity), covering every stop's window.
  MapGrid corridor;
  // What each stop maps: x ∈ region_x_m (right), y ∈ region_y_m (forward) in the frame of the
  // sensor's heading about its position; the window is the world-aligned box around it.
  Eigen::Vector2d region_x_m{-5.0, 5.0};
  Eigen::Vector2d region_y_m{3.0, 14.0};
  ScanToMapConfig map;                // how a scan is mapped (its locus settings merge it too)
  RegistrationConfig registration;    // the registration's settings; its odometry model sets the prior
  bool weighted_maps = false;         // whether the registration reads the weighted maps (readsWeightedMaps)
  // Whether an accepted registration's covariance is calibrated (only then is it propagated into
  // the merged view's σ; docs/composite.md).
  bool covariance_calibrated = false;
  // The pose's own uncertainty in the composite's σ (as a part every view of a cell shares):
  // absent, a view merges with its map's σ alone (and a rejected stop with odometry's σ since the
  // last fix, as before).
  std::optional<LocalisationDrift> drift;
};

// One stop as the rover has it.
struct StopEstimate {
  Eigen::Isometry3d predicted_WB = Eigen::Isometry3d::Identity();  // odometry from the last estimate
  Eigen::Isometry3d estimated_WB = Eigen::Isometry3d::Identity();  // after registration
  Eigen::Isometry3d predicted_WS = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d estimated_WS = Eigen::Isometry3d::Identity();
  bool registered = false;  // a registration ran
  bool accepted = false;    // and the rover accepted it
  double since_fix_m = 0;   // odometry's distance since the last accepted registration (or the start)
  double distance_m = 0;    // odometry's distance from the start
  double fix_distance_m = 0;  // odometry's distance from the start to the last accepted registration
  std::optional<RegistrationResult> registration;
  double seconds_map = 0, seconds_register = 0, seconds_merge = 0;
};

// Registers scan J (believed at believed_WS) against view I: registerViews by a method, or a
// peer's method; config.acceptance holds this stop's prior.
using Registrar = std::function<RegistrationResult(const ReferenceView& view_i, const ScanMap& scan_j,
                                                   const Eigen::Isometry3d& believed_WS, const RegistrationConfig& config)>;

class Localiser {
 public:
  // Throws std::invalid_argument when the corridor is not world-aligned or empty.
  Localiser(LocaliserConfig config, Registrar registrar);

  // The first stop, at a pose the rover knows (the traverse's frame).
  const StopEstimate& start(const RangeImage& measured, const SensorModel& sensor, const Eigen::Isometry3d& T_WB);
  // A later stop: odometry's measured step since the last stop and the inclinometer's tilt here.
  const StopEstimate& step(const RangeImage& measured, const SensorModel& sensor, const OdometryStep& measured_step,
                           const Eigen::Matrix3d& tilt);

  const ElevationMap& composite() const { return composite_; }
  const std::vector<StopEstimate>& stops() const { return stops_; }
  const LocaliserConfig& config() const { return config_; }

  // The window of the corridor a sensor at T_WS maps (clipped to the corridor; may be empty).
  CorridorWindow window(const Eigen::Isometry3d& T_WS) const;

 private:
  // Maps the scan at `T_WS` on its window and merges it with the σ its pose adds: `nu_covariance`'s
  // as the view's own, the drift's as its own too or, with drift.shared, as part of the σ every view
  // of a cell shares.
  void merge(const ScanMap& scan, const Eigen::Isometry3d& T_WS, const std::optional<Matrix6d>& nu_covariance,
             const std::optional<Matrix6d>& drift_covariance, const PoseVector& nu, StopEstimate& stop);
  ReferenceView reference() const;

  LocaliserConfig config_;
  Registrar registrar_;
  ElevationMap composite_;
  Raster<float> composite_shared_;
  std::optional<ScanMap> previous_;  // the previous stop's scan, its image at the estimated pose
  std::vector<StopEstimate> stops_;
};

// The world-aligned box around the region x ∈ region_x (right), y ∈ region_y (forward) of the frame
// at `xy` facing `heading` (radians from world x): what a stop's window covers before it is put
// on the corridor's lattice.
Eigen::AlignedBox2d regionBox(const Eigen::Vector2d& xy, double heading, const Eigen::Vector2d& region_x,
                              const Eigen::Vector2d& region_y);

// The map's cells inside `window` (same lattice), as a map on the window's grid.
ElevationMap cropMap(const ElevationMap& map, const CorridorWindow& window);

// The covariance of ν (registerViews' convention) for a pose error of σ_t on each translation
// axis and σ_r on each rotation axis of the sensor at believed_WS, independent: what a
// dead-reckoned pose's prior adds (A⁻¹·diag·A⁻ᵀ with A = sensorPoseJacobian(0, believed_WS)).
Matrix6d priorNuCovariance(const PriorSigma& prior, const Eigen::Isometry3d& believed_WS);

// The covariance of ν for the drift `drift` says a sensor at T_WS has after `distance_m` metres:
// the world's horizontal axes and its height, independent, and a turn about the world's vertical
// through the sensor (A⁻¹·P_e·A⁻ᵀ as priorNuCovariance).
Matrix6d driftNuCovariance(const LocalisationDrift& drift, double distance_m, const Eigen::Isometry3d& T_WS);

}  // namespace ambler::perception
