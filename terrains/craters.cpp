#include "terrains/craters.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "base/random.hpp"

namespace ambler::terrains {

void checkCraterSpec(const CraterSpec& s) {
  auto fail = [](const char* what) {
    throw std::invalid_argument(std::string("craters: ") + what);
  };
  if (s.count < 0) fail("count must be >= 0");
  if (s.count > 1000000) fail("count must be <= 1e6");
  if (!(s.min_diameter_m > 0.0) || !std::isfinite(s.min_diameter_m))
    fail("min_diameter_m must be finite and > 0");
  if (!(s.max_diameter_m >= s.min_diameter_m) || !std::isfinite(s.max_diameter_m))
    fail("max_diameter_m must be finite and >= min_diameter_m");
  if (!(s.sfd_exponent > 0.0) || !std::isfinite(s.sfd_exponent))
    fail("sfd_exponent must be finite and > 0");
}

double craterDiameterQuantile(const CraterSpec& s, double u) {
  const double b = s.sfd_exponent;
  const double lo = std::pow(s.min_diameter_m, -b), hi = std::pow(s.max_diameter_m, -b);
  const double d = std::pow(lo - u * (lo - hi), -1.0 / b);
  return std::clamp(d, s.min_diameter_m, s.max_diameter_m);  // rounding must not leave the range
}

double craterProfile(double r, double diameter_m) {
  const double radius = 0.5 * diameter_m;
  const double depth = kCraterDepthRatio * diameter_m, rim = kCraterRimRatio * diameter_m;
  if (r < radius) return (depth + rim) * (r / radius) * (r / radius) - depth;
  if (r >= kCraterCutoffRadii * radius) return 0.0;
  // Subtracting the cut-off value and renormalising keeps h at the rim and 0 at the cut-off:
  // continuous everywhere, within h/511 of the untapered h·(R/r)³.
  const double tail = std::pow(1.0 / kCraterCutoffRadii, 3);
  const double s = radius / r;
  return rim * (s * s * s - tail) / (1.0 - tail);
}

std::vector<Crater> sampleCraters(const CraterSpec& spec, const Heightfield& grid,
                                  std::uint64_t key) {
  checkCraterSpec(spec);
  base::Rng rng(key);
  std::vector<Crater> craters(spec.count);
  for (auto& c : craters) {
    c.diameter_m = craterDiameterQuantile(spec, rng.uniform());
    c.center = {rng.uniform(grid.xMin(), grid.xMax()), rng.uniform(grid.yMin(), grid.yMax())};
  }
  return craters;
}

void addCraters(Heightfield& ground, const std::vector<Crater>& craters) {
  for (const auto& crater : craters) {
    const double reach = 0.5 * kCraterCutoffRadii * crater.diameter_m;
    const Eigen::Vector2d lo =
        (crater.center.array() - reach - ground.origin().array()) / ground.cell();
    const Eigen::Vector2d hi =
        (crater.center.array() + reach - ground.origin().array()) / ground.cell();
    const int c0 = std::max(0, int(std::floor(lo.x()))),
              c1 = std::min(ground.cols() - 1, int(std::ceil(hi.x())));
    const int r0 = std::max(0, int(std::floor(lo.y()))),
              r1 = std::min(ground.rows() - 1, int(std::ceil(hi.y())));
    for (int r = r0; r <= r1; ++r)
      for (int c = c0; c <= c1; ++c)
        ground.at(r, c) +=
            craterProfile((ground.position(r, c) - crater.center).norm(), crater.diameter_m);
  }
}

}  // namespace ambler::terrains
