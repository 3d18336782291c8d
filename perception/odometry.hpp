#pragma once
// The rover's dead reckoning on a traverse (docs/traverse.md): the body frame, the sensor's
// mounting on it, one odometry step as the legs measure it, and the pose it integrates to.
//
// Body frame B (REP 103): x forward along the heading, y left, z up along the normal of the ground
// plane under the body's footprint; its origin on that plane under the body's centre. The heading
// ψ of a pose is the angle of B's x axis projected on the horizontal plane, from world x; its tilt
// is what is left, R_tilt = Rz(ψ)ᵀ·R_WB (roll and pitch: what an inclinometer measures).
#include <Eigen/Geometry>

namespace ambler::perception {

// The sensor on the body: height_m above B's origin along B's z, looking forward (B's x) and
// pitched by pitch_rad about its own x axis (negative looks down). With the body level and heading
// ψ the sensor's pose is sensorPose(origin + height·z, {0, pitch, ψ − 90°}) (docs/conventions.md).
struct Mount {
  double height_m = 3.0;
  double pitch_rad = -0.5235987755982988;  // −30°
};

// T_WS of the sensor on a body at T_WB.
Eigen::Isometry3d sensorOnBody(const Eigen::Isometry3d& T_WB, const Mount& mount);

// The heading ψ of a body pose (radians, in (−π, π]) and its tilt Rz(ψ)ᵀ·R.
double headingOf(const Eigen::Matrix3d& R_WB);
Eigen::Matrix3d tiltOf(const Eigen::Matrix3d& R_WB);

// One step as odometry measures it, in the frame of the previous stop's heading (gravity-aligned:
// x forward, y left): the planar displacement, the height change and the turn.
struct OdometryStep {
  double dx_m = 0, dy_m = 0, dz_m = 0;
  double dheading_rad = 0;
};

// The step from body pose `from` to `to`, exactly (no error).
OdometryStep stepBetween(const Eigen::Isometry3d& from, const Eigen::Isometry3d& to);

// The pose a step leads to from `from`: heading ψ + dψ, position from + Rz(ψ)·(dx, dy, dz), and
// the tilt `tilt` the inclinometer measures at the new stop (roll and pitch are observed, not
// integrated). integrate(from, stepBetween(from, to), tiltOf(to)) reproduces `to` to rounding.
Eigen::Isometry3d integrate(const Eigen::Isometry3d& from, const OdometryStep& step, const Eigen::Matrix3d& tilt);

// What the rover believes of its own localisation error at its last accepted registration, d
// metres (odometry's count) from the start (docs/traverse.md, "The composite's σ"):
// each horizontal axis σ = translation_sigma_per_m·d, the height vertical_sigma_per_m·d, the
// heading heading_sigma_deg_per_sqrt_m·√d. A drift that grows with distance, as a traverse's does
// (the registrations' errors are not independent steps of a random walk: each new view is tied to
// the composite of several before it); roll and pitch come from the inclinometer and do not drift.
struct LocalisationDrift {
  double translation_sigma_per_m = 0.0033;
  double vertical_sigma_per_m = 0.0003;
  double heading_sigma_deg_per_sqrt_m = 0.067;
  // The σ the pose adds counted as the part of each cell's σ every view of it shares (true), or as
  // each view's own (false). The pose errors of stops 1 to 8 m apart, which see the same cells, are
  // correlated 0.90–0.99 (docs/traverse.md, "The composite's σ").
  bool shared = true;
};

}  // namespace ambler::perception
