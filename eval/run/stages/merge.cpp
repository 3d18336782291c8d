// The merge stage (docs/scenario.md, "merge"; docs/composite.md): the views' poses — the true ones,
// or the rover's, chained from view 0 through the first listed matching method's estimates — and
// the composite the rover builds on them (perception::buildComposite: each scan mapped on the
// composite grid at its pose, each link's covariance propagated into the cells' σ, merged by eq. 9),
// scored against ground truth: maps/composite_*, metrics.composite.
#include <algorithm>
#include <cstdio>

#include "eval/score/composite_score.hpp"
#include "eval/score/map_metrics.hpp"
#include "eval/pictures/map_outputs.hpp"
#include "eval/run/stages.hpp"
#include "perception/composite.hpp"
#include "perception/placement.hpp"

namespace ambler::eval::stages {

namespace {

void run(RunState& s) {
  const Scenario& sc = s.scenario;
  const MergeSpec& spec = *sc.merge;
  const perception::MapGrid grid = spec.grid();
  base::Stopwatch t;
  // Matched poses: view 0 at its true pose (the composite's frame is view 0's world), the others
  // chained through the first listed method's registrations that the rover accepted; a view no
  // accepted registration reaches is left out. Only a calibrated covariance is propagated.
  std::vector<perception::PlacementLink> links;
  const MatchMethod first = sc.matching ? sc.matching->methods.front() : MatchMethod::IconicLm;
  for (const PairEstimate& e : s.estimates) {
    if (e.method != first) continue;
    perception::PlacementLink l;
    l.i = e.i, l.j = e.j, l.T_WS_i = e.T_WS_i, l.believed_WS_j = e.believed_WS_j, l.nu = e.nu, l.accepted = e.accepted;
    if (e.covariance_calibrated) l.covariance = e.covariance;
    links.push_back(l);
  }
  std::vector<perception::ViewPlacement> placements;
  if (spec.poses == MergePoses::Matched) {
    placements = perception::placeViews(int(s.views.size()), 0, s.views[0].T_WS, links);
  } else {
    placements.resize(s.views.size());
    for (std::size_t k = 0; k < s.views.size(); ++k)
      placements[k] = {k == 0 ? perception::PlacementHow::Reference : perception::PlacementHow::True, s.views[k].T_WS, {}};
  }
  // The rover's composite (perception::buildComposite); what some view could see is the truth's:
  // visible if any view sees the true surface, else hidden if one view's field of view holds it
  // behind terrain.
  std::vector<const perception::ScanMap*> scans;
  for (const ViewState& v : s.views) scans.push_back(v.locus ? &*v.locus : nullptr);
  perception::ElevationMap composite = perception::buildComposite(scans, placements, grid, locusConfig(sc));
  const perception::ElevationMap truth = s.truth->elevation(grid);
  perception::Raster<std::uint8_t> visible = perception::Raster<std::uint8_t>::Zero(grid.rows, grid.cols);
  int views_used = 0;
  for (std::size_t k = 0; k < s.views.size(); ++k) {
    if (placements[k].how == perception::PlacementHow::LeftOut) continue;
    ++views_used;
    const auto& vis = *s.views[k].visibility;
    for (int r = 0; r < grid.rows; ++r)
      for (int c = 0; c < grid.cols; ++c) {
        const std::uint8_t a = visible(r, c), b = vis(r, c);
        const auto V = std::uint8_t(sim::Visibility::Visible), H = std::uint8_t(sim::Visibility::Hidden);
        visible(r, c) = (a == V || b == V) ? V : (a == H || b == H) ? H : std::uint8_t(sim::Visibility::OutOfView);
      }
  }
  s.addTime("merge", t.seconds());
  const MapMetrics m = mapMetrics(composite, truth, visible);
  CompositeScore score;
  score.map = m, score.views = int(s.views.size()), score.views_used = views_used;
  score.poses = mergePosesName(spec.poses);
  score.placements = &placements, score.links = &links;
  s.metrics["composite"] = toJson(score);
  writeMapFiles(s.out / "maps", "composite", composite, &truth,
                sc.name + ": composite of " + std::to_string(s.views.size()) + " views (" + mergePosesName(spec.poses) +
                    " poses)",
                s.geo);
  char line[200];
  std::snprintf(line, sizeof line, "merge     composite of %d of %d views (%s poses): coverage %.1f%%, RMS error %.4f m, within 1σ %.0f%%",
                views_used, int(s.views.size()), mergePosesName(spec.poses), 100 * m.coverage, m.rms_error_m, 100 * m.within_1sigma);
  s.say(line);
  s.composite = std::move(composite);
}

}  // namespace

Stage merge() {
  return {"merge", [](const Scenario& sc) { return sc.merge.has_value(); }, run};
}

}  // namespace ambler::eval::stages
