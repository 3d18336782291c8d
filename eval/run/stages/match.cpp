// The match stage (docs/scenario.md, "matching"): each pair (I, J) of views registered by each
// method, scored against the true relative pose. The rover does not know view J's pose: it
// believes T_0 = T_IJ·E (E the scenario's initial_error) and hands image J to the matcher at the
// believed pose; view I's map (map stage) is the reference. A method estimates the transform from
// the world to the rover's believed world of view J, and with it the pose of sensor J; nothing a
// method sees depends on the true pose of J. matching/pair_I_J_METHOD.json and metrics.registration;
// pictures of the views' features, the pair's maps before and after, and the methods' residuals.
#include <algorithm>
#include <cstdio>
#include <optional>
#include <string>

#include "eval/score/registration_score.hpp"
#include "eval/scenario/io.hpp"
#include "eval/pictures/match_figures.hpp"
#include "eval/run/pair_registration.hpp"
#include "eval/run/stages.hpp"
#include "perception/locus_mapper.hpp"
#include "perception/registration.hpp"
#include "perception/rigid_transform.hpp"
#include "perception/sensor_geometry.hpp"

namespace ambler::eval::stages {

namespace {

nlohmann::ordered_json matrixJson(const Eigen::MatrixXd& m) {
  nlohmann::ordered_json rows = nlohmann::ordered_json::array();
  for (int r = 0; r < m.rows(); ++r) {
    nlohmann::ordered_json row = nlohmann::ordered_json::array();
    for (int c = 0; c < m.cols(); ++c) row.push_back(m(r, c));
    rows.push_back(row);
  }
  return rows;
}

// A map's features (docs/matching.md), in its map frame.
nlohmann::ordered_json featuresJson(const std::vector<perception::Feature>& features) {
  static const char* kTypes[] = {"point", "line", "region"};
  nlohmann::ordered_json out = nlohmann::ordered_json::array();
  for (const perception::Feature& f : features) {
    nlohmann::ordered_json e;
    e["type"] = kTypes[int(f.type)];
    e["position_m"] = {f.position.x(), f.position.y(), f.position.z()};
    if (f.type == perception::FeatureType::Line) {
      e["direction"] = {f.direction.x(), f.direction.y(), f.direction.z()};
      e["length_m"] = f.length_m;
    }
    e["extent_m"] = f.extent_m;
    e["strength_per_m"] = f.strength;
    e["cells"] = f.cells;
    out.push_back(e);
  }
  return out;
}

// ---- Pictures (eval/pictures/match_figures.hpp), apart from the registration: they only read its results.
struct Registered {
  std::string method;
  Eigen::Isometry3d corrected_WS;  // sensor J where the method puts it
  std::vector<double> rms_m;
};

// matching/view_K_features.png: each view's map with its features.
void featurePictures(const RunState& s) {
  // The features registration extracts: from each view's map as registration maps it
  // (registrationConfig: the samples at edges trusted), which the run's map may not be.
  const perception::RegistrationConfig config = registrationConfig(s.scenario);
  for (int k = 0; k < int(s.views.size()); ++k) {
    const perception::ScanMap& view = *s.views[k].locus;
    const perception::ElevationMap map = perception::referenceView(view, view.map.grid(), config, false).map;
    writeFeaturesPicture(s.out / "matching", k, map, perception::extractFeatures(map),
                         s.scenario.name + ": " + viewName(k) + " locus map");
  }
}

// Scan J mapped on map I's grid (perception::mapAtPose: the map stage's unwrapped image and edges)
// at the believed pose and at each method's estimate: matching/pair_I_J_difference_METHOD.png and
// pair_I_J_convergence.png.
void pairPictures(const RunState& s, int i, int j, const Eigen::Isometry3d& believed_WS,
                  const std::vector<Registered>& registered) {
  const Scenario& sc = s.scenario;
  const perception::ElevationMap& map_i = s.views[i].locus->map;
  const perception::LocusConfig locus = locusConfig(sc);
  const auto mapJ = [&](const Eigen::Isometry3d& T_WS) {
    return perception::mapAtPose(*s.views[j].locus, T_WS, map_i.grid(), locus);
  };
  const perception::ElevationMap before = mapJ(believed_WS);
  std::vector<perception::ElevationMap> after;
  after.reserve(registered.size());  // RegisteredMap points into it
  std::vector<RegisteredMap> maps;
  for (const Registered& r : registered) {
    if (r.rms_m.empty()) continue;
    after.push_back(mapJ(r.corrected_WS));
    maps.push_back({r.method, &after.back(), r.rms_m});
  }
  writePairPictures(s.out / "matching", i, j, map_i, before, maps, sc.name);
}
// ---- End of the pictures.

// The two-stage methods' verification (pair JSON "verification"): each hypothesis with its cost
// and, for scoring only, where sensor J would be from its start and from its refinement.
nlohmann::ordered_json verificationJson(const perception::RegistrationResult& reg, const Eigen::Isometry3d& T_IJ,
                                        const Eigen::Isometry3d& T_WS_i, const Eigen::Isometry3d& believed_WS) {
  nlohmann::ordered_json hs = nlohmann::ordered_json::array();
  for (std::size_t k = 0; k < reg.hypotheses.size(); ++k) {
    const perception::RegistrationHypothesis& h = reg.hypotheses[k];
    // Scoring only: where sensor J would be from the start and from its refinement.
    const auto error = [&](const perception::PoseVector& nu) {
      return perception::poseError(T_IJ, T_WS_i.inverse() * perception::poseFromVector(nu).inverse() * believed_WS);
    };
    const perception::PoseError e0 = error(h.nu0), e1 = error(h.nu);
    hs.push_back({{"start", h.start},
                  {"stage", h.stage},
                  {"D_m", h.D_m},
                  {"iterations", h.iterations},
                  {"cost", h.cost},
                  {"chosen", int(k) == reg.chosen},
                  {"start_translation_error_m", e0.translation_m},
                  {"start_rotation_error_deg", e0.rotation_deg},
                  {"translation_error_m", e1.translation_m},
                  {"rotation_error_deg", e1.rotation_deg}});
  }
  return {{"common_lines", reg.common_lines}, {"hypotheses", hs}};
}

// The feature stage (pair JSON "feature_matching"); D_true_m, eq. 3 at the true transform, is
// scoring only: whether a failure is the search's or the verification's.
nlohmann::ordered_json featureMatchingJson(const perception::RegistrationResult& reg,
                                           const perception::MapGrid& grid_j, const Eigen::Isometry3d& believed_WS,
                                           const Eigen::Isometry3d& T_WS_j, const perception::FeatureMatchConfig& match) {
  const perception::FeatureMatch& fm = *reg.feature_match;
  nlohmann::ordered_json f;
  f["features_i"] = featuresJson(reg.features_i);
  f["features_j"] = featuresJson(reg.features_j);
  f["T_WM_j"] = matrixJson(grid_j.T_WM.matrix());
  f["found"] = fm.found;
  f["D_m"] = fm.D;
  f["D_initial_m"] = fm.D0;
  // Eq. 3 at the true transform (world → believed world), and its pairing.
  std::vector<std::pair<int, int>> true_pairs;
  f["D_true_m"] = perception::featureDistanceSum(reg.features_i, reg.features_j, *reg.map_j,
                                                 grid_j.T_WM.inverse() * believed_WS * T_WS_j.inverse(),
                                                 match, &true_pairs);
  f["pairs_true"] = true_pairs.size();
  nlohmann::ordered_json pairs = nlohmann::ordered_json::array();
  for (const auto& [a, b] : fm.pairs) pairs.push_back({a, b});
  f["pairs"] = pairs;
  f["rotation_sigma_deg"] = fm.rotation_sigma_deg;
  f["nodes"] = fm.nodes;
  f["hypotheses"] = fm.hypotheses;
  f["exhausted"] = fm.exhausted;
  return f;
}

// Fig. 5: map J's features moved into map I's frame by T_F (M_J → M_I: T_F⁻¹), over map I:
// matching/pair_I_J_correspondence_METHOD.png.
void writeCorrespondencePicture(const RunState& s, int i, int j, const std::string& name,
                                const perception::RegistrationResult& reg) {
  const perception::FeatureMatch& fm = *reg.feature_match;
  const perception::ElevationMap& map_i = s.views[i].locus->map;
  std::vector<perception::Feature> moved;
  const Eigen::Isometry3d T_F_inv = perception::poseFromVector(fm.nu).inverse();
  for (const perception::Feature& fj : reg.features_j) moved.push_back(perception::transformed(fj, T_F_inv));
  writePng(s.out / "matching" / ("pair_" + std::to_string(i) + "_" + std::to_string(j) + "_correspondence_" +
                                 methodFileName(name) + ".png"),
           correspondencePicture(map_i, reg.features_i, moved, fm.pairs,
                                 s.scenario.name + ": views " + std::to_string(i) + "-" + std::to_string(j) +
                                     ", features after T_F (" + name + ")"));
}

void run(RunState& s) {
  const Scenario& sc = s.scenario;
  const MatchingSpec& spec = *sc.matching;
  std::filesystem::create_directories(s.out / "matching");
  s.metrics["registration"] = nlohmann::ordered_json::array();
  featurePictures(s);
  const perception::RegistrationConfig config = registrationConfig(sc);
  for (const auto& [i, j] : spec.pairs) {
    const ViewState& vi = s.views[i];
    const ViewState& vj = s.views[j];
    const PairRegistration pair_reg(*vi.locus, vi.T_WS, *vj.locus, vj.T_WS, config, spec.methods);
    const Eigen::Isometry3d& T_IJ = pair_reg.trueRelative();  // the truth, for scoring only
    const Eigen::Isometry3d T_0 = spec.initialEstimate(T_IJ, sc.seed, i, j);  // what the rover believes
    const Eigen::Isometry3d believed_WS = vi.T_WS * T_0;       // sensor J in the believed world
    const perception::ElevationMap& map_i = vi.locus->map;
    const perception::MapGrid grid_j = perception::believedGrid(map_i.grid(), vi.T_WS, believed_WS);
    std::vector<Registered> registered;
    for (const MatchMethod method : spec.methods) {
      const PairResult result = pair_reg.run(method, T_0);
      const perception::RegistrationResult& reg = result.reg;
      const perception::IconicResult& res = reg.iconic;
      const double seconds = result.seconds;
      s.addTime("match", seconds);
      const Eigen::Isometry3d& T_est = result.T_est;
      const perception::PoseError err = result.error, start = result.start;
      const bool success = isSuccess(err, spec);
      const std::string name = matchMethodName(method);
      nlohmann::ordered_json pair;
      pair["pair"] = {i, j};
      pair["method"] = name;
      pair["T_true"] = matrixJson(T_IJ.matrix());
      pair["T_initial"] = matrixJson(T_0.matrix());
      pair["T_estimated"] = matrixJson(T_est.matrix());
      pair["translation_error_m"] = err.translation_m;
      pair["rotation_error_deg"] = err.rotation_deg;
      pair["success"] = success;
      pair["iterations"] = reg.iterations;
      pair["time_s"] = seconds;
      // Of ν (world → believed world), rx ry rz tx ty tz; null where a direction is free or the
      // method gives none (features alone).
      const bool covariance = reg.ran_iconic && !res.degenerate;
      pair["covariance"] = covariance ? matrixJson(res.covariance) : nlohmann::ordered_json(nullptr);
      pair["degenerate"] = reg.ran_iconic && res.degenerate;
      pair["free_directions"] = res.free_directions;
      pair["overlap"] = res.overlap;
      // The same of sensor J's pose in its own frame (what is scored), rx ry rz tx ty tz.
      pair["covariance_pose"] = covariance && res.covariance.allFinite()
                                    ? matrixJson(perception::sensorPoseCovariance(reg.nu, res.covariance, believed_WS))
                                    : nlohmann::ordered_json(nullptr);
      pair["covariance_calibrated"] = covariance && covarianceCalibrated(method, sc.sensor);
      // The rover's verdict, made without truth, and how it scores against the truth.
      const perception::Assessment& a = reg.assessment;
      pair["accepted"] = a.accepted;
      pair["reject_reasons"] = a.reject_reasons;
      pair["false_accept"] = a.accepted && !success;
      pair["assessment"] = assessmentJson(a);
      if (!reg.hypotheses.empty()) pair["verification"] = verificationJson(reg, T_IJ, vi.T_WS, believed_WS);
      if (reg.feature_match) {
        pair["feature_matching"] = featureMatchingJson(reg, grid_j, believed_WS, vj.T_WS, config.match);
        writeCorrespondencePicture(s, i, j, name, reg);
      }
      nlohmann::ordered_json trace = nlohmann::ordered_json::array();
      for (std::size_t k = 0; k < res.rms_m.size(); ++k)
        trace.push_back({{"iteration", k}, {"E", res.E_m2[k]}, {"rms_m", res.rms_m[k]}, {"lines", res.lines[k]}});
      pair["trace"] = trace;
      writeJson(s.out / "matching" / ("pair_" + std::to_string(i) + "_" + std::to_string(j) + "_" + methodFileName(name) + ".json"), pair);
      registered.push_back({name, reg.corrected_WS, res.rms_m});
      PairEstimate estimate{i, j, method, T_est, reg.nu, std::nullopt};
      if (covariance && res.covariance.allFinite()) estimate.covariance = res.covariance;
      estimate.covariance_calibrated = covarianceCalibrated(method, sc.sensor);
      estimate.accepted = a.accepted;
      estimate.T_WS_i = vi.T_WS;
      estimate.believed_WS_j = believed_WS;
      s.estimates.push_back(estimate);
      const RegistrationScore score{i, j, name, err, start, success, a, reg.iterations, seconds};
      s.metrics["registration"].push_back(toJson(score));
      char line[240];
      std::snprintf(line, sizeof line, "match     views %d-%d %-18s %3d iterations: error %.4f m %.3f deg (from %.3f m %.2f deg)%s%s",
                    i, j, name.c_str(), reg.iterations, err.translation_m, err.rotation_deg, start.translation_m,
                    start.rotation_deg, success ? "" : "  FAILED",
                    a.accepted ? (success ? "" : " (accepted: a false accept)") : (success ? "  rejected (a false reject)" : "  rejected"));
      s.say(line);
    }
    pairPictures(s, i, j, believed_WS, registered);
  }
}

}  // namespace

Stage match() {
  return {"match", [](const Scenario& sc) { return sc.matching.has_value(); }, run};
}

}  // namespace ambler::eval::stages
