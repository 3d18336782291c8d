#pragma once
// Feature matching (paper §4.1): predict candidate pairings of two maps' features, verify each
// pairing's transform by the distance D of eq. 3, and search the pairings depth-first from the
// rover's initial estimate (docs/matching.md, "Feature matching"). Onboard code: it sees the two
// maps and their features, never a true pose.
#include <utility>
#include <vector>

#include "perception/elevation_map.hpp"
#include "perception/features.hpp"
#include "perception/rigid_transform.hpp"

namespace ambler::perception {

struct FeatureMatchConfig {
  // The rover's prior: how far the truth may be from T_0 (the scenario's initial_error bounds). A
  // transform turned further than max_rotation_deg from T_0, plus three σ of its fit's rotation
  // (a fit errs, and the truth may lie at the bound), is not a candidate; a feature of map 1
  // pairs only with features of map 2 within max_shift_m of where T_0 puts it.
  double max_rotation_deg = 30.0;
  double max_shift_m = 10.0;
  // Predict: two features are similar when of one type, their strengths within strength_ratio of
  // the larger, and (lines) their lengths within length_ratio of the longer plus one cell's
  // worth of slack (length_slack_m).
  double strength_ratio = 0.6;
  double length_ratio = 0.5;
  double length_slack_m = 0.3;
  // The search: a pairing is rigid-consistent when every two of its pairs keep their distance to
  // within tolerance_m (lines: their angle to within tolerance_m / half the shorter length);
  // hypotheses pair `pairs_per_hypothesis` of map 1's `search_features` strongest features, at
  // least min_spread_m apart; the search stops after max_nodes nodes.
  double tolerance_m = 0.3;
  int search_features = 24;
  int pairs_per_hypothesis = 3;
  double min_spread_m = 1.0;
  long max_nodes = 200000;
  // Verify: d of eq. 3 truncated at d_max_m (an unexplained feature costs d_max_m), and pairs
  // closer than inlier_m refit the transform (refits times).
  double d_max_m = 0.5;
  double inlier_m = 0.3;
  int refits = 3;
  // The ranked list: the `keep_ranked` distinct pairings of lowest D (their transforms move some
  // feature of map 1 apart by at least inlier_m), the hypotheses that registration's verification
  // refines besides T_0 (perception/registration.hpp).
  int keep_ranked = 3;
};

// One verified pairing of the search: its transform, D and inliers.
struct RankedPairing {
  PoseVector nu = PoseVector::Zero();  // map 1's frame → map 2's
  double D = 0;                        // eq. 3 (m)
  int inliers = 0;                     // pairs closer than inlier_m
};

struct FeatureMatch {
  bool found = false;                     // a pairing beat T_0's D
  PoseVector nu = PoseVector::Zero();     // T_F: map 1's frame → map 2's (F² ≈ T_F(F¹)); ν0 if not found
  double D = 0;                           // eq. 3 at T_F (m)
  double D0 = 0;                          // eq. 3 at T_0
  std::vector<std::pair<int, int>> pairs; // the pairing S_K at T_F: (index in features1, index in features2)
  long nodes = 0;                         // search-tree nodes visited
  long hypotheses = 0;                    // candidate transforms verified
  bool exhausted = false;                 // the search stopped at max_nodes
  // σ of T_F's rotation from its inliers' residuals (the prior admits T_F turned up to
  // max_rotation_deg + 3·rotation_sigma_deg from T_0: docs/matching.md); 0 when not found.
  double rotation_sigma_deg = 0;
  // The distinct pairings of lowest D that beat T_0's, best first (the first is T_F when found).
  std::vector<RankedPairing> ranked;
};

// The distance d of eq. 3 between feature a and feature b (same frame, same type): points and
// regions, the distance of their centres; lines, the distance of a's centre from b's line, plus
// the swing of half the shorter line by their angle, plus how far a's centre lies beyond b's
// extent along it.
double featureDistance(const Feature& a, const Feature& b);

// The feature moved by T (position and direction).
Feature transformed(const Feature& f, const Eigen::Isometry3d& T);

// D of eq. 3 under T: each feature of map 1, moved by T into map 2's frame, costs its distance to
// the nearest feature of its type in map 2, truncated at d_max_m; where it lands off map 2's
// known cells, or meets nothing, it costs d_max_m. `pairs` receives the one-to-one pairing (each
// feature of map 2 taken by its nearest map-1 feature) of those nearer than inlier_m.
double featureDistanceSum(const std::vector<Feature>& features1, const std::vector<Feature>& features2,
                          const ElevationMap& map2, const Eigen::Isometry3d& T, const FeatureMatchConfig& config,
                          std::vector<std::pair<int, int>>* pairs = nullptr);

// Predict and verify: the pairing and transform minimising D, searched depth-first from T_0
// (exp ν0) over rigid-consistent pairings of map 1's strongest features, nearest (under T_0)
// candidates first; each hypothesis's transform is fitted in closed form (fitRigid) and refitted
// on its inliers. features1 are in map 1's frame, features2 and map2 in map 2's. Deterministic.
// Throws std::invalid_argument for a config out of range.
FeatureMatch matchFeatures(const std::vector<Feature>& features1, const std::vector<Feature>& features2,
                           const ElevationMap& map2, const PoseVector& nu0, const FeatureMatchConfig& config = {});

}  // namespace ambler::perception
