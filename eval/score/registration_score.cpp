#include "eval/score/registration_score.hpp"

#include <cmath>
#include <utility>
#include <vector>

namespace ambler::eval {

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

// The two-stage methods' verification ("verification"): each hypothesis with its cost and, for
// scoring only, where sensor J would be from its start and from its refinement.
nlohmann::ordered_json verificationJson(const PairRecord& r) {
  const perception::RegistrationResult& reg = *r.reg;
  nlohmann::ordered_json hs = nlohmann::ordered_json::array();
  for (std::size_t k = 0; k < reg.hypotheses.size(); ++k) {
    const perception::RegistrationHypothesis& h = reg.hypotheses[k];
    const auto error = [&](const perception::PoseVector& nu) {
      return perception::poseError(r.T_true,
                                   r.T_WS_i.inverse() * perception::poseFromVector(nu).inverse() * r.believed_WS);
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

// The feature stage ("feature_matching"); D_true_m, eq. 3 at the true transform (world →
// believed world), is scoring only: whether a failure is the search's or the verification's.
nlohmann::ordered_json featureMatchingJson(const PairRecord& r) {
  const perception::RegistrationResult& reg = *r.reg;
  const perception::FeatureMatch& fm = *reg.feature_match;
  nlohmann::ordered_json f;
  f["features_i"] = featuresJson(reg.features_i);
  f["features_j"] = featuresJson(reg.features_j);
  f["T_WM_j"] = matrixJson(r.grid_j.T_WM.matrix());
  f["found"] = fm.found;
  f["D_m"] = fm.D;
  f["D_initial_m"] = fm.D0;
  std::vector<std::pair<int, int>> true_pairs;
  f["D_true_m"] = perception::featureDistanceSum(reg.features_i, reg.features_j, *reg.map_j,
                                                 r.grid_j.T_WM.inverse() * r.believed_WS * r.T_WS_j.inverse(),
                                                 r.match, &true_pairs);
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

// The iconic stage's iterations: E, the RMS residual and the overlap at each.
nlohmann::ordered_json traceJson(const perception::IconicResult& res) {
  nlohmann::ordered_json trace = nlohmann::ordered_json::array();
  for (std::size_t k = 0; k < res.rms_m.size(); ++k)
    trace.push_back({{"iteration", k}, {"E", res.E_m2[k]}, {"rms_m", res.rms_m[k]}, {"lines", res.lines[k]}});
  return trace;
}

}  // namespace

bool isSuccess(const perception::PoseError& error, const MatchingSpec& spec) {
  return error.translation_m <= spec.success_translation_m && error.rotation_deg <= spec.success_rotation_deg;
}

nlohmann::ordered_json assessmentJson(const perception::Assessment& a) {
  nlohmann::ordered_json j;
  j["overlap"] = a.overlap;
  j["overlap_fraction"] = a.overlap_fraction;
  j["inlier_fraction"] = a.inlier_fraction;
  j["rms_normalized"] = a.rms_normalized;
  j["correction_m"] = a.correction_m;
  j["correction_deg"] = a.correction_deg;
  j["mahalanobis2"] = a.mahalanobis2;
  j["degenerate"] = a.degenerate;
  if (std::isfinite(a.step_mahalanobis2)) j["step_mahalanobis2"] = a.step_mahalanobis2;
  return j;
}

nlohmann::ordered_json toJson(const RegistrationScore& s) {
  nlohmann::ordered_json m;
  m["pair"] = {s.i, s.j};
  m["method"] = s.method;
  m["translation_error_m"] = s.error.translation_m;
  m["rotation_error_deg"] = s.error.rotation_deg;
  m["success"] = s.success;
  m["accepted"] = s.assessment.accepted;
  m["false_accept"] = s.falseAccept();
  m["reject_reasons"] = s.assessment.reject_reasons;
  m["assessment"] = assessmentJson(s.assessment);
  m["iterations"] = s.iterations;
  m["time_s"] = s.seconds;
  m["initial_translation_error_m"] = s.start.translation_m;
  m["initial_rotation_error_deg"] = s.start.rotation_deg;
  return m;
}

nlohmann::ordered_json toJson(const PairRecord& r) {
  const RegistrationScore& s = r.score;
  const perception::RegistrationResult& reg = *r.reg;
  const perception::IconicResult& res = reg.iconic;
  nlohmann::ordered_json pair;
  pair["pair"] = {s.i, s.j};
  pair["method"] = s.method;
  pair["T_true"] = matrixJson(r.T_true.matrix());
  pair["T_initial"] = matrixJson(r.T_initial.matrix());
  pair["T_estimated"] = matrixJson(r.T_estimated.matrix());
  pair["translation_error_m"] = s.error.translation_m;
  pair["rotation_error_deg"] = s.error.rotation_deg;
  pair["success"] = s.success;
  pair["iterations"] = s.iterations;
  pair["time_s"] = s.seconds;
  // Of ν (world → believed world), rx ry rz tx ty tz; null where a direction is free or the
  // method gives none (features alone).
  const bool covariance = reg.ran_iconic && !res.degenerate;
  pair["covariance"] = covariance ? matrixJson(res.covariance) : nlohmann::ordered_json(nullptr);
  pair["degenerate"] = reg.ran_iconic && res.degenerate;
  pair["free_directions"] = res.free_directions;
  pair["overlap"] = res.overlap;
  // The same of sensor J's pose in its own frame (what is scored), rx ry rz tx ty tz.
  pair["covariance_pose"] = r.covariance_pose ? matrixJson(*r.covariance_pose)
                            : covariance && res.covariance.allFinite()
                                ? matrixJson(perception::sensorPoseCovariance(reg.nu, res.covariance, r.believed_WS))
                                : nlohmann::ordered_json(nullptr);
  pair["covariance_calibrated"] = covariance && r.covariance_calibrated;
  // The rover's verdict, made without truth, and how it scores against the truth.
  pair["accepted"] = s.assessment.accepted;
  pair["reject_reasons"] = s.assessment.reject_reasons;
  pair["false_accept"] = s.falseAccept();
  pair["assessment"] = assessmentJson(s.assessment);
  if (!reg.hypotheses.empty()) pair["verification"] = verificationJson(r);
  if (reg.feature_match) pair["feature_matching"] = featureMatchingJson(r);
  pair["trace"] = traceJson(res);
  return pair;
}

}  // namespace ambler::eval
