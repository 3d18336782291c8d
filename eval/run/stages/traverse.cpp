// The traverse stage (docs/scenario.md, "traverse"; docs/traverse.md): the body's true pose at
// each stop on the true terrain, odometry's measured steps with the scenario's seeded errors, one
// ERIM scan per stop from the true pose, and the rover's loop (perception::Localiser: map,
// register, accept, merge, carry the pose on) fed with them; then its poses and its composite
// scored against the truth: traverse/poses.csv, maps/composite_*, metrics.traverse.
#include <cstdio>
#include <optional>
#include <sstream>

#include "base/random.hpp"
#include "base/text.hpp"
#include "eval/pictures/map_outputs.hpp"
#include "eval/pictures/traverse_figures.hpp"
#include "eval/run/stages.hpp"
#include "eval/run/traverse_truth.hpp"
#include "eval/scenario/io.hpp"
#include "eval/score/map_metrics.hpp"
#include "eval/score/registration_score.hpp"
#include "eval/score/trajectory_score.hpp"
#include "eval/tools/shards.hpp"
#include "perception/rigid_transform.hpp"
#include "perception/traverse.hpp"

namespace ambler::eval::stages {

namespace {

perception::TraverseReference referenceOf(TraverseRegister r) {
  switch (r) {
    case TraverseRegister::Previous: return perception::TraverseReference::Previous;
    case TraverseRegister::None: return perception::TraverseReference::None;
    default: return perception::TraverseReference::Composite;
  }
}

// The corridor: the world-aligned box around every planned stop's mapped region, with a margin
// for the drift (the rover plans it from the path, not from the truth).
perception::MapGrid corridorGrid(const std::vector<PathStop>& stops, const MapSpec& map) {
  constexpr double kMargin = 3.0;
  Eigen::AlignedBox2d box;
  for (const PathStop& s : stops) {
    box.extend(perception::regionBox(s.xy, s.heading_rad, map.x_m, map.y_m));
    box.extend(perception::regionBox(s.xy, s.heading_rad, map.x_m, Eigen::Vector2d::Zero()));  // the stop's own line
  }
  const double c = map.cell_m;
  return perception::MapGrid::covering(std::floor((box.min().x() - kMargin) / c) * c,
                                       std::ceil((box.max().x() + kMargin) / c) * c,
                                       std::floor((box.min().y() - kMargin) / c) * c,
                                       std::ceil((box.max().y() + kMargin) / c) * c, c);
}

// The scenario's roll, pitch, yaw of a rotation, R = Rz(yaw)·Ry(roll)·Rx(pitch) (docs/conventions.md).
Eigen::Vector3d rpyOf(const Eigen::Matrix3d& R) {
  // R = Rz(y)·Ry(r)·Rx(p): R(2,0) = −sin r, R(2,1) = cos r·sin p, R(2,2) = cos r·cos p,
  // R(0,0) = cos y·cos r, R(1,0) = sin y·cos r.
  const double roll = std::asin(std::clamp(-R(2, 0), -1.0, 1.0));
  return {roll, std::atan2(R(2, 1), R(2, 2)), std::atan2(R(1, 0), R(0, 0))};
}

// x, y, z and roll, pitch, yaw (degrees, the scenario's convention) of a sensor pose, appended to `cells`.
void addPoseCells(const Eigen::Isometry3d& T, std::vector<std::string>& cells) {
  const Eigen::Vector3d rpy = rpyOf(T.linear()) * (180 / M_PI);
  for (const double x : {T.translation().x(), T.translation().y(), T.translation().z(), rpy.x(), rpy.y(), rpy.z()})
    cells.push_back(base::shortestText(x));
}

// A stop's registration against the truth: the relative pose it implies from the previous
// stop's estimate, against the true relative pose.
struct StopScore {
  perception::PoseError error;
  bool success = false;
};

void writePoses(const std::filesystem::path& file, const std::vector<PathStop>& stops,
                const std::vector<Eigen::Isometry3d>& truth, const std::vector<Eigen::Isometry3d>& believed,
                const std::vector<perception::StopEstimate>& est, const std::vector<std::optional<StopScore>>& scores) {
  std::vector<std::string> header{"stop", "distance_m", "accepted"};
  for (const char* who : {"true", "believed", "estimated"})
    for (const char* k : {"x_m", "y_m", "z_m", "roll_deg", "pitch_deg", "yaw_deg"}) header.push_back(std::string(who) + "_" + k);
  for (const char* k : {"registration_translation_error_m", "registration_rotation_error_deg", "success", "reject_reasons"})
    header.push_back(k);
  std::string csv = csvLine(header);
  for (std::size_t k = 0; k < stops.size(); ++k) {
    std::vector<std::string> cells{std::to_string(k), base::shortestText(stops[k].distance_m),
                                   est[k].registered ? (est[k].accepted ? "true" : "false") : ""};
    for (const Eigen::Isometry3d* T : {&truth[k], &believed[k], &est[k].estimated_WS}) addPoseCells(*T, cells);
    if (scores[k]) {
      std::string reasons;
      for (const std::string& r : est[k].registration->assessment.reject_reasons) reasons += (reasons.empty() ? "" : "; ") + r;
      for (const std::string& c : {base::shortestText(scores[k]->error.translation_m),
                                   base::shortestText(scores[k]->error.rotation_deg),
                                   std::string(scores[k]->success ? "true" : "false"), reasons})
        cells.push_back(c);
    } else {
      cells.insert(cells.end(), 4, "");
    }
    csv += csvLine(cells);
  }
  writeText(file, csv);
}

// The truth of a traverse: its stops, the body's and the sensor's true poses on the terrain,
// odometry's measured steps and dead reckoning's sensor poses.
struct Truth {
  std::vector<PathStop> stops;
  std::vector<Eigen::Isometry3d> true_WB, true_WS, believed_WS;
  std::vector<perception::OdometryStep> steps;
};

Truth makeTruth(const RunState& s, const TraverseSpec& spec) {
  if (!s.terrain) throw std::logic_error("traverse stage: no terrain (the reader refuses an MJCF world in a traverse)");
  Truth t;
  t.stops = stopsAlongPath(spec.waypoints_xy_m, spec.stop_spacing_m);
  for (const PathStop& stop : t.stops) {
    t.true_WB.push_back(bodyPoseOnTerrain(*s.terrain, stop, spec.footprint_radius_m));
    t.true_WS.push_back(perception::sensorOnBody(t.true_WB.back(), spec.mount));
  }
  t.steps = measuredSteps(t.true_WB, spec.odometry, s.scenario.seed);
  for (const Eigen::Isometry3d& T : deadReckoning(t.true_WB, t.steps))
    t.believed_WS.push_back(perception::sensorOnBody(T, spec.mount));
  return t;
}

perception::LocaliserConfig localiserConfig(const Scenario& sc, const std::vector<PathStop>& stops) {
  const TraverseSpec& spec = *sc.traverse;
  const MapSpec map = sc.map ? *sc.map : MapSpec{};
  perception::LocaliserConfig config;
  config.reference = referenceOf(spec.reg);
  config.mount = spec.mount;
  config.corridor = corridorGrid(stops, map);
  config.region_x_m = map.x_m;
  config.region_y_m = map.y_m;
  config.map = map.scanToMapConfig();
  config.registration = registrationConfig(sc);
  const auto paper = paperMethod(spec.method);
  if (!paper) throw std::logic_error("traverse stage: a peer method (the reader refuses it)");
  config.weighted_maps = perception::readsWeightedMaps(*paper);
  config.covariance_calibrated = covarianceCalibrated(spec.method, sc.sensor);
  if (spec.reg != TraverseRegister::None) config.drift = spec.drift;
  return config;
}

// The verdicts against the truth.
struct Verdicts {
  int accepted = 0, rejected = 0, false_accepts = 0, false_rejects = 0;
  std::vector<std::optional<StopScore>> scores;  // per stop, when a registration ran
};

// The rover's walk: one scan per stop from the true pose, fed to the Localiser with odometry's
// step and the true tilt; each registration scored as it comes.
Verdicts walk(RunState& s, const Truth& truth, perception::Localiser& rover) {
  const Scenario& sc = s.scenario;
  const sim::ErimScanner scanner(*s.scene, sc.sensor);
  const MatchingSpec success = sc.matching ? *sc.matching : MatchingSpec{};
  Verdicts v;
  v.scores.resize(truth.stops.size());
  for (std::size_t k = 0; k < truth.stops.size(); ++k) {
    const sim::Scan scan = scanner.scan(truth.true_WS[k], base::viewSeed(sc.seed, int(k)));
    const Eigen::Matrix3d tilt = perception::tiltOf(truth.true_WB[k].linear());
    const perception::StopEstimate& e = k == 0 ? rover.start(scan.image, sc.sensor, truth.true_WB[0])
                                              : rover.step(scan.image, sc.sensor, truth.steps[k], tilt);
    s.addTime("traverse", e.seconds_map + e.seconds_register + e.seconds_merge);
    std::string verdict;
    if (e.registered) {
      const Eigen::Isometry3d est_rel = rover.stops()[k - 1].estimated_WS.inverse() * e.registration->corrected_WS;
      const perception::PoseError err =
          perception::poseError(truth.true_WS[k - 1].inverse() * truth.true_WS[k], est_rel);
      const bool ok = isSuccess(err, success);
      v.scores[k] = StopScore{err, ok};
      e.accepted ? ++v.accepted : ++v.rejected;
      v.false_accepts += e.accepted && !ok;
      v.false_rejects += !e.accepted && ok;
      verdict = std::string(e.accepted ? "accepted" : "rejected") + (e.accepted && !ok ? " (a false accept)" : "");
    }
    const perception::PoseError drift = perception::poseError(truth.true_WS[k], e.estimated_WS);
    char line[200];
    std::snprintf(line, sizeof line, "traverse  stop %zu/%zu at %.1f m: error %.3f m %.2f deg %s", k + 1,
                  truth.stops.size(), truth.stops[k].distance_m, drift.translation_m, drift.rotation_deg, verdict.c_str());
    s.say(line);
  }
  return v;
}

// metrics.traverse's pose figures: the estimate's and dead reckoning's against the truth.
nlohmann::ordered_json trajectoryJson(const Truth& truth, const std::vector<Eigen::Isometry3d>& est_WS) {
  nlohmann::ordered_json t;
  if (truth.stops.size() < 2) return t;
  const TrajectoryErrors est = trajectoryErrors(truth.true_WS, est_WS);
  const TrajectoryErrors dr = trajectoryErrors(truth.true_WS, truth.believed_WS);
  t["final_drift_pct"] = jsonNumber(est.final_drift_pct);
  t["dead_reckoning_drift_pct"] = jsonNumber(dr.final_drift_pct);
  const nlohmann::ordered_json ej = toJson(est);
  for (const char* key : {"ate_rms_m", "ate_max_m", "rte_pct", "rotation_deg_per_m", "segments"}) t[key] = ej[key];
  t["dead_reckoning"] = toJson(dr);
  return t;
}

// What some stop's sensor could see of the true surface on the corridor: visible if any stop sees
// it, else hidden if one holds it behind terrain.
perception::Raster<std::uint8_t> corridorVisibility(const RunState& s, const Truth& truth,
                                                    const perception::Localiser& rover,
                                                    const perception::ElevationMap& true_map) {
  const perception::MapGrid& g = true_map.grid();
  perception::Raster<std::uint8_t> visible = perception::Raster<std::uint8_t>::Zero(g.rows, g.cols);
  const auto V = std::uint8_t(sim::Visibility::Visible), H = std::uint8_t(sim::Visibility::Hidden);
  for (const Eigen::Isometry3d& T : truth.true_WS) {
    const perception::CorridorWindow w = rover.window(T);
    if (w.grid.rows == 0 || w.grid.cols == 0) continue;
    const perception::Raster<std::uint8_t> vis = s.truth->visibility(perception::cropMap(true_map, w), T, s.scenario.sensor);
    for (int r = 0; r < w.grid.rows; ++r)
      for (int c = 0; c < w.grid.cols; ++c) {
        std::uint8_t& a = visible(w.row0 + r, w.col0 + c);
        const std::uint8_t b = vis(r, c);
        a = (a == V || b == V) ? V : (a == H || b == H) ? H : std::uint8_t(sim::Visibility::OutOfView);
      }
  }
  return visible;
}

void run(RunState& s) {
  const Scenario& sc = s.scenario;
  const TraverseSpec& spec = *sc.traverse;
  const Truth truth = makeTruth(s, spec);
  const perception::RegistrationMethod method = *paperMethod(spec.method);
  perception::Localiser rover(localiserConfig(sc, truth.stops),
                              [method](const perception::ReferenceView& view, const perception::ScanMap& scan,
                                       const Eigen::Isometry3d& believed, const perception::RegistrationConfig& c) {
                                return perception::registerViews(view, scan, believed, method, c);
                              });
  base::Stopwatch total;
  const Verdicts v = walk(s, truth, rover);
  const double seconds = total.seconds();
  // Scores.
  const std::vector<PathStop>& stops = truth.stops;
  std::vector<Eigen::Isometry3d> est_WS;
  for (const perception::StopEstimate& e : rover.stops()) est_WS.push_back(e.estimated_WS);
  std::filesystem::create_directories(s.out / "traverse");
  std::filesystem::create_directories(s.out / "maps");
  writePoses(s.out / "traverse" / "poses.csv", stops, truth.true_WS, truth.believed_WS, rover.stops(), v.scores);
  nlohmann::ordered_json t;
  t["stops"] = stops.size();
  t["distance_m"] = stops.back().distance_m;
  t["register"] = traverseRegisterName(spec.reg);
  t["method"] = matchMethodName(spec.method);
  t.update(trajectoryJson(truth, est_WS));
  t["accepted"] = v.accepted;
  t["rejected"] = v.rejected;
  t["false_accepts"] = v.false_accepts;
  t["false_rejects"] = v.false_rejects;
  t["seconds_per_stop"] = seconds / double(stops.size());
  const perception::ElevationMap& composite = rover.composite();
  const perception::ElevationMap true_map = s.truth->elevation(composite.grid());
  const MapMetrics m = mapMetrics(composite, true_map, corridorVisibility(s, truth, rover, true_map));
  t["composite"] = compositeJson(m, int(stops.size()), "traverse");
  s.metrics["traverse"] = t;
  std::vector<double> distance;
  for (const PathStop& stop : stops) distance.push_back(stop.distance_m);
  writePathsPicture(s.out / "traverse" / "paths.png", true_map, truth.true_WS, truth.believed_WS, est_WS,
                    sc.name + ": paths (true, dead reckoning, estimate)");
  writeErrorPlot(s.out / "traverse" / "error.png", distance, truth.true_WS, truth.believed_WS, est_WS,
                 sc.name + ": position error against distance");
  writeMapFiles(s.out / "maps", "composite", composite, &true_map,
                sc.name + ": composite of a " + base::shortestText(stops.back().distance_m) + " m traverse", s.geo);
  const auto number = [&](const char* key) { return t.contains(key) && t[key].is_number() ? t[key].get<double>() : NAN; };
  char line[240];
  std::snprintf(line, sizeof line,
                "traverse  %zu stops, %.0f m: final drift %.2f%% (dead reckoning %.2f%%), %d accepted, %d rejected; "
                "composite RMS error %.4f m, within 1σ %.0f%%",
                stops.size(), stops.back().distance_m, number("final_drift_pct"), number("dead_reckoning_drift_pct"),
                v.accepted, v.rejected, m.rms_error_m, 100 * m.within_1sigma);
  s.say(line);
  s.composite = composite;
}

}  // namespace

Stage traverse() {
  return {"traverse", [](const Scenario& sc) { return sc.traverse.has_value(); }, run};
}

}  // namespace ambler::eval::stages
