// The leg stage (docs/scenario.md, "leg"; docs/leg.md): the simulated leg, built once for the run on
// the world cropped to the footfall region (sim::Leg), steps on each footfall method's choice and
// reports the foot's tilt, sink, slip and whether it settled, beside the tilt and height a rigid
// disk would rest at on the true surface (sim::restingDisk, no dynamics), and the same for the
// candidate the method would choose on the true surface (its truth_best: what a perfect map would
// have given). world/leg.xml (the world with the leg, for MuJoCo's simulate), leg/METHOD.json,
// leg/predicted_tilt.tiff (every candidate), metrics.footfall[k].leg and .truth_best.leg,
// metrics.footfall_region's rigid-disk figures.
#include <tbb/parallel_invoke.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <thread>
#include <utility>
#include <vector>

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

double soilSinkage(const Scenario& sc) {
  if (!sc.footfall || !sc.leg || sc.leg->soil != Soil::Sand) return 0.0;
  return sim::bekkerSinkage(sc.leg->load_n, legConfig(sc));
}

sim::LegRegion legRegion(const Scenario& sc) {
  const FootfallSpec& ff = *sc.footfall;
  return {ff.x_m[0], ff.x_m[1], ff.y_m[0], ff.y_m[1]};
}

namespace stages {

namespace {

// The true surface on the footfall map's grid (the footfall stage's), rows flipped to
// restingDisk's (row 0 at the smallest y), and where its first cell's centre lies.
struct TrueHeights {
  Eigen::MatrixXf heights;
  double cell, x0, y0;
  std::optional<sim::DiskRest> rest(double x, double y, double diameter_m) const {
    return sim::restingDisk(heights, cell, x0, y0, x, y, diameter_m);
  }
};

TrueHeights trueHeights(const RunState& s) {
  const perception::MapGrid& grid = s.footfall_truth->grid();
  return {s.footfall_truth->elevation().colwise().reverse(), grid.cell, grid.x_min + 0.5 * grid.cell,
          grid.y_max - (grid.rows - 0.5) * grid.cell};
}

// The prediction for every candidate centre of the region: the tilt a rigid disk rests at on the
// true surface (leg/predicted_tilt.tiff, NaN outside the region or where no rest exists); and
// whether any candidate of R could hold: the smallest rest tilt and the share of candidates within
// the goal's 5° (metrics.footfall_region; docs/experiments/footfall.md, "Where the misses come from").
void predictedTilts(RunState& s, const TrueHeights& truth, double diameter_m) {
  const perception::MapGrid& grid = s.footfall_truth->grid();
  const perception::CellRegion region = s.scenario.footfall->candidates(grid);
  perception::Raster<float> tilt =
      perception::Raster<float>::Constant(grid.rows, grid.cols, std::numeric_limits<float>::quiet_NaN());
  double lowest = std::numeric_limits<double>::quiet_NaN();
  long within = 0;
  const long candidates = long(region.rows) * region.cols;
  for (int r = region.row0; r < region.row0 + region.rows; ++r)
    for (int c = region.col0; c < region.col0 + region.cols; ++c) {
      const Eigen::Vector2d xy = grid.center(r, c);
      const auto rest = truth.rest(xy.x(), xy.y(), diameter_m);
      if (!rest) continue;
      tilt(r, c) = float(rest->tilt_deg);
      if (!(tilt(r, c) >= lowest)) lowest = tilt(r, c);
      within += tilt(r, c) <= 5.0f;
    }
  writeGeoTiff(s.out / "leg" / "predicted_tilt.tiff", tilt, grid, s.geo);
  s.metrics["footfall_region"]["min_predicted_tilt_deg"] = jsonNumber(lowest);
  s.metrics["footfall_region"]["predicted_within_5deg_fraction"] =
      jsonNumber(candidates ? double(within) / double(candidates) : std::numeric_limits<double>::quiet_NaN());
}

void run(RunState& s) {
  const Scenario& sc = s.scenario;
  const sim::LegConfig config = legConfig(sc);
  sim::writeLegWorld(s.world_xml, config);
  std::filesystem::create_directories(s.out / "leg");
  const TrueHeights truth = trueHeights(s);
  predictedTilts(s, truth, config.foot_diameter_m);
  // Built once, on the world cropped to the footfall region, which holds every choice.
  base::Stopwatch build;
  sim::Leg leg(s.world_xml, legRegion(sc), config);
  s.addTime("leg", build.seconds());
  // A step is a function of where the foot goes (sim::Leg's steps are independent): every spot
  // (each method's choice and its truth's best) is stepped on once, by two legs at once where
  // there are two spots and two cores (Leg::clone: the same outcomes, bit for bit).
  std::vector<std::pair<double, double>> spots;
  for (const FootfallChoice& c : s.choices)
    for (const auto& xy : {std::make_pair(c.x_m, c.y_m), std::make_pair(c.truth_best_x_m, c.truth_best_y_m)})
      if (std::isfinite(xy.first) && std::find(spots.begin(), spots.end(), xy) == spots.end()) spots.push_back(xy);
  std::vector<sim::LegOutcome> outcomes(spots.size());
  {
    base::Stopwatch t;
    const auto stepEvery = [&](sim::Leg& l, std::size_t first) {
      for (std::size_t i = first; i < spots.size(); i += 2) outcomes[i] = l.step(spots[i].first, spots[i].second);
    };
    if (spots.size() > 1 && std::thread::hardware_concurrency() > 1) {
      sim::Leg twin = leg.clone();
      tbb::parallel_invoke([&] { stepEvery(leg, 0); }, [&] { stepEvery(twin, 1); });
    } else {
      for (std::size_t i = 0; i < spots.size(); ++i) outcomes[i] = leg.step(spots[i].first, spots[i].second);
    }
    s.addTime("leg", t.seconds());
  }
  const auto stepOn = [&](double x, double y) {
    return outcomes[std::size_t(std::find(spots.begin(), spots.end(), std::make_pair(x, y)) - spots.begin())];
  };
  // The leg's figures at (x, y), and the rigid disk's tilt there on the truth; nulls without a spot.
  const auto outcome = [&](double x, double y) {
    nlohmann::ordered_json j;
    j["x_m"] = jsonNumber(x);
    j["y_m"] = jsonNumber(y);
    if (!std::isfinite(x)) {
      for (const char* key : {"tilt_deg", "sink_m", "slip_m"}) j[key] = nullptr;
      j["settled"] = false;
      j["settled_by_excursion"] = false;
      j["predicted_tilt_deg"] = nullptr;
      return j;
    }
    const sim::LegOutcome o = stepOn(x, y);
    const auto rest = truth.rest(x, y, config.foot_diameter_m);
    j["tilt_deg"] = o.tilt_deg;
    j["sink_m"] = o.sink_m;
    j["slip_m"] = o.slip_m;
    j["settled"] = o.settled;
    j["settled_by_excursion"] = o.settled_by_excursion;
    j["contact_cap_reached"] = o.contact_cap_reached;
    j["predicted_tilt_deg"] = rest ? jsonNumber(rest->tilt_deg) : nlohmann::ordered_json(nullptr);
    return j;
  };
  const auto metricsOf = [](const nlohmann::ordered_json& j) {
    nlohmann::ordered_json m;
    for (const char* key : {"tilt_deg", "sink_m", "slip_m", "settled", "settled_by_excursion", "predicted_tilt_deg"})
      m[key] = j[key];
    return m;
  };
  const auto degrees = [](const nlohmann::ordered_json& v) {
    char text[32] = "-";
    if (v.is_number()) std::snprintf(text, sizeof text, "%.2f deg", v.get<double>());
    return std::string(text);
  };
  for (std::size_t k = 0; k < s.choices.size(); ++k) {
    const FootfallChoice& c = s.choices[k];
    nlohmann::ordered_json j = outcome(c.x_m, c.y_m);
    const nlohmann::ordered_json best = outcome(c.truth_best_x_m, c.truth_best_y_m);
    if (std::isfinite(c.x_m)) {
      char line[300];
      std::snprintf(line, sizeof line,
                    "leg       %-21s tilt %5.2f deg (rigid disk on the truth: %s), sink %.1f mm, slip %.1f mm%s%s; "
                    "on the truth's best: tilt %s",
                    c.method.c_str(), j["tilt_deg"].get<double>(), degrees(j["predicted_tilt_deg"]).c_str(),
                    1000 * j["sink_m"].get<double>(), 1000 * j["slip_m"].get<double>(),
                    j["settled"].get<bool>() ? "" : ", NOT SETTLED",
                    j["contact_cap_reached"].get<bool>() ? ", CONTACT CAP REACHED" : "",
                    degrees(best["tilt_deg"]).c_str());
      s.say(line);
    }
    j["truth_best"] = best;
    writeJson(s.out / "leg" / (c.method + ".json"), j);
    s.metrics["footfall"][k]["leg"] = metricsOf(j);
    s.metrics["footfall"][k]["truth_best"]["leg"] = metricsOf(best);
  }
}

}  // namespace

Stage leg() {
  return {"leg", [](const Scenario& sc) { return sc.leg.has_value(); }, run};
}

}  // namespace stages
}  // namespace ambler::eval
