// eval/score/footfall_score: a choice scored against a hand-made true score raster, where the true
// percentile is counted by hand.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "eval/score/footfall_score.hpp"

namespace ambler::eval {
namespace {

constexpr float kNaNf = std::numeric_limits<float>::quiet_NaN();

// A 1 × 5 grid of 0.5 m cells from x = 10 m, its row's top at y = 2 m: cell c's centre is
// (10.25 + 0.5·c, 1.75).
perception::MapGrid grid() {
  perception::MapGrid g;
  g.x_min = 10, g.y_max = 2, g.cell = 0.5, g.rows = 1, g.cols = 5;
  return g;
}

perception::FootfallScores scores(std::initializer_list<float> values, std::optional<int> best_col) {
  perception::FootfallScores s;
  s.score = perception::Raster<float>(1, 5);
  int c = 0;
  for (const float v : values) s.score(0, c++) = v;
  if (best_col) s.best = Eigen::Vector2i(0, *best_col), s.best_score = s.score(0, *best_col);
  return s;
}

TEST(FootfallScore, TruePercentileIsTheShareOfTrueCandidatesScoredBetter) {
  // The truth scores four candidates (one it rejects: NaN); the rover chose column 3, whose true
  // score 0.4 three of the four beat: 3/4.
  const auto truth = scores({0.1f, 0.2f, kNaNf, 0.4f, 0.3f}, std::nullopt);
  const FootfallChoice c = scoreChoice("planar_fit", scores({5, 4, 3, 1, 2}, 3), truth, grid());
  EXPECT_EQ(c.method, "planar_fit");
  EXPECT_DOUBLE_EQ(c.x_m, 11.75);
  EXPECT_DOUBLE_EQ(c.y_m, 1.75);
  EXPECT_DOUBLE_EQ(c.score, 1.0);
  EXPECT_DOUBLE_EQ(c.truth_score, 0.4f);
  EXPECT_DOUBLE_EQ(c.truth_percentile, 0.75);
  // The truth's best is column 0 (0.1 at x = 10.25 m): the regret is 0.4 − 0.1 in float.
  EXPECT_DOUBLE_EQ(c.truth_best_x_m, 10.25);
  EXPECT_DOUBLE_EQ(c.truth_best_y_m, 1.75);
  EXPECT_DOUBLE_EQ(c.truth_best_score, 0.1f);
  EXPECT_DOUBLE_EQ(c.regret, double(0.4f) - double(0.1f));
  // The truth's own best: 0, and no regret.
  const FootfallChoice best = scoreChoice("m", scores({0, 9, 9, 9, 9}, 0), truth, grid());
  EXPECT_DOUBLE_EQ(best.truth_percentile, 0.0);
  EXPECT_EQ(best.regret, 0.0);
  // Ties: the first in row-major order is the truth's best.
  const FootfallChoice tie = scoreChoice("m", scores({0, 9, 9, 9, 9}, 0), scores({0.5f, 0.2f, 0.9f, 0.2f, kNaNf}, std::nullopt), grid());
  EXPECT_DOUBLE_EQ(tie.truth_best_x_m, 10.75);
  EXPECT_DOUBLE_EQ(tie.regret, double(0.5f) - double(0.2f));
  // A cell the truth rejects is worse than every true candidate: 4/4.
  const FootfallChoice rejected = scoreChoice("m", scores({9, 9, 0, 9, 9}, 2), truth, grid());
  EXPECT_TRUE(std::isnan(rejected.truth_score));
  EXPECT_DOUBLE_EQ(rejected.truth_percentile, 1.0);
  EXPECT_TRUE(std::isnan(rejected.regret));  // no true score to compare
  EXPECT_DOUBLE_EQ(rejected.truth_best_score, 0.1f);
}

TEST(FootfallScore, NoCandidateIsAllNaNAndNullInJson) {
  const auto none = scores({kNaNf, kNaNf, kNaNf, kNaNf, kNaNf}, std::nullopt);
  perception::FootfallScores s = none;
  s.best_score = std::numeric_limits<double>::quiet_NaN();
  const FootfallChoice c = scoreChoice("m", s, none, grid());
  EXPECT_TRUE(std::isnan(c.x_m) && std::isnan(c.y_m) && std::isnan(c.truth_percentile));
  const nlohmann::ordered_json j = toJson(c);
  EXPECT_TRUE(std::isnan(c.regret) && std::isnan(c.truth_best_x_m) && std::isnan(c.truth_best_score));
  EXPECT_EQ(j.dump(), R"({"method":"m","x_m":null,"y_m":null,"score":null,"truth_score":null,"truth_percentile":null,)"
                      R"("regret":null,"truth_best":{"x_m":null,"y_m":null,"score":null}})");
}

// The miss's cause as the decision it documents: held; nothing in R rests within 5°; the disk
// rests within 5° here but the leg did not hold; the truth's best would have; neither would.
TEST(FootfallScore, MissCauseFollowsItsRules) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(missCause(4.9, 0.009, true, 9, 9, 9), MissCause::None);  // held, whatever the disk says
  EXPECT_EQ(missCause(4.9, 0.009, false, 1, 1, 1), MissCause::Leg);  // not settled is a miss
  EXPECT_EQ(missCause(6, 0, true, 1, 1, 5.1), MissCause::Ground);
  EXPECT_EQ(missCause(6, 0, true, 1, 1, nan), MissCause::Ground);  // no rest anywhere
  EXPECT_EQ(missCause(3, 0.02, true, 5, 9, 1), MissCause::Leg);    // a slip where the disk rests within 5°
  EXPECT_EQ(missCause(8, 0, true, 7, 5, 1), MissCause::Map);
  EXPECT_EQ(missCause(8, 0, true, 7, 6, 1), MissCause::Method);
  EXPECT_EQ(missCause(8, 0, true, nan, nan, 1), MissCause::Method);  // no rest at either spot
  EXPECT_STREQ(missCauseName(MissCause::Map), "map");
}

}  // namespace
}  // namespace ambler::eval
