// Footfall evaluation (paper §5): every method against its closed form on a tilted plane and
// against a direct evaluation of its definition (cell centres, general least squares) on a
// sinusoid and a step; the paper's failure cases (a spike beats an undulation for max-min and
// planar fit, equal-frequency sinusoids tie for support area, off-centre holes tie for free
// volume); the unknown-cell rule and the plane fill; equilibrium_uncertain avoiding a shadow
// with a high ceiling and a patch of large σ that fool equilibrium; determinism over thread
// counts; bad input. Timings are printed, not asserted.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <limits>
#include <stdexcept>
#include <string>
#include <type_traits>

#include "perception/footfall.hpp"

namespace ambler::perception {
namespace {

constexpr double kEps = 1.0 / (1 << 23);  // 2·(float's unit roundoff): one rounding to float, with margin
using M = FootfallMethod;

ElevationMap surfaceMap(const MapGrid& g, const std::function<double(double, double)>& f, double sigma = 0) {
  ElevationMap m(g);
  for (int r = 0; r < g.rows; ++r)
    for (int c = 0; c < g.cols; ++c) {
      const Eigen::Vector2d p = g.center(r, c);
      m.setKnown(r, c, float(f(p.x(), p.y())), float(sigma));
    }
  return m;
}

CellRegion wholeMap(const MapGrid& g) { return {0, 0, g.rows, g.cols}; }

const FootfallScores& of(const std::vector<FootfallScores>& all, M m) {
  for (const auto& s : all)
    if (s.method == m) return s;
  throw std::logic_error("method not evaluated");
}

// The disk by its definition: cells whose centres are within D/2 of the candidate's centre (m).
struct DiskCell {
  int r, c;
  double u, v;  // offset from the candidate's centre, m
};
std::vector<DiskCell> diskOf(const MapGrid& g, int r, int c, double diameter) {
  const Eigen::Vector2d p = g.center(r, c);
  const int reach = int(diameter / g.cell) + 1;
  std::vector<DiskCell> d;
  for (int i = r - reach; i <= r + reach; ++i)
    for (int j = c - reach; j <= c + reach; ++j) {
      const Eigen::Vector2d q = g.center(i, j) - p;
      if (q.squaredNorm() <= 0.25 * diameter * diameter) d.push_back({i, j, q.x(), q.y()});
    }
  return d;
}

// Every §5 criterion computed straight from its definition on a fully known disk, in double from
// the map's stored floats: z_max − z_min; general least squares (QR) for the plane; the k-th
// highest for d_opt; V = cell²·Σ(z_max − z_i); m = cell²·Σ(u_i, v_i)(z_max − z_i).
struct Reference {
  double max_min, rms, tilt_deg, d_opt, V, E, spread_z;
};
Reference reference(const ElevationMap& map, int r, int c, const FootfallConfig& cfg = {}) {
  const MapGrid& g = map.grid();
  const auto disk = diskOf(g, r, c, cfg.foot_diameter_m);
  const int n = int(disk.size());
  Eigen::MatrixXd A(n, 3);
  Eigen::VectorXd z(n);
  for (int i = 0; i < n; ++i) {
    A.row(i) << 1, disk[i].u, disk[i].v;
    z(i) = map.elevation()(disk[i].r, disk[i].c);
  }
  Reference ref{};
  const double zmax = z.maxCoeff();
  ref.max_min = zmax - z.minCoeff();
  const Eigen::Vector3d p = A.colPivHouseholderQr().solve(z);
  ref.rms = std::sqrt((A * p - z).squaredNorm() / n);
  ref.tilt_deg = std::atan(std::hypot(p(1), p(2))) * 180 / M_PI;
  std::vector<double> sorted(z.data(), z.data() + n);
  std::sort(sorted.begin(), sorted.end(), std::greater<double>());
  const int k = int(std::ceil(cfg.min_support_fraction * n - 1e-9));
  ref.d_opt = zmax - sorted[k - 1];
  const double cell2 = g.cell * g.cell;
  double V = 0, mx = 0, my = 0;
  for (int i = 0; i < n; ++i) {
    V += zmax - z(i);
    mx += disk[i].u * (zmax - z(i));
    my += disk[i].v * (zmax - z(i));
  }
  ref.V = cell2 * V;
  ref.E = cell2 * std::hypot(mx, my);
  ref.spread_z = z.cwiseAbs().maxCoeff();
  return ref;
}

double equilibriumOf(const Reference& ref, const FootfallConfig& cfg = {}) {
  return ref.V + cfg.moment_weight * ref.E / (0.5 * cfg.foot_diameter_m);
}

// Bit-for-bit equality of two float rasters (NaNs included).
bool sameBits(const Raster<float>& a, const Raster<float>& b) {
  return a.rows() == b.rows() && a.cols() == b.cols() &&
         std::memcmp(a.data(), b.data(), sizeof(float) * size_t(a.size())) == 0;
}

TEST(Footfall, MethodNamesRoundTrip) {
  for (M m : kAllFootfallMethods) EXPECT_EQ(footfallMethodFromName(footfallMethodName(m)), m);
  EXPECT_EQ(footfallMethodName(M::EquilibriumUncertain), "equilibrium_uncertain");
  EXPECT_EQ(footfallMethodName(M::EquilibriumSoil), "equilibrium_soil");
  EXPECT_THROW(footfallMethodFromName("flat_enough"), std::invalid_argument);
}

TEST(Footfall, RegionOfABoxIsTheCellsWhoseCentresLieInIt) {
  const MapGrid g = MapGrid::covering(-1, 1, -1, 1, 0.1);
  const CellRegion reg = regionOfBox(g, -0.2, 0.31, 0.0, 0.5);
  // x centres −0.15 … 0.25 (cols 8..12), y centres 0.45 … 0.05 (rows 5..9).
  EXPECT_EQ(reg.col0, 8);
  EXPECT_EQ(reg.cols, 5);
  EXPECT_EQ(reg.row0, 5);
  EXPECT_EQ(reg.rows, 5);
  EXPECT_EQ(regionOfBox(g, 0.31, 0.34, 0, 1).cols, 0);  // no centre in [0.31, 0.34]
}

// z = a·x + b·y + c: on the discrete disk (offsets u, v; t = a·u + b·v, Σt = 0):
// max-min = max t − min t; planar fit residual 0 with its normal at atan(√(a² + b²)) from
// vertical; d_opt = t_(1) − t_(k); V = cell²·N·max t; m = −cell²·(a·Σu², b·Σv²), so
// E = cell²·Σu²·√(a² + b²); uncertain with uniform σ: V + cell²·N·2kσ, E unchanged.
TEST(Footfall, TiltedPlaneScoresAreTheirClosedForms) {
  const double a = 0.12, b = -0.07, c0 = 0.4, sigma = 0.01;
  for (double cell : {0.1, 0.02}) {
    const MapGrid g = MapGrid::covering(-1, 1, -1, 1, cell);
    const ElevationMap map = surfaceMap(g, [&](double x, double y) { return a * x + b * y + c0; }, sigma);
    const FootfallConfig cfg;
    const auto all = evaluateFootfalls(map, wholeMap(g), cfg);
    const auto disk = diskOf(g, 0, 0, cfg.foot_diameter_m);  // offsets are the same everywhere
    const int n = int(disk.size());
    std::vector<double> t;
    double su2 = 0, sum_abs_u = 0;
    for (const auto& d : disk) t.push_back(a * d.u + b * d.v), su2 += d.u * d.u, sum_abs_u += std::abs(d.u);
    std::sort(t.begin(), t.end(), std::greater<double>());
    const int k = int(std::ceil(0.5 * n));
    const double cell2 = cell * cell, R = 0.15;
    const double max_min = t.front() - t.back(), d_opt = t.front() - t[k - 1];
    const double V = cell2 * n * t.front(), E = cell2 * su2 * std::hypot(a, b);
    const double tilt = std::atan(std::hypot(a, b)) * 180 / M_PI;
    // The stored floats are off the plane by ≤ ε_z; each score is a sum of ≤ 2N such errors
    // (times its weights), plus its own rounding to float.
    const double ez = 0.7 * kEps / 2;  // |z| ≤ 0.4 + 0.19·1 < 0.7
    int checked = 0;
    for (int r = 0; r < g.rows; ++r)
      for (int c = 0; c < g.cols; ++c) {
        if (std::isnan(of(all, M::MaxMin).score(r, c))) continue;
        ++checked;
        EXPECT_NEAR(of(all, M::MaxMin).score(r, c), max_min, 2 * ez + kEps * max_min);
        EXPECT_NEAR(of(all, M::PlanarFit).score(r, c), 0, 2 * ez);
        // δslope ≤ ε_z·Σ|u|/Σu² per axis.
        EXPECT_NEAR(of(all, M::PlanarFit).tilt_deg(r, c), tilt, 2 * ez * sum_abs_u / su2 * 180 / M_PI + kEps * tilt);
        EXPECT_NEAR(of(all, M::SupportArea).score(r, c), d_opt, 2 * ez + kEps * d_opt);
        EXPECT_NEAR(of(all, M::FreeVolume).score(r, c), V, cell2 * 2 * n * ez + kEps * V);
        // δE ≤ cell²·Σ|u|·2ε_z (z_max's error meets Σu = 0).
        const double eq = V + E / R, e_eq = cell2 * 2 * ez * (n + sum_abs_u / R) + kEps * eq;
        EXPECT_NEAR(of(all, M::Equilibrium).score(r, c), eq, e_eq);
        // z ± 2σ: the top rises by 2σ and every lower bound falls by 2σ.
        const double equ = eq + cell2 * n * 2 * cfg.sigma_k * sigma;
        EXPECT_NEAR(of(all, M::EquilibriumUncertain).score(r, c), equ, e_eq + kEps * equ);
      }
    // Candidates: every cell whose disk lies on the map (reach 1 cell at 10 cm, 7 at 2 cm).
    const int reach = cell > 0.05 ? 1 : 7;
    EXPECT_EQ(checked, (g.rows - 2 * reach) * (g.cols - 2 * reach)) << "cell " << cell;
    EXPECT_EQ(n, cell > 0.05 ? 9 : 177);
  }
}

// Off the plane, each score is its definition evaluated directly (reference() above).
void expectDefinitions(const ElevationMap& map, int stride) {
  const FootfallConfig cfg;
  const auto all = evaluateFootfalls(map, wholeMap(map.grid()), cfg);
  int checked = 0;
  for (int r = 0; r < map.grid().rows; r += stride)
    for (int c = 0; c < map.grid().cols; c += stride) {
      if (std::isnan(of(all, M::MaxMin).score(r, c))) continue;
      ++checked;
      const Reference ref = reference(map, r, c, cfg);
      // Both sides are double sums of the same floats (a few ulps of double apart); the
      // scores are then rounded to float. The residual's cancellation: √(ε_double·Σz²/N).
      const double tiny = 1e-12 * (1 + ref.spread_z);
      EXPECT_NEAR(of(all, M::MaxMin).score(r, c), ref.max_min, kEps * ref.max_min + tiny);
      EXPECT_NEAR(of(all, M::PlanarFit).tilt_deg(r, c), ref.tilt_deg, kEps * ref.tilt_deg + 1e-9);
      if (ref.tilt_deg <= cfg.max_normal_deviation_deg)
        EXPECT_NEAR(of(all, M::PlanarFit).score(r, c), ref.rms, kEps * ref.rms + 1e-7 * ref.spread_z);
      else
        EXPECT_TRUE(std::isnan(of(all, M::PlanarFit).score(r, c)));
      EXPECT_NEAR(of(all, M::SupportArea).score(r, c), ref.d_opt, kEps * ref.d_opt + tiny);
      EXPECT_NEAR(of(all, M::FreeVolume).score(r, c), ref.V, kEps * ref.V + tiny);
      const double eq = equilibriumOf(ref, cfg);
      EXPECT_NEAR(of(all, M::Equilibrium).score(r, c), eq, kEps * eq + tiny);
      EXPECT_NEAR(of(all, M::EquilibriumUncertain).score(r, c), eq, kEps * eq + tiny);  // σ = 0
    }
  EXPECT_GT(checked, 50);
}

TEST(Footfall, SinusoidScoresAreTheirDefinitions) {
  for (double cell : {0.1, 0.02}) {
    const MapGrid g = MapGrid::covering(0, 2, 0, 1.5, cell);
    expectDefinitions(surfaceMap(g, [](double x, double y) {
                        return 0.3 + 0.05 * std::sin(2 * M_PI * x / 0.37) * std::cos(2 * M_PI * y / 0.53) + 0.1 * x;
                      }),
                      cell > 0.05 ? 1 : 3);
  }
}

// A step of h at x = 1.03: a disk straddling it has max-min h, d_opt 0 or h (whether the upper
// side holds k cells), V = cell²·h·N_low and E = cell²·h·|Σ_low u|; the rest all 0.
TEST(Footfall, StepScoresAreTheirClosedForms) {
  const double h = 0.2, xs = 1.036;  // between cell centres at 10 and 2 cm
  for (double cell : {0.1, 0.02}) {
    const MapGrid g = MapGrid::covering(0, 2, 0, 1, cell);
    const ElevationMap map = surfaceMap(g, [&](double x, double) { return x > xs ? h : 0.0; });
    expectDefinitions(map, cell > 0.05 ? 1 : 2);
    const auto all = evaluateFootfalls(map, wholeMap(g));
    const int n = cell > 0.05 ? 9 : 177, k = (n + 1) / 2;
    const int r = g.rows / 2;
    for (int c = 0; c < g.cols; ++c) {
      if (std::isnan(of(all, M::MaxMin).score(r, c))) continue;
      int low = 0;
      double su_low = 0;
      for (const auto& d : diskOf(g, r, c, 0.3))
        if (g.center(d.r, d.c).x() <= xs) ++low, su_low += d.u;
      const bool straddles = low > 0 && low < n;
      const double cell2 = cell * cell;
      EXPECT_FLOAT_EQ(of(all, M::MaxMin).score(r, c), straddles ? h : 0) << c;
      EXPECT_FLOAT_EQ(of(all, M::SupportArea).score(r, c), straddles && n - low < k ? h : 0) << c;
      // h = 0.2 is stored as 0.2f (relative 2^-24) and the score is rounded once more: 2·kEps.
      EXPECT_NEAR(of(all, M::FreeVolume).score(r, c), straddles ? cell2 * h * low : 0, 2 * kEps * cell2 * h * n) << c;
      EXPECT_NEAR(of(all, M::Equilibrium).score(r, c), straddles ? cell2 * h * (low + std::abs(su_low) / 0.15) : 0,
                  2 * kEps * cell2 * h * n * 2)
          << c;
    }
  }
}

// §5, max-min and planar fit: "There are cases where this method prefers a flat surface
// punctuated by a single spike rather than an undulating surface." Left: flat with 3 cm spikes on
// a 20 cm lattice (every 30 cm disk holds one to four); right: a 2 cm-amplitude undulation of
// 16 cm wavelength. Max-min sees 3 cm < 4 cm and planar fit a residual of ~s/√N < a/√2: both
// choose the spike. Support area (d_opt = s on a spike, ≤ a on the undulation), free volume
// (≈ N·s vs ≈ N·a) and equilibrium choose the undulation.
TEST(Footfall, ASpikeFoolsMaxMinAndPlanarFitButNotTheLaterMethods) {
  const double s = 0.03, a = 0.02, cell = 0.02;
  const MapGrid g = MapGrid::covering(0, 2, 0, 1, cell);
  ElevationMap map(g);
  for (int r = 0; r < g.rows; ++r)
    for (int c = 0; c < g.cols; ++c) {
      double z = 0;
      if (c < g.cols / 2)
        z = (r % 10 == 5 && c % 10 == 5) ? s : 0;
      else
        z = a * std::cos(2 * M_PI * c / 8);  // crests on cell centres: the spread is 2a
      map.setKnown(r, c, float(z), 0);
    }
  const auto all = evaluateFootfalls(map, wholeMap(g));
  // Whether the chosen disk holds a spike (a cell at s; the undulation never reaches s).
  auto choosesSpike = [&](M m) {
    const auto& b = of(all, m).best;
    EXPECT_TRUE(b.has_value()) << footfallMethodName(m);
    if (!b) return false;
    bool spike = false;
    for (const auto& d : diskOf(g, (*b)(0), (*b)(1), 0.3)) spike |= map.elevation()(d.r, d.c) == float(s);
    return spike;
  };
  EXPECT_TRUE(choosesSpike(M::MaxMin));
  EXPECT_FLOAT_EQ(float(of(all, M::MaxMin).best_score), float(s));
  EXPECT_TRUE(choosesSpike(M::PlanarFit));
  for (M m : {M::SupportArea, M::FreeVolume, M::Equilibrium, M::EquilibriumUncertain}) {
    EXPECT_FALSE(choosesSpike(m)) << footfallMethodName(m);
    EXPECT_GE((*of(all, m).best)(1), g.cols / 2) << footfallMethodName(m);  // centred on the undulation
  }
  // d_opt on the spiky side is the spike itself: the flat is the support.
  EXPECT_FLOAT_EQ(of(all, M::SupportArea).score(25, 25), float(s));
}

// §5, support area: "two sinusoidal surfaces with the same frequency but different amplitudes"
// it cannot tell apart, free volume can. Every §5 score is linear in the amplitude (z = a·f ⇒
// d_opt, V, E ∝ a), so a tie needs d_opt = 0: the crest cells alone make A_min. Columns
// alternating ±a (a sinusoid of period 2 cells, 10 cm): a disk centred on a trough has 6 of its 9
// cells on crests (≥ k = 5), d_opt = 0 for a1 and for a2 = 2·a1, while V = cell²·3·2a tells them
// apart. Where the crests are narrow (16 cm wavelength at 2 cm), d_opt ∝ a does tell them apart.
TEST(Footfall, EqualFrequencySinusoidsTieForSupportAreaNotForFreeVolume) {
  const double a1 = 0.02, a2 = 0.04, cell = 0.1;
  const MapGrid g = MapGrid::covering(0, 4, 0, 2, cell);
  ElevationMap map(g);
  for (int r = 0; r < g.rows; ++r)
    for (int c = 0; c < g.cols; ++c) map.setKnown(r, c, float((c < 20 ? a1 : a2) * (c % 2 ? -1 : 1)), 0);
  const auto all = evaluateFootfalls(map, wholeMap(g));
  auto bestIn = [&](const Raster<float>& s, int c0, int c1) {
    float b = INFINITY;
    for (int r = 0; r < g.rows; ++r)
      for (int c = c0; c < c1; ++c)
        if (!std::isnan(s(r, c))) b = std::min(b, s(r, c));
    return b;
  };
  const auto& sa = of(all, M::SupportArea).score;
  EXPECT_EQ(bestIn(sa, 0, 18), 0.0f);  // both patches' best d_opt: 0, a tie
  EXPECT_EQ(bestIn(sa, 22, 40), 0.0f);
  const auto& fv = of(all, M::FreeVolume);
  ASSERT_TRUE(fv.best);
  EXPECT_LT((*fv.best)(1), 19);  // the smaller amplitude
  EXPECT_NEAR(fv.best_score, cell * cell * 6 * a1, 2 * kEps * cell * cell * 6 * a1);
  EXPECT_NEAR(bestIn(fv.score, 22, 40), cell * cell * 6 * a2, 2 * kEps * cell * cell * 6 * a2);

  // Narrow crests: d_opt scales with the amplitude.
  const MapGrid f = MapGrid::covering(0, 1, 0, 1, 0.02);
  auto wave = [&](double amp) {
    ElevationMap m(f);
    for (int r = 0; r < f.rows; ++r)
      for (int c = 0; c < f.cols; ++c) m.setKnown(r, c, float(amp * std::cos(2 * M_PI * c / 8)), 0);
    return of(evaluateFootfalls(m, wholeMap(f), {}, {M::SupportArea}), M::SupportArea).best_score;
  };
  const double d1 = wave(a1), d2 = wave(a2);
  EXPECT_GT(d1, 0);
  EXPECT_NEAR(d2 / d1, a2 / a1, 4 * kEps);
}

// §5, equilibrium: holes off-centre. Flat ground with 5 cm holes along every third column: every
// 3 × 3 disk (10 cm cells) holds one hole column, so V = cell²·3h everywhere and free volume ties
// (the first candidate in row-major order wins); equilibrium prefers the disks centred on a hole
// column (E = 0) to those with it at the side (E = cell³·3h).
TEST(Footfall, OffCentreHolesTieForFreeVolumeButNotForEquilibrium) {
  const double h = 0.05, cell = 0.1;
  const MapGrid g = MapGrid::covering(0, 3, 0, 2, cell);
  ElevationMap map(g);
  for (int r = 0; r < g.rows; ++r)
    for (int c = 0; c < g.cols; ++c) map.setKnown(r, c, float(c % 3 == 2 ? -h : 0.0), 0);
  const auto all = evaluateFootfalls(map, wholeMap(g));
  const double V = cell * cell * 3 * h, E = cell * cell * cell * 3 * h;
  for (int r = 1; r < g.rows - 1; ++r)
    for (int c = 1; c < g.cols - 1; ++c) {
      // h is stored as a float (relative 2^-24), the score rounded once more.
      EXPECT_NEAR(of(all, M::FreeVolume).score(r, c), V, 2 * kEps * V);
      EXPECT_NEAR(of(all, M::Equilibrium).score(r, c), c % 3 == 2 ? V : V + E / 0.15, 4 * kEps * V);
    }
  EXPECT_EQ(*of(all, M::FreeVolume).best, Eigen::Vector2i(1, 1));  // a tie: the first candidate
  EXPECT_EQ(*of(all, M::Equilibrium).best, Eigen::Vector2i(1, 2));
}

TEST(Footfall, PlanarFitRejectsNormalsTooFarFromTheLeg) {
  const MapGrid g = MapGrid::covering(0, 1, 0, 1, 0.05);
  for (double deg : {10.0, 20.0}) {
    const double slope = std::tan(deg * M_PI / 180);
    const auto all = evaluateFootfalls(surfaceMap(g, [&](double x, double) { return slope * x; }), wholeMap(g), {},
                                       {M::PlanarFit, M::MaxMin});
    const auto& pf = of(all, M::PlanarFit);
    EXPECT_NEAR(pf.tilt_deg(10, 10), deg, 1e-4);  // |z| ≤ 0.37: float z moves the slope ≲ 1e-7
    EXPECT_EQ(pf.best.has_value(), deg < 15) << deg;
    EXPECT_EQ(std::isnan(pf.score(10, 10)), deg > 15) << deg;
    EXPECT_TRUE(of(all, M::MaxMin).best.has_value());  // only planar fit has the constraint
  }
}

// The unknown-cell rule. Default: a disk with any non-Known cell is no candidate for the five §5
// methods. With max_unknown_fraction = 0.2 (one cell of 9), a disk with one unknown cell is
// filled with the plane of its Known cells, which on a plane gives the plane's own scores; a disk
// with two is still refused. equilibrium_uncertain: Unseen or a ceiling-less Shadow refuses the
// disk; a Shadow with a ceiling is taken at the ceiling.
TEST(Footfall, UnknownCellsFollowTheStatedRule) {
  const MapGrid g = MapGrid::covering(0, 2, 0, 2, 0.1);
  auto plane = [](double x, double y) { return 0.1 * x + 0.05 * y; };
  const ElevationMap full = surfaceMap(g, plane);
  const double ez = 0.3 * kEps / 2;  // |z| ≤ 0.3: a float's rounding
  const auto ref = evaluateFootfalls(full, wholeMap(g));
  ElevationMap map = full;
  map.setShadow(5, 5, float(plane(g.center(5, 5).x(), g.center(5, 5).y())));  // ceiling at the plane
  map.setUnknown(10, 10, CellState::Unseen);
  map.setUnknown(10, 11, CellState::Unseen);
  map.setUnknown(15, 15, CellState::Shadow);  // no ceiling
  auto near = [](int r, int c, int r0, int c0) { return std::abs(r - r0) <= 1 && std::abs(c - c0) <= 1; };
  for (double frac : {0.0, 0.2}) {
    FootfallConfig cfg;
    cfg.max_unknown_fraction = frac;
    const auto all = evaluateFootfalls(map, wholeMap(g), cfg);
    for (int r = 1; r < g.rows - 1; ++r)
      for (int c = 1; c < g.cols - 1; ++c) {
        const int unknown = near(r, c, 5, 5) + near(r, c, 10, 10) + near(r, c, 10, 11) + near(r, c, 15, 15);
        for (M m : {M::MaxMin, M::PlanarFit, M::SupportArea, M::FreeVolume, M::Equilibrium}) {
          const float v = of(all, m).score(r, c), want = of(ref, m).score(r, c);
          if (unknown > (frac > 0 ? 1 : 0))
            EXPECT_TRUE(std::isnan(v)) << footfallMethodName(m) << " " << r << "," << c;
          else  // filled from the plane of 8 Known cells (each within ε_z of the plane, a fill
                // within 3ε_z), the plane's scores: heights ± 2·(3 + 1)ε_z, V and E far less.
            EXPECT_NEAR(v, want, 8 * ez + kEps * std::abs(want)) << footfallMethodName(m) << " " << r << "," << c;
        }
        const bool refused = near(r, c, 10, 10) || near(r, c, 10, 11) || near(r, c, 15, 15);
        const float u = of(all, M::EquilibriumUncertain).score(r, c);
        if (refused)
          EXPECT_TRUE(std::isnan(u)) << r << "," << c;
        else  // the ceiling is the plane: the same as the full map (σ = 0)
          EXPECT_FLOAT_EQ(u, of(ref, M::EquilibriumUncertain).score(r, c)) << r << "," << c;
      }
  }
}

// Terrain of 1 cm columns alternating ±1 cm (σ 5 mm) with a 3-column clearing at columns 8–10:
// flat in the map, but either (shadow) its middle column is a range shadow under a 0.3 m ceiling
// hiding a 0.25 m rock, or (sigma) the whole clearing has σ = 0.1 m over ±15 cm of rough truth.
// Equilibrium (interpolating the shadow with the plane of the disk's Known cells) sees a perfect
// flat and steps there; equilibrium_uncertain sees the ceiling / the ±2σ band and steps on the
// known terrain, which the truth scores far better.
TEST(Footfall, EquilibriumUncertainAvoidsHighShadowsAndLargeSigmaThatFoolEquilibrium) {
  const double cell = 0.1;
  const MapGrid g = MapGrid::covering(0, 3, 0, 1.5, cell);
  auto base = [](int c, double amp) { return amp * (c % 2 ? -1 : 1); };
  for (bool shadow : {true, false}) {
    ElevationMap map(g), truth(g);
    for (int r = 0; r < g.rows; ++r)
      for (int c = 0; c < g.cols; ++c) {
        const bool clearing = c >= 8 && c <= 10;
        map.setKnown(r, c, float(clearing ? 0.0 : base(c, 0.01)), clearing && !shadow ? 0.1f : 0.005f);
        double t = clearing ? 0.0 : base(c, 0.01);
        if (shadow && c == 9) {
          map.setShadow(r, c, 0.3f);
          t = 0.25;
        }
        if (!shadow && clearing) t = base(c, 0.15);
        truth.setKnown(r, c, float(t), 0);
      }
    FootfallConfig cfg;
    cfg.max_unknown_fraction = 0.35;  // a third of a 3 × 3 disk may be interpolated
    const auto all = evaluateFootfalls(map, wholeMap(g), cfg);
    const auto on_truth = evaluateFootfalls(truth, wholeMap(g), cfg, {M::Equilibrium});
    const auto& eq = of(all, M::Equilibrium);
    const auto& equ = of(all, M::EquilibriumUncertain);
    ASSERT_TRUE(eq.best && equ.best);
    SCOPED_TRACE(shadow ? "shadow" : "sigma");
    EXPECT_EQ((*eq.best)(1), 9);  // fooled: the clearing's centre
    EXPECT_EQ(eq.best_score, 0.0);
    EXPECT_TRUE((*equ.best)(1) < 7 || (*equ.best)(1) > 11);  // wholly off the clearing
    const auto& t = of(on_truth, M::Equilibrium).score;
    EXPECT_LT(t((*equ.best)(0), (*equ.best)(1)), 0.2 * t((*eq.best)(0), (*eq.best)(1)));
    // The uncertain score at the clearing's centre, by hand: shadow: top 0.3, six Known lower
    // bounds at −0.01, three at 0.3 → V = cell²·(9·0.3 − (−0.06 + 0.9)); sigma: top 0.2, lower
    // bounds −0.2 → V = cell²·9·0.4. E = 0 (symmetric).
    const double want = cell * cell * (shadow ? 9 * 0.3 - (-0.06 + 0.9) : 9 * 0.4);
    EXPECT_NEAR(equ.score(5, 9), want, 1e-6 * want);
  }
}

// The soil-aware equilibrium (docs/footfall.md, "Soil"), against its definition and closed forms.
// Its disk is the cells within one cell beyond the foot's rim (diameter D + 2·cell).
// - Rigid ground (sinkage 0): the equilibrium's V + w·E/R over that disk, from the definition
//   (`reference` on the wider disk; R stays the foot's radius), on a rough surface.
// - A tilted plane: its grey opening is the plane itself, so no cell is rigid, every cell sinks
//   alike, and V and E (differences from the disk's top) are those of rigid ground.
// - A flat plane with a box rock of height h narrower than the opening's element: the rock's cells
//   stand h above the ground, so they are rigid and the rest sinks by s. Relative to the ground's
//   cells every rock cell then stands h + s, not h: V = cell²·(N − n_r)·(h + s) and, since Σx = 0
//   over the disk, E = cell³·(h + s)·|Σ_rock (x, y)|: the rigid score times (h + s)/h.
TEST(Footfall, EquilibriumSoilIsEquilibriumOnTheSurfaceTheSoilLeaves) {
  const double cell = 0.05;
  FootfallConfig wide;  // the reference's disk; cells on its circle count (a centre 4 cells away)
  wide.foot_diameter_m = FootfallConfig{}.foot_diameter_m + 2 * cell + 1e-9;
  const double R = 0.5 * FootfallConfig{}.foot_diameter_m;
  const int reach = int(std::floor(0.5 * wide.foot_diameter_m / cell + 1e-9));
  const MapGrid g = MapGrid::covering(0, 2, 0, 2, cell);
  const auto interior = [&](int r, int c) {
    return r >= reach && c >= reach && r < g.rows - reach && c < g.cols - reach;
  };
  for (double sinkage : {0.0, 0.05}) {
    for (bool tilted : {false, true}) {
      if (sinkage > 0 && !tilted) continue;  // rough ground has cells that stand out: not a plane
      const ElevationMap m = surfaceMap(g, [&](double x, double y) {
        return tilted ? 0.12 * x - 0.07 * y + 0.4 : 0.1 * std::sin(7 * x) * std::cos(5 * y) + 0.03 * std::sin(31 * x + 17 * y);
      });
      FootfallConfig cfg;
      cfg.sinkage_m = sinkage;
      const auto soil = evaluateFootfalls(m, wholeMap(g), cfg, {M::EquilibriumSoil});
      int compared = 0;
      for (int r = 0; r < g.rows; ++r)
        for (int c = 0; c < g.cols; ++c) {
          if (!interior(r, c) || std::isnan(soil[0].score(r, c))) continue;
          const Reference ref = reference(m, r, c, wide);
          const double want = ref.V + ref.E / R;
          ++compared;
          // One rounding to float at the end, of sums of 37 heights of order 0.5 m.
          ASSERT_NEAR(soil[0].score(r, c), want, 1e-6 * want + 1e-9) << r << ", " << c << " sinkage " << sinkage;
        }
      EXPECT_GT(compared, 1000);
    }
  }
  // A flat plane with a box rock (2 × 2 cells) of height h: the score with sinkage s is the score
  // on rigid ground times (h + s)/h wherever the disk holds some of the rock, 0 elsewhere.
  const double h = 0.04, s = 0.05;
  const MapGrid g2 = MapGrid::covering(0, 1.5, 0, 1.5, cell);
  ElevationMap rock(g2);
  for (int r = 0; r < g2.rows; ++r)
    for (int c = 0; c < g2.cols; ++c) rock.setKnown(r, c, (r == 14 || r == 15) && (c == 14 || c == 15) ? float(h) : 0.0f, 0);
  FootfallConfig rigid_cfg, sand_cfg;
  sand_cfg.sinkage_m = s;
  const auto on_rock = evaluateFootfalls(rock, wholeMap(g2), rigid_cfg, {M::EquilibriumSoil});
  const auto on_sand = evaluateFootfalls(rock, wholeMap(g2), sand_cfg, {M::EquilibriumSoil});
  int with_rock = 0;
  for (int r = reach; r < g2.rows - reach; ++r)
    for (int c = reach; c < g2.cols - reach; ++c) {
      const double rigid = on_rock[0].score(r, c), sand = on_sand[0].score(r, c);
      if (std::isnan(rigid)) continue;
      if (rigid == 0) {
        EXPECT_NEAR(sand, 0.0, 1e-12) << r << ", " << c;  // no rock in the disk: it sinks level
        continue;
      }
      ++with_rock;
      EXPECT_NEAR(sand, rigid * (h + s) / h, 1e-6 * sand) << r << ", " << c;
    }
  EXPECT_GT(with_rock, 20);
  // An unknown cell just beyond the rim (4 cells from the centre: outside §5's disk, inside the
  // ring) rejects the disk for the soil's method, not for equilibrium: a rock the map has not seen
  // may stand there.
  ElevationMap holed = rock;
  holed.setUnknown(20, 24, CellState::Unseen);
  const auto h2 = evaluateFootfalls(holed, wholeMap(g2), sand_cfg, {M::Equilibrium, M::EquilibriumSoil});
  EXPECT_TRUE(std::isfinite(h2[0].score(20, 20)));
  EXPECT_TRUE(std::isnan(h2[1].score(20, 20)));
  EXPECT_TRUE(std::isfinite(h2[1].score(20, 19)));  // 5 cells away: beyond the ring
}

// Same bits on one thread and on two: each candidate is computed alone, in a fixed order.
TEST(Footfall, ScoresAreTheSameOnAnyNumberOfThreads) {
  const MapGrid g = MapGrid::covering(0, 3, 0, 3, 0.02);
  ElevationMap map(g);
  for (int r = 0; r < g.rows; ++r)
    for (int c = 0; c < g.cols; ++c) {
      const unsigned hsh = (unsigned(r) * 73856093u) ^ (unsigned(c) * 19349663u);
      const double noise = double(hsh % 1000) / 1000 - 0.5;
      const double z = 0.1 * std::sin(r * 0.13) * std::cos(c * 0.07) + 0.01 * noise;
      if (hsh % 97 == 0)
        map.setShadow(r, c, float(z + 0.05));
      else if (hsh % 211 == 0)
        map.setUnknown(r, c, CellState::Unseen);
      else
        map.setKnown(r, c, float(z), float(0.002 + 0.001 * (hsh % 7)));
    }
  FootfallConfig cfg;
  cfg.max_unknown_fraction = 0.05;
  cfg.sinkage_m = 0.05;
  cfg.rigid_height_m = 0.01;  // some cells rigid, some not
  auto run = [&](int threads) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(threads));
    return evaluateFootfalls(map, wholeMap(g), cfg, {kAllFootfallMethods.begin(), kAllFootfallMethods.end()});
  };
  const auto one = run(1), two = run(2);
  for (size_t i = 0; i < one.size(); ++i) {
    EXPECT_TRUE(sameBits(one[i].score, two[i].score)) << footfallMethodName(one[i].method);
    EXPECT_EQ(one[i].best, two[i].best);
  }
  EXPECT_TRUE(sameBits(of(one, M::PlanarFit).tilt_deg, of(two, M::PlanarFit).tilt_deg));
}

template <class F>
void expectInvalid(F f, const std::string& words) {
  try {
    f();
    ADD_FAILURE() << "no exception; expected one saying '" << words << "'";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
  }
}

TEST(Footfall, BadInputThrowsWithAClearMessage) {
  const MapGrid g = MapGrid::covering(0, 2, 0, 2, 0.1);
  const ElevationMap map = surfaceMap(g, [](double, double) { return 0.0; });
  expectInvalid([&] { evaluateFootfalls(map, {5, 5, 2, 10}); }, "larger than the region");  // 0.2 m < 0.3 m
  expectInvalid([&] { evaluateFootfalls(map, {-5, 5, 7, 10}); }, "larger than the region");  // clipped: 0.2 m
  expectInvalid([&] { evaluateFootfalls(map, {30, 30, 5, 5}); }, "no cell on the");
  expectInvalid([&] { evaluateFootfalls(map, regionOfBox(g, 5, 6, 5, 6)); }, "no cell on the");
  FootfallConfig cfg;
  cfg.foot_diameter_m = 0.15;  // one cell of 10 cm
  expectInvalid([&] { evaluateFootfalls(map, wholeMap(g), cfg); }, "a plane needs 3");
  cfg = {};
  cfg.min_support_fraction = 0;
  expectInvalid([&] { evaluateFootfalls(map, wholeMap(g), cfg); }, "min_support_fraction");
  cfg = {};
  cfg.foot_diameter_m = -1;
  expectInvalid([&] { evaluateFootfalls(map, wholeMap(g), cfg); }, "foot_diameter_m");
  cfg = {};
  cfg.max_unknown_fraction = 1;
  expectInvalid([&] { evaluateFootfalls(map, wholeMap(g), cfg); }, "max_unknown_fraction");
  cfg = {};
  cfg.sinkage_m = -0.01;
  expectInvalid([&] { evaluateFootfalls(map, wholeMap(g), cfg); }, "sinkage_m");
  cfg = {};
  cfg.rigid_height_m = std::numeric_limits<double>::quiet_NaN();
  expectInvalid([&] { evaluateFootfalls(map, wholeMap(g), cfg); }, "rigid_height_m");
  cfg = {};
  cfg.rigid_width_m = 0;
  expectInvalid([&] { evaluateFootfalls(map, wholeMap(g), cfg); }, "rigid_width_m");
}

// Layers held elsewhere (ElevationLayers: the Python module's numpy arrays) give the bits the same
// values give in an ElevationMap, also when each layer is a block of a wider raster (a stride
// between rows that is not the row's length), and are read in place: a change made to the wider
// raster after the view was made changes the scores. A layer of the wrong size is refused.
TEST(Footfall, LayersHeldElsewhereGiveTheMapsBitsAndAreReadInPlace) {
  const MapGrid g = MapGrid::covering(0, 2, 0, 1.5, 0.05);
  ElevationMap map(g);
  for (int r = 0; r < g.rows; ++r)
    for (int c = 0; c < g.cols; ++c) {
      const unsigned hsh = (unsigned(r) * 73856093u) ^ (unsigned(c) * 19349663u);
      const double z = 0.1 * std::sin(r * 0.3) * std::cos(c * 0.2) + 0.002 * double(hsh % 10);
      if (hsh % 37 == 0)
        map.setShadow(r, c, float(z + 0.05));
      else
        map.setKnown(r, c, float(z), float(0.002 + 0.001 * (hsh % 5)));
    }
  // Each layer in the middle of a raster 3 rows and 5 columns larger (filled with junk).
  const auto embed = [&](const auto& layer, auto junk) {
    using R = std::decay_t<decltype(layer)>;
    R wide = R::Constant(layer.rows() + 3, layer.cols() + 5, junk);
    wide.block(2, 1, layer.rows(), layer.cols()) = layer;
    return wide;
  };
  Raster<float> z = embed(map.elevation(), 7.0f);
  const Raster<float> s = embed(map.sigma(), -1.0f), c = embed(map.shadowCeiling(), 9.0f);
  const Raster<std::uint8_t> st = embed(map.state(), std::uint8_t(CellState::Known));
  const auto inner = [&](const auto& wide) {
    using T = typename std::decay_t<decltype(wide)>::Scalar;
    return RasterView<T>(&wide(2, 1), g.rows, g.cols, Eigen::OuterStride<>(wide.cols()));
  };
  const ElevationLayers layers(g, inner(z), inner(s), inner(c), inner(st));
  ASSERT_EQ(layers.elevation.data(), &z(2, 1));
  FootfallConfig cfg;
  cfg.max_unknown_fraction = 0.1;
  const CellRegion region = regionOfBox(g, 0.3, 1.7, 0.3, 1.2);
  const auto want = evaluateFootfalls(map, region, cfg), got = evaluateFootfalls(layers, region, cfg);
  ASSERT_EQ(want.size(), got.size());
  for (size_t i = 0; i < want.size(); ++i) {
    ASSERT_TRUE(want[i].best) << footfallMethodName(want[i].method);
    EXPECT_TRUE(sameBits(want[i].score, got[i].score)) << footfallMethodName(want[i].method);
    EXPECT_EQ(want[i].best, got[i].best);
    EXPECT_EQ(std::memcmp(&want[i].best_score, &got[i].best_score, sizeof(double)), 0);
  }
  EXPECT_TRUE(sameBits(of(want, M::PlanarFit).tilt_deg, of(got, M::PlanarFit).tilt_deg));
  // A spike at max-min's best cell, made in the wide raster: the view sees it.
  const Eigen::Vector2i best = *of(want, M::MaxMin).best;
  z(2 + best(0), 1 + best(1)) += 1.0f;
  const auto after = evaluateFootfalls(layers, region, cfg, {M::MaxMin});
  EXPECT_GT(after[0].score(best(0), best(1)), of(want, M::MaxMin).score(best(0), best(1)) + 0.9f);
  // Wrong sizes.
  const RasterView<float> short_view(s.data(), g.rows - 1, g.cols, Eigen::OuterStride<>(s.cols()));
  const ElevationLayers short_sigma(g, inner(z), short_view, inner(c), inner(st));
  expectInvalid([&] { evaluateFootfalls(short_sigma, region, cfg); },
                "the sigma layer is " + std::to_string(g.rows - 1) + " x " + std::to_string(g.cols) + ", the grid " +
                    std::to_string(g.rows) + " x " + std::to_string(g.cols));
}

// Speed is `ambler bench footfall`'s (docs/benchmarks.md), not a test's.

}  // namespace
}  // namespace ambler::perception
