#pragma once
// Order statistics the commands print and plot (bench, basin, experiments, sweep reports).
#include <algorithm>
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

}  // namespace ambler::eval
