// The match stage (docs/scenario.md, "matching"): each pair (I, J) of views registered by each
// method, scored against the true relative pose. The rover does not know view J's pose: it
// believes T_0 = T_IJ·E (E the scenario's initial_error) and hands image J to the matcher at the
// believed pose; view I's map (map stage) is the reference. A method estimates the transform from
// the world to the rover's believed world of view J, and with it the pose of sensor J; nothing a
// method sees depends on the true pose of J. matching/pair_I_J_METHOD.json and metrics.registration;
// pictures of the views' features, the pair's maps before and after, and the methods' residuals.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>

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
    // The methods run side by side (PairRegistration::run is thread-safe and deterministic), then
    // are scored and written in the scenario's order: the same files as one after another. Each
    // method's time_s is its own wall time, longer where it shared the cores; the stage's time is
    // the wall time of them all.
    // A user's own methods (RunOptions::custom) then run one after another, in the caller's order.
    const CustomMethods none;
    const CustomMethods& custom = s.custom ? *s.custom : none;
    std::vector<PairResult> results(spec.methods.size() + custom.size());
    base::Stopwatch wall;
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, spec.methods.size(), 1),
                      [&](const tbb::blocked_range<std::size_t>& range) {
                        for (std::size_t k = range.begin(); k != range.end(); ++k)
                          results[k] = pair_reg.run(spec.methods[k], T_0);
                      },
                      tbb::simple_partitioner());
    for (std::size_t k = 0; k < custom.size(); ++k) results[spec.methods.size() + k] = pair_reg.run(custom[k], T_0);
    s.addTime("match", wall.seconds());
    std::vector<Registered> registered;
    for (std::size_t k = 0; k < results.size(); ++k) {
      // The method: built-in, or a user's (no MatchMethod; its covariance is not calibrated).
      const bool builtin = k < spec.methods.size();
      const MatchMethod method = builtin ? spec.methods[k] : MatchMethod{};
      const PairResult& result = results[k];
      const perception::RegistrationResult& reg = result.reg;
      const perception::IconicResult& res = reg.iconic;
      const double seconds = result.seconds;
      const Eigen::Isometry3d& T_est = result.T_est;
      const perception::PoseError err = result.error, start = result.start;
      const bool success = isSuccess(err, spec);
      const std::string name = builtin ? matchMethodName(method) : custom[k - spec.methods.size()].name;
      const perception::Assessment& a = reg.assessment;
      const RegistrationScore score{i, j, name, err, start, success, a, reg.iterations, seconds};
      PairRecord record;
      record.score = score;
      record.T_true = T_IJ, record.T_initial = T_0, record.T_estimated = T_est;
      record.reg = &reg;
      record.believed_WS = believed_WS, record.T_WS_i = vi.T_WS, record.T_WS_j = vj.T_WS;
      record.grid_j = grid_j;
      record.match = config.match;
      record.covariance_calibrated = builtin && covarianceCalibrated(method, sc.sensor);
      record.covariance_pose = result.covariance_pose;
      if (reg.feature_match) writeCorrespondencePicture(s, i, j, name, reg);
      const std::string stem = "pair_" + std::to_string(i) + "_" + std::to_string(j) + "_" + methodFileName(name);
      writeJson(s.out / "matching" / (stem + ".json"), toJson(record));
      registered.push_back({name, reg.corrected_WS, res.rms_m});
      if (builtin) {  // the merge places views by the built-in methods' estimates only
        const bool covariance = reg.ran_iconic && !res.degenerate;  // ν has a covariance (the pair JSON's)
        PairEstimate estimate{i, j, method, T_est, reg.nu, std::nullopt};
        if (covariance && res.covariance.allFinite()) estimate.covariance = res.covariance;
        estimate.covariance_calibrated = covarianceCalibrated(method, sc.sensor);
        estimate.accepted = a.accepted;
        estimate.T_WS_i = vi.T_WS;
        estimate.believed_WS_j = believed_WS;
        s.estimates.push_back(estimate);
      }
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
