#pragma once
// Order statistics the commands print and plot (bench, basin, experiments, sweep reports).
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace ambler::eval {

// The median of `v` (the mean of the two middle values for an even count); NaN when empty.
inline double median(std::vector<double> v) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::sort(v.begin(), v.end());
  const std::size_t h = v.size() / 2;
  return v.size() % 2 ? v[h] : 0.5 * (v[h - 1] + v[h]);
}

// The q-quantile of `v` (q in [0, 1]), linear between order statistics; NaN when empty.
inline double quantile(std::vector<double> v, double q) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::sort(v.begin(), v.end());
  const double at = q * double(v.size() - 1);
  const std::size_t i = std::size_t(std::floor(at));
  return i + 1 < v.size() ? v[i] + (at - double(i)) * (v[i + 1] - v[i]) : v[i];
}

// A proportion's interval (lo, hi in [0, 1]); NaN for no trials.
struct Interval {
  double lo = std::numeric_limits<double>::quiet_NaN(), hi = std::numeric_limits<double>::quiet_NaN();
};

// Wilson's score interval for `successes` of `trials` at 95 % (z = 1.95996): centre
// (p + z²/2n)/(1 + z²/n), half-width z·√(p(1−p)/n + z²/4n²)/(1 + z²/n). Unlike p ± z·√(p(1−p)/n)
// it stays inside [0, 1] and does not collapse to a point at 0 or n successes.
inline Interval wilsonInterval(int successes, int trials) {
  if (trials <= 0) return {};
  constexpr double z = 1.959963984540054;  // the normal's 97.5 % quantile
  const double n = trials, p = successes / n, z2 = z * z;
  const double centre = (p + z2 / (2 * n)) / (1 + z2 / n);
  const double half = z * std::sqrt(p * (1 - p) / n + z2 / (4 * n * n)) / (1 + z2 / n);
  return {std::max(0.0, centre - half), std::min(1.0, centre + half)};
}

}  // namespace ambler::eval
