#include "eval/score/footfall_score.hpp"

#include <cmath>
#include <limits>

#include "eval/scenario/io.hpp"

namespace ambler::eval {

FootfallChoice scoreChoice(const std::string& method, const perception::FootfallScores& scores,
                           const perception::FootfallScores& truth, const perception::MapGrid& grid) {
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  FootfallChoice choice{method, kNaN, kNaN, scores.best_score, kNaN, kNaN, kNaN, kNaN, kNaN, kNaN};
  // The truth's best: its lowest score, the first in row-major order on ties (as
  // FootfallScores::best).
  const auto& ts = truth.score;
  for (int r = 0; r < ts.rows(); ++r)
    for (int c = 0; c < ts.cols(); ++c)
      if (std::isfinite(ts(r, c)) && !(ts(r, c) >= choice.truth_best_score)) {
        choice.truth_best_score = ts(r, c);
        const Eigen::Vector2d xy = grid.center(r, c);
        choice.truth_best_x_m = xy.x(), choice.truth_best_y_m = xy.y();
      }
  if (!scores.best) return choice;
  const int r = scores.best->x(), c = scores.best->y();
  const Eigen::Vector2d xy = grid.center(r, c);
  choice.x_m = xy.x(), choice.y_m = xy.y();
  choice.truth_score = truth.score(r, c);
  choice.regret = choice.truth_score - choice.truth_best_score;
  long better = 0, all = 0;
  for (int i = 0; i < ts.size(); ++i)
    if (std::isfinite(ts.data()[i])) ++all, better += !std::isfinite(choice.truth_score) || ts.data()[i] < choice.truth_score;
  choice.truth_percentile = all ? double(better) / double(all) : kNaN;
  return choice;
}

MissCause missCause(double tilt_deg, double slip_m, bool settled, double predicted_tilt_deg,
                    double truth_best_predicted_deg, double region_min_predicted_deg) {
  constexpr double kTiltDeg = 5.0, kSlipM = 0.01;
  if (settled && tilt_deg <= kTiltDeg && slip_m <= kSlipM) return MissCause::None;
  if (!(region_min_predicted_deg <= kTiltDeg)) return MissCause::Ground;
  if (predicted_tilt_deg <= kTiltDeg) return MissCause::Leg;
  if (truth_best_predicted_deg <= kTiltDeg) return MissCause::Map;
  return MissCause::Method;
}

const char* missCauseName(MissCause c) {
  switch (c) {
    case MissCause::None: return "none";
    case MissCause::Ground: return "ground";
    case MissCause::Leg: return "leg";
    case MissCause::Map: return "map";
    case MissCause::Method: return "method";
  }
  return "?";
}

nlohmann::ordered_json toJson(const FootfallChoice& c) {
  nlohmann::ordered_json j;
  j["method"] = c.method;
  j["x_m"] = jsonNumber(c.x_m);
  j["y_m"] = jsonNumber(c.y_m);
  j["score"] = jsonNumber(c.score);
  j["truth_score"] = jsonNumber(c.truth_score);
  j["truth_percentile"] = jsonNumber(c.truth_percentile);
  j["regret"] = jsonNumber(c.regret);
  j["truth_best"] = {{"x_m", jsonNumber(c.truth_best_x_m)}, {"y_m", jsonNumber(c.truth_best_y_m)},
                     {"score", jsonNumber(c.truth_best_score)}};
  return j;
}

}  // namespace ambler::eval
