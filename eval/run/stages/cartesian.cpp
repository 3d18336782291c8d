// The Cartesian baseline stage: each view's unwrapped image (from the map stage) binned into the
// same grid by eq. 1, gaps filled both ways (nearest, linear) and the better by RMS error against
// ground truth reported, a fair competitor; maps/view_<k>_cartesian_*.
#include <cstdio>
#include <optional>
#include <utility>

#include "eval/score/map_metrics.hpp"
#include "eval/pictures/map_outputs.hpp"
#include "eval/run/stages.hpp"
#include "perception/cartesian_mapper.hpp"

namespace ambler::eval::stages {

namespace {

void run(RunState& s) {
  const Scenario& sc = s.scenario;
  s.metrics["map_cartesian"] = nlohmann::ordered_json::array();
  for (int k = 0; k < int(s.views.size()); ++k) {
    const ViewState& view = s.views[k];
    const perception::MapGrid& grid = view.truth->grid();
    const Eigen::Vector3d sensor_position = view.T_WS.translation();
    std::optional<perception::ElevationMap> best;
    std::optional<MapMetrics> best_m;
    std::string best_fill;
    base::Stopwatch t;
    for (const auto& [fill, name] : {std::pair{perception::GapFill::Nearest, "nearest"},
                                     std::pair{perception::GapFill::Linear, "linear"}}) {
      perception::CartesianConfig config;
      config.gap_fill = fill;
      perception::ElevationMap cart = perception::cartesianMap(view.locus->image, grid, config);
      const MapMetrics cm = mapMetrics(cart, *view.truth, *view.visibility, &sensor_position);
      if (!best_m || cm.rms_error_m < best_m->rms_error_m) best.emplace(std::move(cart)), best_m = cm, best_fill = name;
    }
    s.addTime("map_cartesian", t.seconds() / 2);  // per baseline map
    auto j = cartesianJson(*best_m, k);
    j["gap_fill"] = best_fill;
    s.metrics["map_cartesian"].push_back(j);
    writeCartesianFiles(s.out / "maps", viewName(k), *best, &*view.truth,
                        sc.name + ": " + viewName(k) + " Cartesian baseline", s.geo);
    char line[200];
    std::snprintf(line, sizeof line, "cartesian %s: coverage %.1f%%, RMS error %.4f m (%s gap filling)",
                  viewName(k).c_str(), 100 * best_m->coverage, best_m->rms_error_m, best_fill.c_str());
    s.say(line);
  }
}

}  // namespace

Stage cartesian() {
  return {"cartesian", [](const Scenario& sc) { return sc.map && !sc.traverse && sc.map->baseline == Baseline::Cartesian; }, run};
}

}  // namespace ambler::eval::stages
