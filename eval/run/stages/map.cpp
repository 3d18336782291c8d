// The map stage: each view's scan mapped by the locus algorithm (perception::scanToMap) at the
// pose the rover believes (today the true one), on the scenario's map grid, scored against ground
// truth on the same grid; maps/view_<k>_*.
#include <cstdio>

#include "eval/score/map_metrics.hpp"
#include "eval/pictures/map_outputs.hpp"
#include "eval/run/stages.hpp"

namespace ambler::eval::stages {

namespace {

void run(RunState& s) {
  const Scenario& sc = s.scenario;
  const MapSpec& spec = *sc.map;
  const perception::MapGrid grid = spec.grid();
  const perception::ScanToMapConfig config = spec.scanToMapConfig();
  std::filesystem::create_directories(s.out / "maps");
  s.metrics["map"] = nlohmann::ordered_json::array();
  const perception::ElevationMap truth = s.truth->elevation(grid);  // the same grid for every view
  for (int k = 0; k < int(s.views.size()); ++k) {
    ViewState& view = s.views[k];
    view.truth = truth;
    view.visibility = s.truth->visibility(*view.truth, view.T_WS, sc.sensor);
    base::Stopwatch t;
    view.locus = perception::scanToMap(view.scan->image, sc.sensor, view.T_WS, grid, config);
    s.addTime("map", t.seconds());
    const Eigen::Vector3d sensor_position = view.T_WS.translation();
    const MapMetrics m = mapMetrics(view.locus->map, *view.truth, *view.visibility, &sensor_position);
    s.metrics["map"].push_back(toJson(m, k));
    writeMapFiles(s.out / "maps", viewName(k), view.locus->map, &*view.truth,
                  sc.name + ": " + viewName(k) + " locus map", s.geo);
    char line[200];
    std::snprintf(line, sizeof line,
                  "map       %s: %dx%d cells of %.2f m, coverage %.1f%%, RMS error %.4f m, shadow P/R %.2f/%.2f, "
                  "within 1σ %.0f%%",
                  viewName(k).c_str(), grid.rows, grid.cols, grid.cell, 100 * m.coverage, m.rms_error_m,
                  m.shadow_precision, m.shadow_recall, 100 * m.within_1sigma);
    s.say(line);
  }
}

}  // namespace

Stage map() {
  return {"map", [](const Scenario& sc) { return sc.map && !sc.traverse; }, run};
}

}  // namespace ambler::eval::stages
