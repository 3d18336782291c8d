#include "perception/footfall.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cstdint>
#include <cstring>
#include <cmath>
#include <functional>
#include <sstream>
#include <stdexcept>
#include <string>

namespace ambler::perception {

namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

// The foot's disk as cell offsets from the candidate's cell: dcol right (+x), drow down (−y).
// Listed row by row, left to right, so a candidate's cells are read as contiguous row spans.
struct Disk {
  int reach = 0;                 // the largest |drow| (and |dcol|) of the disk
  std::vector<int> drow, dcol;   // one entry per cell
  std::vector<int> span_drow, span_w;  // per disk row: its drow and half-width (dcol = −w..w)
  std::vector<double> x, y;            // per cell: dcol and −drow (x right, y up), in cells
  long sum_dx2 = 0, sum_dy2 = 0;  // Σdcol², Σdrow² (Σdcol = Σdrow = Σdcol·drow = 0: symmetric)
  int size() const { return int(drow.size()); }
};

Disk makeDisk(double cell, double diameter) {
  const double radius = 0.5 * diameter / cell;  // in cells
  // A centre on the circle is in; the tolerance absorbs the rounding of diameter/cell
  // (0.15/0.05 = 2.9999999999999996).
  const double r2 = radius * radius * (1 + 1e-9);
  Disk d;
  d.reach = int(std::floor(radius * (1 + 1e-9)));
  for (int i = -d.reach; i <= d.reach; ++i) {
    int w = -1;
    for (int j = -d.reach; j <= d.reach; ++j)
      if (double(i) * i + double(j) * j <= r2) {
        d.drow.push_back(i);
        d.dcol.push_back(j);
        d.sum_dx2 += long(j) * j;
        d.sum_dy2 += long(i) * i;
        d.x.push_back(j);
        d.y.push_back(-i);
        w = std::max(w, j);
      }
    if (w >= 0) d.span_drow.push_back(i), d.span_w.push_back(w);
  }
  return d;
}

// What one candidate's evaluation produces (only the requested parts are filled).
struct Wanted {
  bool max_min = false, planar = false, support = false, free_volume = false, equilibrium = false,
       uncertain = false, soil = false;
  bool paper() const { return max_min || planar || support || free_volume || equilibrium; }
};

// Per-thread scratch: the disk's heights (paper methods), the uncertain bounds, a copy to select in.
struct Scratch {
  std::vector<double> z, upper, lower;
  std::vector<std::int32_t> keys;
  std::vector<char> known;
};

// Fills the disk's unknown cells with the least-squares plane of its Known cells (offsets in
// cells, heights relative to the first Known one). False if the Known cells are collinear.
bool fillWithPlane(const Disk& disk, std::vector<double>& z, const std::vector<char>& known) {
  long n = 0, sx = 0, sy = 0, sxx = 0, sxy = 0, syy = 0;
  double ref = 0, sz = 0, sxz = 0, syz = 0;
  bool have_ref = false;
  for (int i = 0; i < disk.size(); ++i) {
    if (!known[i]) continue;
    const long x = disk.dcol[i], y = -disk.drow[i];
    if (!have_ref) ref = z[i], have_ref = true;
    const double dz = z[i] - ref;
    ++n, sx += x, sy += y, sxx += x * x, sxy += x * y, syy += y * y;
    sz += dz, sxz += x * dz, syz += y * dz;
  }
  // n²·det(covariance of the offsets), an integer: 0 iff the Known cells are collinear.
  const long long cxx = n * sxx - sx * sx, cyy = n * syy - sy * sy, cxy = n * sxy - sx * sy;
  if (n < 3 || cxx * cyy - cxy * cxy <= 0) return false;
  Eigen::Matrix3d M;
  M << double(n), double(sx), double(sy), double(sx), double(sxx), double(sxy), double(sy), double(sxy),
      double(syy);
  const Eigen::Vector3d p = M.fullPivLu().solve(Eigen::Vector3d(sz, sxz, syz));
  for (int i = 0; i < disk.size(); ++i)
    if (!known[i]) z[i] = ref + p(0) + p(1) * disk.dcol[i] + p(2) * (-disk.drow[i]);
  return true;
}

// A float's bits as an int32 whose signed order is the float's order (negative floats' magnitude
// bits flipped), so a selection can count with integer compares.
inline std::int32_t orderKey(float f) {
  std::int32_t k;
  std::memcpy(&k, &f, sizeof k);
  return k < 0 ? k ^ 0x7fffffff : k;
}
inline float fromOrderKey(std::int32_t k) {
  if (k < 0) k ^= 0x7fffffff;
  float f;
  std::memcpy(&f, &k, sizeof f);
  return f;
}

// The k-th highest of `keys` (k ≥ 1): the largest t with #{key ≥ t} ≥ k, by bisection on t. Each
// step is a branch-free count (vectorised), ≤ 32 steps. Measured (2-core EPYC VM): 0.75 µs for
// 177 keys against 1.9 µs for std::nth_element, whose branches mispredict; for a handful of keys
// nth_element wins (0.10 against 0.23 µs at 9), so it is used below kSelectBisectFrom keys.
constexpr int kSelectBisectFrom = 32;
std::int32_t kthHighest(std::vector<std::int32_t>& keys, int k) {
  const int n = int(keys.size());
  if (n < kSelectBisectFrom) {
    std::nth_element(keys.begin(), keys.begin() + (k - 1), keys.end(), std::greater<std::int32_t>());
    return keys[k - 1];
  }
  std::int64_t lo = *std::min_element(keys.begin(), keys.end()), hi = *std::max_element(keys.begin(), keys.end());
  while (lo < hi) {
    const std::int64_t mid = lo + (hi - lo + 1) / 2;
    const std::int32_t t = std::int32_t(mid);
    int count = 0;
    for (int i = 0; i < n; ++i) count += keys[i] >= t;
    if (count >= k)
      lo = mid;
    else
      hi = mid - 1;
  }
  return std::int32_t(lo);
}

// Sums over a disk in kLanes interleaved partial sums, added up in a fixed order: shorter add
// chains (the loop is latency-bound otherwise) and the same bits on every run and thread count.
constexpr int kLanes = 4;
struct Moments {
  double max = -HUGE_VAL, min = HUGE_VAL, s = 0, sxz = 0, syz = 0, szz = 0;
};
// Of h_i − ref: max, min, Σ, Σx·, Σy·, Σ². `top` (if given) takes the max instead of h.
Moments moments(const Disk& disk, const double* h, double ref, const double* top = nullptr) {
  const int n = disk.size();
  double mx[kLanes], mn[kLanes], s[kLanes], sx[kLanes], sy[kLanes], sq[kLanes];
  for (int l = 0; l < kLanes; ++l) mx[l] = -HUGE_VAL, mn[l] = HUGE_VAL, s[l] = sx[l] = sy[l] = sq[l] = 0;
  const double* t = top ? top : h;
  int i = 0;
  for (; i + kLanes <= n; i += kLanes)
    for (int l = 0; l < kLanes; ++l) {
      const double d = h[i + l] - ref, u = t[i + l] - ref;
      mx[l] = std::max(mx[l], u), mn[l] = std::min(mn[l], d);
      s[l] += d, sq[l] += d * d, sx[l] += disk.x[i + l] * d, sy[l] += disk.y[i + l] * d;
    }
  for (int l = 0; i < n; ++i, ++l) {
    const double d = h[i] - ref, u = t[i] - ref;
    mx[l] = std::max(mx[l], u), mn[l] = std::min(mn[l], d);
    s[l] += d, sq[l] += d * d, sx[l] += disk.x[i] * d, sy[l] += disk.y[i] * d;
  }
  Moments m;
  m.max = std::max(std::max(mx[0], mx[1]), std::max(mx[2], mx[3]));
  m.min = std::min(std::min(mn[0], mn[1]), std::min(mn[2], mn[3]));
  m.s = (s[0] + s[1]) + (s[2] + s[3]);
  m.sxz = (sx[0] + sx[1]) + (sx[2] + sx[3]);
  m.syz = (sy[0] + sy[1]) + (sy[2] + sy[3]);
  m.szz = (sq[0] + sq[1]) + (sq[2] + sq[3]);
  return m;
}

struct Outputs {
  std::array<Raster<float>*, kAllFootfallMethods.size()> score{};  // by method index; null: not wanted
  Raster<float>* tilt = nullptr;
};

void validate(const FootfallConfig& cfg, const MapGrid& grid) {
  auto fail = [](const std::string& what) { throw std::invalid_argument("evaluateFootfalls: " + what); };
  auto str = [](double v) {
    std::ostringstream s;
    s << v;
    return s.str();
  };
  if (!(cfg.foot_diameter_m > 0) || !std::isfinite(cfg.foot_diameter_m))
    fail("foot_diameter_m = " + str(cfg.foot_diameter_m) + " must be positive and finite");
  if (!(cfg.min_support_fraction > 0 && cfg.min_support_fraction <= 1))
    fail("min_support_fraction = " + str(cfg.min_support_fraction) + " must be in (0, 1]");
  if (!(cfg.max_normal_deviation_deg > 0 && cfg.max_normal_deviation_deg <= 90))
    fail("max_normal_deviation_deg = " + str(cfg.max_normal_deviation_deg) + " must be in (0, 90]");
  if (!(cfg.moment_weight >= 0) || !std::isfinite(cfg.moment_weight))
    fail("moment_weight = " + str(cfg.moment_weight) + " must be ≥ 0 and finite");
  if (!(cfg.max_unknown_fraction >= 0 && cfg.max_unknown_fraction < 1))
    fail("max_unknown_fraction = " + str(cfg.max_unknown_fraction) + " must be in [0, 1)");
  if (!(cfg.sigma_k >= 0) || !std::isfinite(cfg.sigma_k))
    fail("sigma_k = " + str(cfg.sigma_k) + " must be ≥ 0 and finite");
  if (!(cfg.sinkage_m >= 0) || !std::isfinite(cfg.sinkage_m))
    fail("sinkage_m = " + str(cfg.sinkage_m) + " must be ≥ 0 and finite");
  if (!(cfg.rigid_height_m >= 0) || !std::isfinite(cfg.rigid_height_m))
    fail("rigid_height_m = " + str(cfg.rigid_height_m) + " must be ≥ 0 and finite");
  if (!(cfg.rigid_width_m > 0) || !std::isfinite(cfg.rigid_width_m))
    fail("rigid_width_m = " + str(cfg.rigid_width_m) + " must be positive and finite");
  if (!(grid.cell > 0) || grid.rows <= 0 || grid.cols <= 0) fail("the map's grid is empty");
}

// Every layer the grid's size.
void validateLayers(const ElevationLayers& m) {
  const auto check = [&](const char* name, Eigen::Index rows, Eigen::Index cols) {
    if (rows == m.grid.rows && cols == m.grid.cols) return;
    std::ostringstream s;
    s << "evaluateFootfalls: the " << name << " layer is " << rows << " x " << cols << ", the grid "
      << m.grid.rows << " x " << m.grid.cols;
    throw std::invalid_argument(s.str());
  };
  check("elevation", m.elevation.rows(), m.elevation.cols());
  check("sigma", m.sigma.rows(), m.sigma.cols());
  check("ceiling", m.ceiling.rows(), m.ceiling.cols());
  check("state", m.state.rows(), m.state.cols());
}

// EquilibriumSoil's rigid cells in rows [r0, r1) × cols [c0, c1) (clipped to the map), as a
// map-sized mask: Known cells standing more than `height` above the grey opening of the Known
// heights by `element` (the largest, over every placement of the element that holds the cell, of
// the smallest Known height it covers). The opening is what is left of the surface when every
// feature narrower than the element is taken off: the ground without its rocks. Exact (min and
// max only), so the same on any thread count.
std::vector<std::uint8_t> rigidCells(const ElevationLayers& map, int r0, int r1, int c0, int c1, const Disk& element,
                                     double height) {
  const MapGrid& g = map.grid;
  const int k = element.reach;
  const auto known = [&](int r, int c) {
    return map.state(r, c) == std::uint8_t(CellState::Known) && std::isfinite(map.elevation(r, c));
  };
  // The erosion (min over the element's Known cells) at every placement within `k` of the window,
  // also those centred off the map or on unknown cells: a placement need only hold a Known cell.
  // Clipped to the map instead, the opening of a plane would fall below it near the map's edge
  // (the placements that reach past a cell towards the rising side would be missing).
  const int er0 = r0 - k, er1 = r1 + k, ec0 = c0 - k, ec1 = c1 + k;
  const int ew = ec1 - ec0;
  std::vector<float> eroded(std::size_t(std::max(er1 - er0, 0)) * std::size_t(std::max(ew, 0)), HUGE_VALF);
  for (int r = er0; r < er1; ++r)
    for (int c = ec0; c < ec1; ++c) {
      float lo = HUGE_VALF;
      for (int i = 0; i < element.size(); ++i) {
        const int rr = r + element.drow[i], cc = c + element.dcol[i];
        if (rr < 0 || rr >= g.rows || cc < 0 || cc >= g.cols || !known(rr, cc)) continue;
        lo = std::min(lo, map.elevation(rr, cc));
      }
      eroded[std::size_t(r - er0) * ew + std::size_t(c - ec0)] = lo;
    }
  // The dilation of that (max over the element) at the window's Known cells.
  std::vector<std::uint8_t> mask(std::size_t(g.rows) * g.cols, 0);
  for (int r = std::max(r0, 0); r < std::min(r1, g.rows); ++r)
    for (int c = std::max(c0, 0); c < std::min(c1, g.cols); ++c) {
      if (!known(r, c)) continue;
      float ground = -HUGE_VALF;
      for (int i = 0; i < element.size(); ++i) {
        const int rr = r + element.drow[i], cc = c + element.dcol[i];
        if (rr < er0 || rr >= er1 || cc < ec0 || cc >= ec1) continue;
        const float e = eroded[std::size_t(rr - er0) * ew + std::size_t(cc - ec0)];
        if (e != HUGE_VALF) ground = std::max(ground, e);
      }
      mask[std::size_t(r) * g.cols + c] = double(map.elevation(r, c)) - double(ground) > height;
    }
  return mask;
}

}  // namespace

std::string_view footfallMethodName(FootfallMethod m) {
  switch (m) {
    case FootfallMethod::MaxMin: return "max_min";
    case FootfallMethod::PlanarFit: return "planar_fit";
    case FootfallMethod::SupportArea: return "support_area";
    case FootfallMethod::FreeVolume: return "free_volume";
    case FootfallMethod::Equilibrium: return "equilibrium";
    case FootfallMethod::EquilibriumUncertain: return "equilibrium_uncertain";
    case FootfallMethod::EquilibriumSoil: return "equilibrium_soil";
  }
  return "?";
}

FootfallMethod footfallMethodFromName(std::string_view name) {
  for (FootfallMethod m : kAllFootfallMethods)
    if (footfallMethodName(m) == name) return m;
  throw std::invalid_argument("unknown footfall method '" + std::string(name) +
                              "' (max_min, planar_fit, support_area, free_volume, equilibrium, "
                              "equilibrium_uncertain, equilibrium_soil)");
}

CellRegion regionOfBox(const MapGrid& grid, double x0, double x1, double y0, double y1) {
  // Centres x_min + (c + 0.5)·cell ∈ [x0, x1] and y_max − (r + 0.5)·cell ∈ [y0, y1].
  const double eps = 1e-9;
  const int c0 = int(std::ceil((x0 - grid.x_min) / grid.cell - 0.5 - eps));
  const int c1 = int(std::floor((x1 - grid.x_min) / grid.cell - 0.5 + eps));
  const int r0 = int(std::ceil((grid.y_max - y1) / grid.cell - 0.5 - eps));
  const int r1 = int(std::floor((grid.y_max - y0) / grid.cell - 0.5 + eps));
  CellRegion reg;
  reg.row0 = r0;
  reg.col0 = c0;
  reg.rows = std::max(0, r1 - r0 + 1);
  reg.cols = std::max(0, c1 - c0 + 1);
  return reg;
}

std::vector<FootfallScores> evaluateFootfalls(const ElevationMap& map, const CellRegion& region,
                                              const FootfallConfig& cfg,
                                              const std::vector<FootfallMethod>& methods) {
  return evaluateFootfalls(ElevationLayers(map), region, cfg, methods);
}

std::vector<FootfallScores> evaluateFootfalls(const ElevationLayers& map, const CellRegion& region,
                                              const FootfallConfig& cfg,
                                              const std::vector<FootfallMethod>& methods) {
  const MapGrid& grid = map.grid;
  validate(cfg, grid);
  validateLayers(map);
  // The region clipped to the map.
  const int r_begin = std::max(region.row0, 0), r_end = std::min(region.row0 + region.rows, grid.rows);
  const int c_begin = std::max(region.col0, 0), c_end = std::min(region.col0 + region.cols, grid.cols);
  if (region.rows <= 0 || region.cols <= 0 || r_begin >= r_end || c_begin >= c_end) {
    std::ostringstream s;
    s << "evaluateFootfalls: the region (rows " << region.row0 << ".." << region.row0 + region.rows - 1
      << ", cols " << region.col0 << ".." << region.col0 + region.cols - 1 << ") has no cell on the "
      << grid.rows << " x " << grid.cols << " map";
    throw std::invalid_argument(s.str());
  }
  const double width = (c_end - c_begin) * grid.cell, height = (r_end - r_begin) * grid.cell;
  if (cfg.foot_diameter_m > std::min(width, height) * (1 + 1e-9)) {
    std::ostringstream s;
    s << "evaluateFootfalls: the foot (" << cfg.foot_diameter_m << " m across) is larger than the region ("
      << width << " m x " << height << " m on the map)";
    throw std::invalid_argument(s.str());
  }
  const Disk disk = makeDisk(grid.cell, cfg.foot_diameter_m);
  if (disk.size() < 3) {
    std::ostringstream s;
    s << "evaluateFootfalls: the foot (" << cfg.foot_diameter_m << " m across) covers " << disk.size()
      << " cell(s) of " << grid.cell << " m; a plane needs 3";
    throw std::invalid_argument(s.str());
  }

  std::vector<FootfallScores> out(methods.size());
  Outputs dst;
  Wanted want;
  for (size_t i = 0; i < methods.size(); ++i) {
    out[i].method = methods[i];
    out[i].score = Raster<float>::Constant(grid.rows, grid.cols, kNaN);
  }
  // Each method's raster is written once even if asked for twice (the duplicate is copied after).
  for (size_t i = 0; i < methods.size(); ++i) {
    const int k = int(methods[i]);
    if (dst.score[k]) continue;
    dst.score[k] = &out[i].score;
    switch (methods[i]) {
      case FootfallMethod::MaxMin: want.max_min = true; break;
      case FootfallMethod::PlanarFit:
        want.planar = true;
        out[i].tilt_deg = Raster<float>::Constant(grid.rows, grid.cols, kNaN);
        dst.tilt = &out[i].tilt_deg;
        break;
      case FootfallMethod::SupportArea: want.support = true; break;
      case FootfallMethod::FreeVolume: want.free_volume = true; break;
      case FootfallMethod::Equilibrium: want.equilibrium = true; break;
      case FootfallMethod::EquilibriumUncertain: want.uncertain = true; break;
      case FootfallMethod::EquilibriumSoil: want.soil = true; break;
    }
  }

  // Candidates: region cells whose whole disk lies on the map.
  const int cr0 = std::max(r_begin, disk.reach), cr1 = std::min(r_end, grid.rows - disk.reach);
  const int cc0 = std::max(c_begin, disk.reach), cc1 = std::min(c_end, grid.cols - disk.reach);

  const int n = disk.size();
  const double cell = grid.cell, cell2 = cell * cell, cell3 = cell2 * cell;
  const double radius = 0.5 * cfg.foot_diameter_m;
  const int max_unknown = int(std::floor(cfg.max_unknown_fraction * n + 1e-9));
  // k cells at or above the foot's plane make A_min (at least one: the highest point).
  const int k_support = std::clamp(int(std::ceil(cfg.min_support_fraction * n - 1e-9)), 1, n);
  const double tan_max = std::tan(cfg.max_normal_deviation_deg * M_PI / 180);
  const auto& Z = map.elevation;
  const auto& S = map.sigma;
  const auto& C = map.ceiling;
  const auto& ST = map.state;

  // EquilibriumSoil (docs/footfall.md, "Soil"): the cells under the foot and around its rim
  // (centres within one cell beyond it: a rock sampled there may reach under the rim, and carries
  // the foot once the soil around it yields), and which of them are rigid.
  const Disk overlap = makeDisk(grid.cell, cfg.foot_diameter_m + 2 * grid.cell);
  std::vector<std::uint8_t> rigid;
  if (want.soil && cr0 < cr1 && cc0 < cc1)
    rigid = rigidCells(map, cr0 - overlap.reach, cr1 + overlap.reach, cc0 - overlap.reach, cc1 + overlap.reach,
                       makeDisk(cell, cfg.rigid_width_m), cfg.rigid_height_m);

  auto evaluateRows = [&](const tbb::blocked_range<int>& rows) {
    Scratch w;
    w.z.resize(n), w.upper.resize(n), w.lower.resize(n), w.keys.resize(n), w.known.resize(n);
    for (int r = rows.begin(); r != rows.end(); ++r)
      for (int c = cc0; c < cc1; ++c) {
        // --- The five methods of §5, on the Known cells (and a plane through them). ---
        if (want.paper()) {
          int unknown = 0;
          for (size_t j = 0, i = 0; j < disk.span_w.size(); ++j) {  // row spans: contiguous reads
            const int rr = r + disk.span_drow[j], len = 2 * disk.span_w[j] + 1;
            const float* zp = Z.data() + rr * Z.outerStride() + (c - disk.span_w[j]);
            const std::uint8_t* sp = ST.data() + rr * ST.outerStride() + (c - disk.span_w[j]);
            for (int q = 0; q < len; ++q, ++i) {
              const bool k = sp[q] == std::uint8_t(CellState::Known) && std::isfinite(zp[q]);
              w.known[i] = k;
              w.z[i] = zp[q];
              unknown += !k;
            }
          }
          bool ok = unknown <= max_unknown;
          if (ok && unknown > 0) ok = fillWithPlane(disk, w.z, w.known);
          if (ok) {
            // Heights relative to the centre cell's keep the sums' cancellation small.
            const double ref = w.z[n / 2];
            const Moments m = moments(disk, w.z.data(), ref);
            const double zmax = m.max, zmin = m.min, s = m.s, sxz = m.sxz, syz = m.syz, szz = m.szz;
            if (want.max_min) (*dst.score[0])(r, c) = float(zmax - zmin);
            if (want.planar) {
              // z = z̄ + a·x + b·y on the symmetric disk: a = Σx·z/Σx² (per cell here).
              const double a = sxz / double(disk.sum_dx2), b = syz / double(disk.sum_dy2);
              const double rss = szz - s * s / n - a * sxz - b * syz;
              const double slope = std::hypot(a, b) / cell;  // tan of the normal's angle from vertical
              (*dst.tilt)(r, c) = float(std::atan(slope) * 180 / M_PI);
              if (slope <= tan_max) (*dst.score[1])(r, c) = float(std::sqrt(std::max(rss, 0.0) / n));
            }
            if (want.support) {
              // The k-th highest: with the foot's sole d below the top, k cells touch it. (Map
              // heights are floats, so this is exact; a plane-filled height is rounded to float.)
              for (int i = 0; i < n; ++i) w.keys[i] = orderKey(float(w.z[i]));
              const double kth = fromOrderKey(kthHighest(w.keys, k_support));
              (*dst.score[2])(r, c) = float(zmax - (kth - ref));
            }
            const double V = cell2 * (n * zmax - s);
            if (want.free_volume) (*dst.score[3])(r, c) = float(V);
            if (want.equilibrium) {
              // m_x = Σ x_i(z_max − z_i)·cell² = −cell³·Σdcol·z (Σdcol = 0 on the disk).
              const double E = cell3 * std::hypot(sxz, syz);
              (*dst.score[4])(r, c) = float(V + cfg.moment_weight * E / radius);
            }
          }
        }
        // --- EquilibriumSoil: equilibrium on the surface the soil leaves, over the cells under the
        // foot and around its rim: every cell sunk by the sinkage but the rigid ones. A disk with
        // an unknown cell there is no candidate (a rock the map has not seen may stand under the
        // rim); cells beyond the map's edge are left out.
        if (want.soil) {
          bool ok = true;
          for (int i = 0; i < overlap.size() && ok; ++i) {
            const int rr = r + overlap.drow[i], cc = c + overlap.dcol[i];
            if (rr < 0 || rr >= grid.rows || cc < 0 || cc >= grid.cols) continue;
            ok = ST(rr, cc) == std::uint8_t(CellState::Known) && std::isfinite(Z(rr, cc));
          }
          if (ok) {
            // Heights relative to the centre's; sums in the overlap's fixed order.
            const double ref = Z(r, c);
            double top = -HUGE_VAL, sum = 0, sx = 0, sy = 0, sxz = 0, syz = 0;
            int count = 0;
            for (int i = 0; i < overlap.size(); ++i) {
              const int rr = r + overlap.drow[i], cc = c + overlap.dcol[i];
              if (rr < 0 || rr >= grid.rows || cc < 0 || cc >= grid.cols) continue;
              const double zy = double(Z(rr, cc)) - ref - (rigid[std::size_t(rr) * grid.cols + cc] ? 0.0 : cfg.sinkage_m);
              top = std::max(top, zy);
              sum += zy, sx += overlap.x[i], sy += overlap.y[i], sxz += overlap.x[i] * zy, syz += overlap.y[i] * zy;
              ++count;
            }
            // V = cell²·Σ(top − z_i); m = cell³·Σ(x_i, y_i)(top − z_i), Σx_i not 0 where cells
            // beyond the map's edge were left out.
            const double V = cell2 * (count * top - sum);
            const double E = cell3 * std::hypot(top * sx - sxz, top * sy - syz);
            (*dst.score[6])(r, c) = float(V + cfg.moment_weight * E / radius);
          }
        }
        // --- EquilibriumUncertain: pessimistic bounds from σ_z and shadow ceilings. ---
        if (want.uncertain) {
          bool ok = true;
          for (int i = 0; i < n && ok; ++i) {
            const int rr = r + disk.drow[i], cc = c + disk.dcol[i];
            switch (CellState(ST(rr, cc))) {
              case CellState::Known: {
                const double z = Z(rr, cc), s = S(rr, cc);
                ok = std::isfinite(z) && std::isfinite(s);
                w.upper[i] = z + cfg.sigma_k * s;
                w.lower[i] = z - cfg.sigma_k * s;
                break;
              }
              case CellState::Shadow: {
                const double ceiling = C(rr, cc);
                ok = std::isfinite(ceiling);
                w.upper[i] = w.lower[i] = ceiling;
                break;
              }
              default: ok = false;
            }
          }
          if (ok) {
            const double ref = w.lower[n / 2];
            const Moments m = moments(disk, w.lower.data(), ref, w.upper.data());
            const double top = m.max, s = m.s, sxl = m.sxz, syl = m.syz;
            const double V = cell2 * (n * top - s);
            const double E = cell3 * std::hypot(sxl, syl);
            (*dst.score[5])(r, c) = float(V + cfg.moment_weight * E / radius);
          }
        }
      }
  };
  if (cr0 < cr1 && cc0 < cc1) tbb::parallel_for(tbb::blocked_range<int>(cr0, cr1), evaluateRows);

  for (size_t i = 0; i < methods.size(); ++i) {
    FootfallScores& o = out[i];
    const int k = int(methods[i]);
    if (dst.score[k] != &o.score) {  // a repeated method: copy the first one's
      o.score = *dst.score[k];
      if (methods[i] == FootfallMethod::PlanarFit) o.tilt_deg = *dst.tilt;
    }
    // The lowest score, first in row-major order on ties: a serial scan, so deterministic.
    for (int r = cr0; r < cr1; ++r)
      for (int c = cc0; c < cc1; ++c) {
        const float v = o.score(r, c);
        if (std::isnan(v)) continue;
        if (!o.best || v < o.best_score) o.best = Eigen::Vector2i(r, c), o.best_score = v;
      }
  }
  return out;
}

}  // namespace ambler::perception
