#pragma once
// Registering view J against view I by any of the matching methods (paper §4; docs/matching.md):
// feature matching alone, the paper's iconic descent (from T_0, or from feature matching's T_F),
// Levenberg–Marquardt, and its uncertainty-weighted form. What the match stage, `ambler bench
// match` and the experiments call. Onboard code: image J carries the pose the rover believes.
#include <Eigen/Geometry>
#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

#include "perception/acceptance.hpp"
#include "perception/feature_matching.hpp"
#include "perception/features.hpp"
#include "perception/iconic.hpp"
#include "perception/scan_to_map.hpp"

namespace ambler::perception {

enum class RegistrationMethod : std::uint8_t {
  Features,              // feature matching alone: T_F
  Iconic,                // the paper's gradient descent (eq. 4–8) as printed, from T_0
  FeaturesIconic,        // the paper's two stages: that descent from the verified hypotheses
  IconicRobust,          // our descent: robust cost, map 1's normals, a diagonal gain (docs/matching.md)
  FeaturesIconicRobust,  // the two stages with it
  IconicLm,              // Levenberg–Marquardt, robust, coarse to fine, from T_0
  IconicWeighted,        // the same with residuals weighted by 1/(σ₁² + σ₂²)
  FeaturesLm,            // two stages with our second: Levenberg–Marquardt
  FeaturesIconicWeighted,  // two stages with the weighted LM (feature matching on the plain maps)
};

// Whether the method runs feature matching first, then verifies its refined hypotheses.
bool twoStage(RegistrationMethod method);
// Whether the method's iconic stage is the weighted LM, which reads the maps with the footprint's
// σ_z term (RegistrationConfig::locus).
bool readsWeightedMaps(RegistrationMethod method);

struct RegistrationConfig {
  // How both images are met (each scan brings its sensor model). The weighted methods add the
  // footprint's term to σ_z in the maps their iconic stage reads (LocusConfig::footprint_sigma:
  // the two views smooth the terrain over footprints of different size and shape, so between
  // their maps that error is noise); their feature stage reads the plain maps.
  LocusConfig locus;
  FeatureConfig features;     // feature extraction, both maps
  FeatureMatchConfig match;   // predict, verify, search; its max_shift_m is set by registerViews
  // The rover's prior on its dead-reckoning error: translation (m) and rotation (degrees) at most
  // these. A feature at distance d from sensor J moves by at most prior_translation_m +
  // 2·sin(prior_rotation/2)·d between T_0 and the truth (the max_shift_m given to matchFeatures,
  // d the farthest corner of map I's grid); the rotation bounds match.max_rotation_deg. Both are
  // totals: eval's registrationConfig sets those of the scenario's per-axis bounds (the box's
  // diagonal, 3√3 m, and its widest turn, 55.8° for 30° per angle: docs/matching.md).
  double prior_translation_m = 5.2;
  double prior_rotation_deg = 30;
  IconicOptions iconic;
  // The verdict's thresholds and the prior's σ it gates the correction by (eval sets the σ from
  // the scenario: the odometry model at the distance between the views, or a declared prior).
  AcceptanceConfig acceptance;
  // When set, the prior's σ for a pair is this model at the believed distance between the two
  // views (acceptanceFor); otherwise acceptance.prior as given.
  std::optional<OdometryModel> odometry;
  // Verification screens feature matching's pairings on the lines of every screen_stride-th cell.
  int screen_stride = 4;
};

// The verdict's thresholds for a pair whose believed relative pose is T_0 (sensor J in sensor
// I's frame): config.acceptance with the odometry model's σ at |T_0.t| when there is one.
AcceptanceConfig acceptanceFor(const RegistrationConfig& config, const Eigen::Isometry3d& T_0);

// One start of a two-stage method's verification: refined by its iconic method, and scored by
// the robust iconic cost over the lines every hypothesis's estimate has (commonOverlapCosts).
struct RegistrationHypothesis {
  std::string start;                     // "T_F" (feature matching's best), "T_0", "pairing K" (its K-th)
  std::string stage;                     // "screen" (the coarse lines alone) or "refine" (in full)
  PoseVector nu0 = PoseVector::Zero();   // the start (map I's frame → the believed frame of J)
  PoseVector nu = PoseVector::Zero();    // refined
  double D_m = 0;                        // eq. 3 at the start's pairing (T_0: at T_0)
  double cost = 0;                       // mean c²·ln(1 + u²/c²) over its stage's common lines, c = 3σ
  int iterations = 0;
};

struct RegistrationResult {
  PoseVector nu = PoseVector::Zero();  // map I's frame → the believed frame of image J
  // The correction as a motion of map I's frame (the world), exp(ν)⁻¹: the one place ν becomes a
  // pose. It moves sensor J from where the rover believed it to corrected_WS = correction·believed.
  Eigen::Isometry3d correction = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d corrected_WS = Eigen::Isometry3d::Identity();
  int iterations = 0;                  // iconic iterations (0 for features alone)
  IconicResult iconic;                 // the iconic stage's result (iterations, trace, covariance), if it ran
  bool ran_iconic = false;
  // Feature matching, when it ran: both maps' features (each in its map's frame), map J itself
  // (on grid_j), and the match; its ν maps map I's frame to map J's, T_WM_J⁻¹·exp(ν) here.
  std::vector<Feature> features_i, features_j;
  std::optional<ElevationMap> map_j;
  std::optional<FeatureMatch> feature_match;
  // Two-stage methods whose feature stage found a pairing: each pairing screened and the costs
  // over their common lines, then the best and T_0 refined and theirs (common_lines: of these
  // two); chosen indexes the one kept. Empty otherwise.
  std::vector<RegistrationHypothesis> hypotheses;
  int chosen = -1;
  long common_lines = 0;
  // The rover's verdict on nu, made without truth (assessRegistration).
  Assessment assessment;
};

// Verification (docs/matching.md, "Verification"): each start (feature matching's distinct
// pairings, best first, in the believed frame: nu0, start, D_m) is screened by `refine` on the
// lines of every config.screen_stride-th cell; the one of lowest robust cost over the (coarse) lines all
// screened estimates have (commonOverlapCosts, c = acceptance.inlier_sigmas) is refined in full
// from where its screen ended, and so is T_0 (ν = 0); of the two the lower cost over their common
// lines is kept, the pairing's on a tie. So the result is never one that the cost rates worse than
// refining T_0. Without starts, T_0's refinement alone.
using Refiner = std::function<IconicResult(const PoseVector& start, const IconicOptions& options)>;
struct Verification {
  std::vector<RegistrationHypothesis> hypotheses;  // the screens, then the two refinements
  int chosen = -1;                                 // the one kept
  long common_lines = 0;                           // of the two refinements
  IconicResult result;
};
Verification verifyHypotheses(const ElevationMap& map_i, const LocusMapper& image_j,
                              const std::vector<RegistrationHypothesis>& starts, double D0, const Refiner& refine,
                              const RegistrationConfig& config);

// The covariance of sensor J's estimated pose (what is scored), from ν's covariance P: the
// estimate's error as e with T̂(ν + δ) = T̂(ν)·exp(e), rx ry rz tx ty tz in sensor J's frame; to
// first order e = A·δ with A = ∂log(B⁻¹·exp(ν)·exp(ν + δ)⁻¹·B)/∂δ (B the believed pose of sensor J,
// central differences), so the covariance is A·P·Aᵀ. ν's translation is about the world origin, e's
// about sensor J: a yaw error moves them differently (docs/matching.md, "Calibration"). NEES is
// the same in either (first order: an invertible linear map).
Matrix6d sensorPoseCovariance(const PoseVector& nu, const Matrix6d& P, const Eigen::Isometry3d& believed_WS_j);
// The inverse: ν's covariance A⁻¹·C·A⁻ᵀ from a covariance C of sensor J's pose (a method that
// reports the pose's, as a user's own method does). Throws std::invalid_argument when A is singular.
Matrix6d nuCovariance(const PoseVector& nu, const Matrix6d& C, const Eigen::Isometry3d& believed_WS_j);
// A (as above): how an error δ of ν moves the estimated pose of sensor J.
Matrix6d sensorPoseJacobian(const PoseVector& nu, const Eigen::Isometry3d& believed_WS_j);

// The grid of the rover's map of view J: map I's grid carried from sensor I to where the rover
// believes sensor J is (T_WM_J = believed_WS_J·T_WS_I⁻¹, kept gravity-aligned: its yaw and
// translation), so that map J covers what sensor J sees as map I covers what sensor I sees.
MapGrid believedGrid(const MapGrid& grid_i, const Eigen::Isometry3d& T_WS_i, const Eigen::Isometry3d& believed_WS_j);

// View I as registration reads it (map I's frame is the world): its map made with the
// configuration's locus settings, what feature matching and every method but the weighted ones
// read; for the weighted methods the same with the footprint's σ_z term, and the mapper it was made
// with (the pixels of image I its lines share, IconicOptions::map1_source). T_WS is sensor I's
// pose, from which map J's grid is carried (believedGrid).
struct ReferenceView {
  ElevationMap map;
  std::optional<ElevationMap> weighted;  // absent: no weighted method can register against this view
  std::optional<LocusMapper> source;     // absent for a map that is no single scan's (a composite)
  Eigen::Isometry3d T_WS = Eigen::Isometry3d::Identity();
};

// View I from its scan, mapped at the scan's pose (scan.image.T_WS, in the world) on `grid` (in the
// world frame); with_weighted: also the weighted methods' map and its mapper (the scan must then
// outlive the view). Throws std::invalid_argument when the grid is not in the world frame.
ReferenceView referenceView(const ScanMap& scan, const MapGrid& grid, const RegistrationConfig& config,
                            bool with_weighted);
// View I as a merged map (a composite, whose σ_z already has the footprint's term: every method
// reads it), its reference pose T_WS. Throws std::invalid_argument when it is not in the world frame.
ReferenceView referenceView(ElevationMap composite, const Eigen::Isometry3d& T_WS);

// Registers scan J, which the rover believes was taken from believed_WS_j, against view I. A
// two-stage method refines T_F, T_0 and feature matching's next-best distinct pairings
// (FeatureMatch::ranked) by its iconic method and keeps the refinement of lowest robust iconic
// cost over the lines all of them have: it never returns what its own cost rates worse than
// refining T_0. Every result carries the rover's verdict (assessRegistration, config.acceptance:
// the caller sets this pair's prior, acceptanceFor). The estimate ν maps map I's frame to the frame
// the believed pose lives in; the corrected pose of sensor J is corrected_WS = correction·believed,
// correction = poseFromVector(ν)⁻¹. Feature matching maps scan J on map I's grid carried to the
// believed pose (believedGrid). Throws std::invalid_argument when a weighted method is asked of a
// view without its weighted map.
RegistrationResult registerViews(const ReferenceView& view_i, const ScanMap& scan_j,
                                 const Eigen::Isometry3d& believed_WS_j, RegistrationMethod method,
                                 const RegistrationConfig& config);

}  // namespace ambler::perception
