#pragma once
// Registration that knows when it has failed (docs/matching.md, "Verification and acceptance"):
// the rover's prior on its dead-reckoning error, the choice among refined hypotheses by their
// robust iconic cost over the lines they all have, and the rover's verdict on a registration.
// Onboard code: nothing here sees a true pose.
#include <Eigen/Geometry>
#include <algorithm>
#include <limits>
#include <string>
#include <vector>

#include "perception/elevation_map.hpp"
#include "perception/iconic.hpp"
#include "perception/locus_mapper.hpp"
#include "perception/rigid_transform.hpp"

namespace ambler::perception {

// The rover's prior on its error between two views, σ per axis: translation (m, each of x, y, z)
// and rotation (degrees, each of the three angles of the rotation vector).
struct PriorSigma {
  double translation_m = 0.15;
  double rotation_deg = 2.0;
};

// Dead reckoning's error grows with the distance walked: σ = max(floor, per_m · distance), for
// translation and for heading (the rotation's σ; roll and pitch, which an inclinometer bounds,
// are given the heading's). Defaults (docs/matching.md, "The rover's prior"): a walker's
// kinematic odometry on loose, rocky ground, 15 % of the distance and 2° a metre.
struct OdometryModel {
  double translation_per_m = 0.15;
  double translation_floor_m = 0.05;
  double heading_deg_per_m = 2.0;
  double heading_floor_deg = 0.5;
  PriorSigma at(double distance_m) const {
    const double d = distance_m > 0 ? distance_m : 0.0;
    return {std::max(translation_floor_m, translation_per_m * d), std::max(heading_floor_deg, heading_deg_per_m * d)};
  }
};

// The thresholds of the verdict and their derivation (docs/matching.md):
struct AcceptanceConfig {
  PriorSigma prior;
  // The correction's squared Mahalanobis distance under the prior is χ² with 6 degrees of
  // freedom; at most its 99.9 % point (a true correction is refused once in a thousand).
  double max_mahalanobis2 = 22.458;
  // A line agrees when |r| ≤ inlier_sigmas·σ (σ² = σ₁² + σ₂², the two maps' σ_z): under the
  // sensor model 99.7 % of the lines at the true pose do. At least min_inlier_fraction of the
  // overlap must agree: at the truth only what the model leaves out disagrees (a rock's side one
  // view saw, an edge's mixed pixels; measured at most 0.2 % of the lines over 1 500 refined
  // registrations on four terrain kinds, docs/matching.md), at a wrong pose much of the terrain.
  // 2 % allows ten times what was measured.
  double inlier_sigmas = 3.0;
  double min_inlier_fraction = 0.98;
  // The overlap: at least min_overlap_lines lines, and min_overlap_fraction of map 1's known cells.
  long min_overlap_lines = 200;
  double min_overlap_fraction = 0.05;
  // The method stopped at a minimum of its own cost: one Gauss–Newton step of that cost from the
  // estimate (IconicResult::step_mahalanobis2) predicts a decrease of E/σ² of at most χ²₆'s
  // 99.9 % point, i.e. the cost's minimum lies inside the estimate's own 99.9 % region. At a
  // minimum it is about 0; a descent that stalled on a long valley of the cost stops short of it
  // by more than its noise allows.
  double max_step_mahalanobis2 = 22.458;
};

struct Assessment {
  bool accepted = false;
  std::vector<std::string> reject_reasons;  // empty when accepted
  long overlap = 0;                         // lines that meet image 2 at the estimate
  double overlap_fraction = 0;              // of map 1's known cells
  double inlier_fraction = 0;               // of the overlap, |r/σ| ≤ inlier_sigmas
  double rms_normalized = 0;                // RMS of r/σ over the agreeing lines
  double mahalanobis2 = 0;                  // of the correction under the prior
  double correction_m = 0, correction_deg = 0;  // the correction: believed → estimated pose of sensor J
  bool degenerate = false;
  std::vector<std::string> free_directions;
  double step_mahalanobis2 = std::numeric_limits<double>::quiet_NaN();  // the method's, NaN if none
};

// The correction of sensor J's pose, δ = believed⁻¹·estimated (in the believed sensor's frame,
// where the dead-reckoning error E lives: believed = truth·E), and its squared Mahalanobis
// distance |δt|²/σ_t² + |δθ|²/σ_θ².
double correctionMahalanobis2(const Eigen::Isometry3d& believed_WS, const Eigen::Isometry3d& estimated_WS,
                              const PriorSigma& prior);

// The verdict on ν (map 1's frame → the frame image 2's believed pose `believed_WS` lives in, as
// registerViews returns it): the lines' agreement and overlap at ν (normalizedResiduals), the
// correction under the prior, the surface's degeneracy at ν (the method's, or if null degeneracy()
// of JᵀJ there) and, when
// the method gives one, whether its covariance is positive definite, and whether it stopped at a
// minimum of its own cost (step_mahalanobis2, IconicResult's; NaN: the method does not say).
// Every failed test is one reason. residuals: the lines' normalized residuals at ν if the method
// kept them (IconicResult::residuals_u), else they are evaluated. Deterministic.
Assessment assessRegistration(const ElevationMap& map1, const LocusMapper& image2, const PoseVector& nu,
                              const Eigen::Isometry3d& believed_WS, const Matrix6d* covariance,
                              const Degeneracy* degeneracy, const AcceptanceConfig& config,
                              const std::vector<double>* residuals = nullptr,
                              double step_mahalanobis2 = std::numeric_limits<double>::quiet_NaN());

// Verification: the robust cost Σ c²·ln(1 + u²/c²) of each hypothesis's normalized residuals
// (normalizedResiduals, one vector per hypothesis, all on map 1's cells) over the lines every
// hypothesis has; `common` receives their number. Lines that one hypothesis's overlap lacks do not
// decide between them.
std::vector<double> commonOverlapCosts(const std::vector<std::vector<double>>& residuals, double c, long* common);

}  // namespace ambler::perception
