// The leg stage (docs/scenario.md, "leg"; docs/leg.md): the simulated leg, built once for the run on
// the world cropped to the footfall region (sim::Leg), steps on each footfall method's choice and
// reports the foot's tilt, sink, slip and whether it settled, beside the tilt and height a rigid
// disk would rest at on the true surface (sim::restingDisk, no dynamics). world/leg.xml (the world with the leg, for MuJoCo's
// simulate), leg/METHOD.json, leg/predicted_tilt.tiff (every candidate), metrics.footfall[k].leg.
#include <cmath>
#include <cstdio>
#include <limits>

#include "eval/scenario/io.hpp"
#include "eval/run/stages.hpp"
#include "sim/leg.hpp"

namespace ambler::eval {

sim::LegConfig legConfig(const Scenario& sc) {
  sim::LegConfig config;
  config.foot_diameter_m = sc.footfall->foot_diameter_m;
  config.load_n = sc.leg->load_n;
  config.soil = sc.leg->soil == Soil::Sand ? sim::Soil::Sand : sim::Soil::Rock;
  config.hold_s = 0;  // the drift over a hold is not reported: stop when settled
  return config;
}

sim::LegRegion legRegion(const Scenario& sc) {
  const FootfallSpec& ff = *sc.footfall;
  return {ff.x_m[0], ff.x_m[1], ff.y_m[0], ff.y_m[1]};
}

namespace stages {

namespace {

void run(RunState& s) {
  const Scenario& sc = s.scenario;
  const sim::LegConfig config = legConfig(sc);
  sim::writeLegWorld(s.world_xml, config);
  std::filesystem::create_directories(s.out / "leg");
  // The true surface on the footfall map's grid (the footfall stage's), rows flipped to
  // restingDisk's (row 0 at the smallest y).
  const perception::MapGrid& grid = s.footfall_truth->grid();
  const Eigen::MatrixXf heights = s.footfall_truth->elevation().colwise().reverse();
  const double x0 = grid.x_min + 0.5 * grid.cell, y0 = grid.y_max - (grid.rows - 0.5) * grid.cell;
  // The prediction for every candidate centre of the region: the tilt a rigid disk rests at on the
  // true surface (leg/predicted_tilt.tiff, NaN outside the region or where no rest exists).
  {
    const FootfallSpec& ff = *sc.footfall;
    const perception::CellRegion region = ff.candidates(grid);
    perception::Raster<float> tilt =
        perception::Raster<float>::Constant(grid.rows, grid.cols, std::numeric_limits<float>::quiet_NaN());
    for (int r = region.row0; r < region.row0 + region.rows; ++r)
      for (int c = region.col0; c < region.col0 + region.cols; ++c) {
        const Eigen::Vector2d xy = grid.center(r, c);
        if (const auto rest = sim::restingDisk(heights, grid.cell, x0, y0, xy.x(), xy.y(), config.foot_diameter_m))
          tilt(r, c) = float(rest->tilt_deg);
      }
    writeGeoTiff(s.out / "leg" / "predicted_tilt.tiff", tilt, grid, s.geo);
  }
  // Built once, on the world cropped to the footfall region, which holds every choice.
  base::Stopwatch build;
  sim::Leg leg(s.world_xml, legRegion(sc), config);
  s.addTime("leg", build.seconds());
  for (std::size_t k = 0; k < s.choices.size(); ++k) {
    const FootfallChoice& c = s.choices[k];
    nlohmann::ordered_json j;
    j["x_m"] = jsonNumber(c.x_m);
    j["y_m"] = jsonNumber(c.y_m);
    if (!std::isfinite(c.x_m)) {
      for (const char* key : {"tilt_deg", "sink_m", "slip_m"}) j[key] = nullptr;
      j["settled"] = false;
    } else {
      base::Stopwatch t;
      const sim::LegOutcome o = leg.step(c.x_m, c.y_m);
      s.addTime("leg", t.seconds());
      const auto rest = sim::restingDisk(heights, grid.cell, x0, y0, c.x_m, c.y_m, config.foot_diameter_m);
      j["tilt_deg"] = o.tilt_deg;
      j["sink_m"] = o.sink_m;
      j["slip_m"] = o.slip_m;
      j["settled"] = o.settled;
      j["contact_cap_reached"] = o.contact_cap_reached;
      j["predicted_tilt_deg"] = rest ? jsonNumber(rest->tilt_deg) : nlohmann::ordered_json(nullptr);
      char predicted[32] = "-", line[220];
      if (rest) std::snprintf(predicted, sizeof predicted, "%.2f deg", rest->tilt_deg);
      std::snprintf(line, sizeof line, "leg       %-21s tilt %5.2f deg (rigid disk on the truth: %s), sink %.1f mm, slip %.1f mm%s%s",
                    c.method.c_str(), o.tilt_deg, predicted, 1000 * o.sink_m, 1000 * o.slip_m,
                    o.settled ? "" : ", NOT SETTLED", o.contact_cap_reached ? ", CONTACT CAP REACHED" : "");
      s.say(line);
    }
    writeJson(s.out / "leg" / (c.method + ".json"), j);
    nlohmann::ordered_json m;
    for (const char* key : {"tilt_deg", "sink_m", "slip_m", "settled"}) m[key] = j[key];
    s.metrics["footfall"][k]["leg"] = m;
  }
}

}  // namespace

Stage leg() {
  return {"leg", [](const Scenario& sc) { return sc.leg.has_value(); }, run};
}

}  // namespace stages
}  // namespace ambler::eval
