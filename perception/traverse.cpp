#include "perception/traverse.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <limits>
#include <string>

#include "perception/composite.hpp"

namespace ambler::perception {

namespace {

double secondsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// The body under a sensor: T_WB = T_WS·T_BS⁻¹.
Eigen::Isometry3d bodyUnder(const Eigen::Isometry3d& T_WS, const Mount& mount) {
  return T_WS * sensorOnBody(Eigen::Isometry3d::Identity(), mount).inverse();
}

// Copies `block` into `map`'s cells at (row0, col0).
void paste(ElevationMap& map, Raster<float>& shared, const ElevationMap& block, const Raster<float>& block_shared,
           const CorridorWindow& w) {
  const int rows = w.grid.rows, cols = w.grid.cols;
  map.elevation().block(w.row0, w.col0, rows, cols) = block.elevation();
  map.sigma().block(w.row0, w.col0, rows, cols) = block.sigma();
  map.state().block(w.row0, w.col0, rows, cols) = block.state();
  map.shadowCeiling().block(w.row0, w.col0, rows, cols) = block.shadowCeiling();
  shared.block(w.row0, w.col0, rows, cols) = block_shared;
}

}  // namespace

ElevationMap cropMap(const ElevationMap& map, const CorridorWindow& w) {
  ElevationMap out(w.grid);
  const int rows = w.grid.rows, cols = w.grid.cols;
  if (w.row0 < 0 || w.col0 < 0 || w.row0 + rows > map.grid().rows || w.col0 + cols > map.grid().cols)
    throw std::invalid_argument("cropMap: the window is not inside the map");
  out.elevation() = map.elevation().block(w.row0, w.col0, rows, cols);
  out.sigma() = map.sigma().block(w.row0, w.col0, rows, cols);
  out.state() = map.state().block(w.row0, w.col0, rows, cols);
  out.shadowCeiling() = map.shadowCeiling().block(w.row0, w.col0, rows, cols);
  return out;
}

Eigen::AlignedBox2d regionBox(const Eigen::Vector2d& xy, double heading, const Eigen::Vector2d& region_x,
                              const Eigen::Vector2d& region_y) {
  const Eigen::Vector2d f(std::cos(heading), std::sin(heading)), right(std::sin(heading), -std::cos(heading));
  Eigen::AlignedBox2d box;
  for (const double x : {region_x.x(), region_x.y()})
    for (const double y : {region_y.x(), region_y.y()}) box.extend(Eigen::Vector2d(xy + x * right + y * f));
  return box;
}

Matrix6d priorNuCovariance(const PriorSigma& prior, const Eigen::Isometry3d& believed_WS) {
  const double r = prior.rotation_deg * M_PI / 180, t = prior.translation_m;
  Matrix6d P_e = Matrix6d::Zero();
  P_e.diagonal() << r * r, r * r, r * r, t * t, t * t, t * t;
  const Matrix6d A_inv = sensorPoseJacobian(PoseVector::Zero(), believed_WS).inverse();
  return A_inv * P_e * A_inv.transpose();
}

Matrix6d driftNuCovariance(const LocalisationDrift& drift, double distance_m, const Eigen::Isometry3d& T_WS) {
  const double d = std::max(0.0, distance_m);
  const double h = drift.translation_sigma_per_m * d, v = drift.vertical_sigma_per_m * d;
  const double yaw = drift.heading_sigma_deg_per_sqrt_m * M_PI / 180 * std::sqrt(d);
  // The error e in sensor J's frame (rx ry rz tx ty tz, sensorPoseJacobian's): a turn about the
  // world's z and a translation along the world's axes, both seen from the sensor.
  const Eigen::Matrix3d Rt = T_WS.linear().transpose();
  const Eigen::Vector3d z = Rt * Eigen::Vector3d::UnitZ();
  Matrix6d P_e = Matrix6d::Zero();
  P_e.topLeftCorner<3, 3>() = yaw * yaw * z * z.transpose();
  P_e.bottomRightCorner<3, 3>() = Rt * Eigen::Vector3d(h * h, h * h, v * v).asDiagonal() * Rt.transpose();
  const Matrix6d A_inv = sensorPoseJacobian(PoseVector::Zero(), T_WS).inverse();
  return A_inv * P_e * A_inv.transpose();
}

Localiser::Localiser(LocaliserConfig config, Registrar registrar)
    : config_(std::move(config)), registrar_(std::move(registrar)) {
  const MapGrid& g = config_.corridor;
  if (!g.inWorldFrame()) throw std::invalid_argument("Localiser: the corridor's grid is not in the world frame");
  if (g.rows <= 0 || g.cols <= 0 || !(g.cell > 0)) throw std::invalid_argument("Localiser: the corridor's grid is empty");
  composite_ = ElevationMap(g);
  composite_shared_ = Raster<float>::Zero(g.rows, g.cols);
}

CorridorWindow Localiser::window(const Eigen::Isometry3d& T_WS) const {
  const MapGrid& g = config_.corridor;
  const Eigen::Vector3d fwd3 = T_WS.linear() * Eigen::Vector3d::UnitY();
  const double heading = std::atan2(fwd3.y(), fwd3.x());
  const Eigen::AlignedBox2d box =
      regionBox(T_WS.translation().head<2>(), heading, config_.region_x_m, config_.region_y_m);
  const double x0 = box.min().x(), x1 = box.max().x(), y0 = box.min().y(), y1 = box.max().y();
  // Whole cells outwards, a box edge within 1e-9 cells of a cell edge taken as on it (as
  // MapGrid::covering rounds).
  constexpr double e = 1e-9;
  const int c0 = std::clamp(int(std::floor((x0 - g.x_min) / g.cell + e)), 0, g.cols);
  const int c1 = std::clamp(int(std::ceil((x1 - g.x_min) / g.cell - e)), c0, g.cols);
  const int r0 = std::clamp(int(std::floor((g.y_max - y1) / g.cell + e)), 0, g.rows);
  const int r1 = std::clamp(int(std::ceil((g.y_max - y0) / g.cell - e)), r0, g.rows);
  CorridorWindow w;
  w.row0 = r0, w.col0 = c0;
  w.grid.cell = g.cell;
  w.grid.x_min = g.x_min + c0 * g.cell;
  w.grid.y_max = g.y_max - r0 * g.cell;
  w.grid.rows = r1 - r0;
  w.grid.cols = c1 - c0;
  return w;
}

void Localiser::merge(const ScanMap& scan, const Eigen::Isometry3d& T_WS, const std::optional<Matrix6d>& nu_covariance,
                      const std::optional<Matrix6d>& drift_covariance,
                      const PoseVector& nu, StopEstimate& stop) {
  const auto t0 = std::chrono::steady_clock::now();
  const CorridorWindow w = window(T_WS);
  if (w.grid.rows == 0 || w.grid.cols == 0) return;
  Raster<float> shared;
  ElevationMap map = mapForComposite(scan, T_WS, w.grid, config_.map.locus, shared);
  // The pose's σ enters each view's σ and, with drift.shared, the part every view of a cell shares
  // (docs/composite.md): the poses of stops that see the same cells err together (docs/traverse.md).
  if (nu_covariance) addSigma(map, registrationSigma(map, nu, *nu_covariance));
  if (drift_covariance) {
    const Raster<float> drift_sigma = registrationSigma(map, nu, *drift_covariance);
    addSigma(map, drift_sigma);
    if (config_.drift->shared) addShared(shared, map, drift_sigma);
  }
  ElevationMap block = cropMap(composite_, w);
  Raster<float> block_shared = composite_shared_.block(w.row0, w.col0, w.grid.rows, w.grid.cols);
  mergeInto(block, block_shared, map, shared);
  paste(composite_, composite_shared_, block, block_shared, w);
  stop.seconds_merge = secondsSince(t0);
}

ReferenceView Localiser::reference() const {
  const Eigen::Isometry3d& T_WS = previous_->image.T_WS;
  const CorridorWindow w = window(T_WS);
  if (config_.reference == TraverseReference::Composite) return referenceView(cropMap(composite_, w), T_WS);
  return referenceView(*previous_, w.grid, config_.registration, config_.weighted_maps);
}

const StopEstimate& Localiser::start(const RangeImage& measured, const SensorModel& sensor,
                                     const Eigen::Isometry3d& T_WB) {
  if (!stops_.empty()) throw std::logic_error("Localiser::start: the traverse has started");
  StopEstimate stop;
  stop.predicted_WB = stop.estimated_WB = T_WB;
  stop.predicted_WS = stop.estimated_WS = sensorOnBody(T_WB, config_.mount);
  const auto t0 = std::chrono::steady_clock::now();
  ScanMap scan = scanToMap(measured, sensor, stop.estimated_WS, window(stop.estimated_WS).grid, config_.map);
  stop.seconds_map = secondsSince(t0);
  merge(scan, stop.estimated_WS, std::nullopt, std::nullopt, PoseVector::Zero(), stop);
  previous_ = std::move(scan);
  stops_.push_back(std::move(stop));
  return stops_.back();
}

const StopEstimate& Localiser::step(const RangeImage& measured, const SensorModel& sensor,
                                    const OdometryStep& measured_step, const Eigen::Matrix3d& tilt) {
  if (stops_.empty()) throw std::logic_error("Localiser::step: call start first");
  const StopEstimate& last = stops_.back();
  StopEstimate stop;
  stop.predicted_WB = integrate(last.estimated_WB, measured_step, tilt);
  stop.predicted_WS = sensorOnBody(stop.predicted_WB, config_.mount);
  const double step_m = std::hypot(measured_step.dx_m, measured_step.dy_m);
  const bool fixed_last = last.accepted || stops_.size() == 1;
  stop.since_fix_m = (fixed_last ? 0.0 : last.since_fix_m) + step_m;
  stop.distance_m = last.distance_m + step_m;
  stop.fix_distance_m = fixed_last ? last.distance_m : last.fix_distance_m;
  auto t0 = std::chrono::steady_clock::now();
  const ScanMap scan = scanToMap(measured, sensor, stop.predicted_WS, window(stop.predicted_WS).grid, config_.map);
  stop.seconds_map = secondsSince(t0);
  stop.estimated_WS = stop.predicted_WS;
  if (config_.reference != TraverseReference::None) {
    t0 = std::chrono::steady_clock::now();
    RegistrationConfig rc = config_.registration;
    rc.acceptance = acceptanceFor(rc, previous_->image.T_WS.inverse() * stop.predicted_WS);
    stop.registration = registrar_(reference(), scan, stop.predicted_WS, rc);
    stop.registered = true;
    stop.accepted = stop.registration->assessment.accepted;
    stop.seconds_register = secondsSince(t0);
  }
  std::optional<Matrix6d> covariance;
  PoseVector nu = PoseVector::Zero();
  if (stop.accepted) {
    stop.estimated_WS = stop.registration->corrected_WS;
    stop.fix_distance_m = stop.distance_m;
    const IconicResult& res = stop.registration->iconic;
    if (config_.covariance_calibrated && stop.registration->ran_iconic && !res.degenerate &&
        res.covariance.allFinite()) {
      covariance = res.covariance;
      nu = stop.registration->nu;
    }
  } else if (config_.registration.odometry) {
    // The dead-reckoned pose and the prior's σ since the last fix.
    covariance = priorNuCovariance(config_.registration.odometry->at(stop.since_fix_m), stop.predicted_WS);
  }
  // The drift the rover believes it has at its last fix, under whatever this stop adds.
  std::optional<Matrix6d> drift;
  if (config_.drift) drift = driftNuCovariance(*config_.drift, stop.fix_distance_m, stop.estimated_WS);
  // A rejected (or absent) registration keeps the dead-reckoned pose as it is.
  stop.estimated_WB = stop.accepted ? bodyUnder(stop.estimated_WS, config_.mount) : stop.predicted_WB;
  merge(scan, stop.estimated_WS, covariance, drift, nu, stop);
  previous_ = scan;
  previous_->image.T_WS = stop.estimated_WS;
  stops_.push_back(std::move(stop));
  return stops_.back();
}

}  // namespace ambler::perception
