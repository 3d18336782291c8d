#pragma once
// A footfall method's choice scored against the truth (docs/footfall.md): where it put the foot,
// its own score there, the true surface's score there by the same method, its true percentile,
// the share of the true candidates the truth scores better (0: the truth's best; a cell the truth
// rejects is worse than every true candidate: 1), and its regret, the true score there minus the
// truth's best score in the region (0: the truth's best; NaN where the truth rejects the choice),
// with where that best is.
#include <nlohmann/json.hpp>
#include <string>

#include "perception/footfall.hpp"
#include "perception/map_grid.hpp"

namespace ambler::eval {

struct FootfallChoice {
  std::string method;
  double x_m, y_m;  // the chosen foot centre (NaN: no candidate)
  double score, truth_score, truth_percentile;
  double regret;                              // truth_score − truth_best_score
  double truth_best_x_m, truth_best_y_m;      // the truth's best candidate (NaN: none)
  double truth_best_score;
};

// `scores` is the method's evaluation of the rover's map and `truth` the same method's of the
// true surface, both on `grid`.
FootfallChoice scoreChoice(const std::string& method, const perception::FootfallScores& scores,
                           const perception::FootfallScores& truth, const perception::MapGrid& grid);

// Where a step's miss comes from (docs/experiments/footfall.md, "Where the misses come from"), from
// the leg's outcome and rigid-disk rest tilts on the true surface (sim::restingDisk): None, the
// step held (settled, tilt ≤ 5°, slip ≤ 1 cm); Ground, no candidate of R rests a rigid disk within
// 5° (region_min); Leg, the rigid disk rests within 5° at the chosen spot but the leg did not hold;
// Map, the chosen spot tilts the disk beyond 5° and the method's choice on the true surface
// (truth_best) would not; Method, both would. A NaN tilt is not within 5°.
enum class MissCause { None, Ground, Leg, Map, Method };
MissCause missCause(double tilt_deg, double slip_m, bool settled, double predicted_tilt_deg,
                    double truth_best_predicted_deg, double region_min_predicted_deg);
const char* missCauseName(MissCause c);

// footfall/METHOD.json and metrics.footfall[k]: method, x_m, y_m, score, truth_score,
// truth_percentile, regret, truth_best {x_m, y_m, score} (NaN → null).
nlohmann::ordered_json toJson(const FootfallChoice& c);

}  // namespace ambler::eval
