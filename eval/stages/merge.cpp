// The merge stage (docs/scenario.md, "merge"; docs/composite.md): every view's scan mapped on the
// composite grid at its pose — the true one, or the rover's, chained from view 0 through the first
// listed matching method's estimates — and merged by eq. 9 (perception::mergeInto). With matched
// poses each link's covariance is propagated into the cells' σ (perception::registrationSigma), so
// a composite built on a poor match says so. Scored against ground truth: maps/composite_*.
#include <algorithm>
#include <cmath>
#include <cstdio>

#include "eval/map_metrics.hpp"
#include "eval/map_outputs.hpp"
#include "eval/stages.hpp"
#include "perception/composite.hpp"

namespace ambler::eval::stages {

namespace {

// A view's place in the composite: its sensor pose and the links (estimates) it was chained by.
struct Placement {
  bool placed = false;
  Eigen::Isometry3d T_WS = Eigen::Isometry3d::Identity();
  std::vector<const PairEstimate*> links;
};

// Matched poses: view 0 at its true pose (the composite's frame is view 0's world), then each
// pair's estimate of the first listed method, applied from whichever view is placed, until
// nothing more is (the scenario reader checked that every view is linked to view 0).
std::vector<Placement> matchedPlacements(const RunState& s) {
  const MatchMethod first = s.scenario.matching->methods.front();
  std::vector<Placement> p(s.views.size());
  p[0].placed = true;
  p[0].T_WS = s.views[0].T_WS;
  for (bool grew = true; grew;) {
    grew = false;
    for (const PairEstimate& e : s.estimates) {
      if (e.method != first || p[e.i].placed == p[e.j].placed) continue;
      const bool forward = p[e.i].placed;
      Placement& to = p[forward ? e.j : e.i];
      const Placement& from = p[forward ? e.i : e.j];
      to.placed = true;
      to.T_WS = from.T_WS * (forward ? e.T_IJ : e.T_IJ.inverse());
      to.links = from.links;
      to.links.push_back(&e);
      grew = true;
    }
  }
  return p;
}

void run(RunState& s) {
  const Scenario& sc = s.scenario;
  const MergeSpec& spec = *sc.merge;
  const perception::MapGrid grid = spec.grid();
  Stopwatch t;
  std::vector<Placement> placements(s.views.size());
  if (spec.poses == MergePoses::Matched) {
    placements = matchedPlacements(s);
  } else {
    for (std::size_t k = 0; k < s.views.size(); ++k) placements[k] = {true, s.views[k].T_WS, {}};
  }
  perception::LocusConfig locus = locusConfig(sc);
  locus.footprint_sigma = true;  // the footprint's error is shared by every view (docs/composite.md)
  // σ without the terrain's part (docs/locus.md, σ_rough): what is left is the part every view
  // of a cell shares (docs/composite.md).
  perception::LocusConfig noise_only = locus;
  noise_only.roughness = false;
  perception::ElevationMap composite(grid);
  perception::Raster<float> composite_shared = perception::Raster<float>::Zero(grid.rows, grid.cols);
  const perception::ElevationMap truth = s.truth->elevation(grid);
  perception::Raster<std::uint8_t> visible = perception::Raster<std::uint8_t>::Zero(grid.rows, grid.cols);
  for (std::size_t k = 0; k < s.views.size(); ++k) {
    const ViewState& v = s.views[k];
    // The scan as the map stage had it (unwrapped, its edges), at the composite's pose for it.
    perception::ElevationMap map = perception::mapAtPose(*v.locus, placements[k].T_WS, grid, locus);
    const perception::ElevationMap noise = perception::mapAtPose(*v.locus, placements[k].T_WS, grid, noise_only);
    perception::Raster<float> shared = perception::Raster<float>::Zero(grid.rows, grid.cols);
    for (int r = 0; r < grid.rows; ++r)
      for (int c = 0; c < grid.cols; ++c)
        if (map.stateAt(r, c) == perception::CellState::Known && noise.stateAt(r, c) == perception::CellState::Known)
          shared(r, c) = std::sqrt(std::max(0.f, map.sigma()(r, c) * map.sigma()(r, c) - noise.sigma()(r, c) * noise.sigma()(r, c)));
    // Each link's pose covariance, first order and independent: variances add.
    perception::Raster<float> extra = perception::Raster<float>::Zero(grid.rows, grid.cols);
    bool any = false;
    for (const PairEstimate* e : placements[k].links) {
      if (!e->covariance) continue;
      const perception::Raster<float> sr = perception::registrationSigma(map, e->nu, *e->covariance);
      extra = (extra.array().square() + sr.array().square()).sqrt().matrix();
      any = true;
    }
    if (any) perception::addSigma(map, extra);
    perception::mergeInto(composite, composite_shared, map, shared);
    // What some view could see: visible if any view sees the true surface, else hidden if one
    // view's field of view holds it behind terrain.
    const auto& vis = *v.visibility;
    for (int r = 0; r < grid.rows; ++r)
      for (int c = 0; c < grid.cols; ++c) {
        const std::uint8_t a = visible(r, c), b = vis(r, c);
        const auto V = std::uint8_t(sim::Visibility::Visible), H = std::uint8_t(sim::Visibility::Hidden);
        visible(r, c) = (a == V || b == V) ? V : (a == H || b == H) ? H : std::uint8_t(sim::Visibility::OutOfView);
      }
  }
  s.addTime("merge", t.seconds());
  const MapMetrics m = mapMetrics(composite, truth, visible);
  s.metrics["composite"] = compositeJson(m, int(s.views.size()), mergePosesName(spec.poses));
  writeMapFiles(s.out / "maps", "composite", composite, &truth,
                sc.name + ": composite of " + std::to_string(s.views.size()) + " views (" + mergePosesName(spec.poses) +
                    " poses)",
                s.geo);
  char line[200];
  std::snprintf(line, sizeof line, "merge     composite of %d views (%s poses): coverage %.1f%%, RMS error %.4f m, within 1σ %.0f%%",
                int(s.views.size()), mergePosesName(spec.poses), 100 * m.coverage, m.rms_error_m, 100 * m.within_1sigma);
  s.say(line);
  s.composite = std::move(composite);
}

}  // namespace

Stage merge() {
  return {"merge", [](const Scenario& sc) { return sc.merge.has_value(); }, run};
}

}  // namespace ambler::eval::stages
