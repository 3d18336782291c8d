// eval/score/stats.hpp: order statistics by hand, and Wilson's score interval against the values
// Newcombe tabulates (Statistics in Medicine 17, 1998, table II: method 3) and its closed form.
#include <gtest/gtest.h>

#include <cmath>

#include "eval/score/stats.hpp"

namespace ambler::eval {
namespace {

TEST(Stats, MedianAndQuantileByHand) {
  EXPECT_TRUE(std::isnan(median({})));
  EXPECT_EQ(median({3, 1, 2}), 2.0);
  EXPECT_EQ(median({4, 1, 3, 2}), 2.5);
  EXPECT_TRUE(std::isnan(quantile({}, 0.5)));
  // 1 2 3 4 5: q = 0.9 sits at 0.9·4 = 3.6, between 4 and 5.
  EXPECT_DOUBLE_EQ(quantile({5, 1, 4, 2, 3}, 0.9), 4.6);
  EXPECT_EQ(quantile({5, 1, 4, 2, 3}, 0.0), 1.0);
  EXPECT_EQ(quantile({5, 1, 4, 2, 3}, 1.0), 5.0);
  EXPECT_EQ(quantile({7}, 0.3), 7.0);
}

TEST(Stats, WilsonIntervalMatchesNewcombesTable) {
  // Newcombe's examples (4 decimals): 81/263, 15/148, 0/20, 1/29.
  const struct {
    int k, n;
    double lo, hi;
  } rows[] = {{81, 263, 0.2553, 0.3662}, {15, 148, 0.0624, 0.1605}, {0, 20, 0.0, 0.1611}, {1, 29, 0.0061, 0.1718}};
  for (const auto& r : rows) {
    const Interval i = wilsonInterval(r.k, r.n);
    EXPECT_NEAR(i.lo, r.lo, 5e-5) << r.k << "/" << r.n;  // the table's rounding
    EXPECT_NEAR(i.hi, r.hi, 5e-5) << r.k << "/" << r.n;
  }
  // All successes: the mirror of none, 1 − hi(0/n) = n/(n + z²).
  const double z2 = 1.959963984540054 * 1.959963984540054;
  EXPECT_NEAR(wilsonInterval(200, 200).lo, 200 / (200 + z2), 1e-12);
  EXPECT_DOUBLE_EQ(wilsonInterval(200, 200).hi, 1.0);
  EXPECT_TRUE(std::isnan(wilsonInterval(0, 0).lo));
}

}  // namespace
}  // namespace ambler::eval
