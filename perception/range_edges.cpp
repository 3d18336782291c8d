#include "perception/range_edges.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace ambler::perception {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr double kNaND = std::numeric_limits<double>::quiet_NaN();
// Over-relaxation of the SOR sweeps (Blake & Zisserman's update f ← f − ω·(∂E/∂f)/T).
constexpr float kOmega = 1.5f;
// Below this many pixels a pass runs on one thread: TBB's scheduling would cost more than it saves.
constexpr long kSerialPixels = 1L << 15;
// Unwrapping: a fold continues a surface when the candidate is within this many σ of the
// prediction; across a depth discontinuity it is accepted when the range changes by at most this
// factor (seen from a height h over an obstacle of height H, an occlusion multiplies the range
// by h/(h − H): 1.5 for a 1 m rock under a 3 m mast) and exactly one candidate does.
constexpr double kUnwrapSigmas = 5.0;
constexpr double kUnwrapJumpRatio = 1.5;

// Runs body(begin, end) over the rows [0, n), in parallel for large images.
template <class Body>
void forRows(int n, long pixels, const Body& body) {
  if (pixels < kSerialPixels) {
    body(0, n);
    return;
  }
  tbb::parallel_for(tbb::blocked_range<int>(0, n, 4),
                    [&](const tbb::blocked_range<int>& b) { body(b.begin(), b.end()); });
}

// Median of five by Devillard's seven compare-exchanges (branch-free).
inline void sort2(float& a, float& b) {
  const float lo = std::min(a, b);
  b = std::max(a, b);
  a = lo;
}
inline float median5(float a, float b, float c, float d, float e) {
  sort2(a, b), sort2(d, e), sort2(a, d), sort2(b, e), sort2(b, c), sort2(c, d), sort2(b, c);
  return c;
}

// A link's rest difference, from the first differences of u along its scanline: its own, x, and
// two either side, (a, b) before and (e, g) after, NaN where missing. The trend s is their median
// (a missing one replaced by its mirror image about the link, or by x, so the window stays
// centred). On a plane u = n·d/c is linear in the beam direction and its differences vary slowly,
// so the median follows them; a jump is one outlier among five (a mixed pixel splits it in two),
// so the trend ignores it and the jump stands out in full. An occlusion makes the range change
// faster than the surface does (towards grazing), never slower: a difference between the trend
// and 0 (a face turned towards the sensor, e.g. a rock's front between ground and top) is smooth
// surface, so the rest difference is x clamped to [0, s].
inline float restDifference(float a, float b, float x, float e, float g) {
  const float b2 = b == b ? b : (e == e ? e : x), e2 = e == e ? e : (b == b ? b : x);
  const float a2 = a == a ? a : (g == g ? g : x), g2 = g == g ? g : (a == a ? a : x);
  const float s = median5(a2, b2, x, e2, g2);
  return std::min(std::max(x, std::min(s, 0.0f)), std::max(s, 0.0f));
}

// B&Z's g^(p) for the membrane (c = c*/p, c* = 1/2): λ²t² up to q, then α − c(|t| − r)²/2 up to
// r, then α. The break costs α = λh0²/2, so an isolated step in the data breaks when taller than
// the contrast threshold h0 = √(2α/λ). Only the derivative is needed.
struct Penalty {
  float two_l2, q, r, c;
  Penalty(double lambda, double h0, double p) {
    const double alpha = 0.5 * lambda * h0 * h0, cc = 0.5 / p;
    const double rr = std::sqrt(alpha * (2.0 / cc + 1.0 / (lambda * lambda)));
    two_l2 = float(2 * lambda * lambda), q = float(alpha / (lambda * lambda * rr)), r = float(rr);
    c = float(cc);
  }
  // Below q the quadratic branch 2λ²|t| is the smaller, above q the concave one c(r − |t|) (they
  // meet at q), and beyond r the slope is 0: one min and one max, no branch, so sweeps vectorise.
  float deriv(float t) const {
    const float a = std::abs(t);
    return std::copysign(std::min(two_l2 * a, std::max(c * (r - a), 0.0f)), t);
  }
};

// The noise of u = 1/ρ: σ_u = σ/ρ² = √(k² + (σ_q² + σ_s²)·u⁴), with σ_ρ² = (k·ρ²)² + σ_q² the
// sensor model's (SensorModel::rangeVariance) and σ_s the surface's own departure from the
// membrane's local trend (GncConfig::surface_sigma_m), in single precision.
struct NoiseU {
  float sq, k;
  NoiseU(const SensorModel& s, double surface_sigma_m)
      : sq(float(std::sqrt(s.quantizationVariance() + surface_sigma_m * surface_sigma_m))), k(float(s.noise_k)) {}
  float variance(float u) const {
    const float q = sq * u * u;
    return k * k + q * q;
  }
  float sigma(float u) const { return std::sqrt(variance(u)); }
};

// B&Z's SOR step f ← f − ω·(∂E/∂f)/T on n pixels `fo` of one colour: the data term (f − u)²/σ_u²,
// and per link (right, left, down, up) the neighbour f, the rest difference s and k. T bounds
// ∂²E/∂f²: 2/σ_u² from the data, 2λ²k² from each link. The pointers are restrict parameters (the
// runs never overlap) so that the loop vectorises without alias checks.
void sorRun(float* __restrict fo, const float* __restrict fr, const float* __restrict fl,
            const float* __restrict fd, const float* __restrict fu, const float* __restrict u,
            const float* __restrict sr, const float* __restrict kr, const float* __restrict sl,
            const float* __restrict kl, const float* __restrict sd, const float* __restrict kd,
            const float* __restrict su, const float* __restrict ku, int n, const NoiseU noise,
            const Penalty g) {
  for (int j = 0; j < n; ++j) {
    // A pixel without data has u = 0 and only links with k = 0, so its f stays 0; its σ_u² is
    // offset by 1 so that nothing divides by 0. (The variance, not σ: no square root per step.)
    const float var = noise.variance(u[j]) + (u[j] == 0.0f ? 1.0f : 0.0f);
    const float fi = fo[j], w = 1.0f / var;
    const float grad = 2.0f * w * (fi - u[j]) - kr[j] * g.deriv(kr[j] * (fr[j] - fi - sr[j])) +
                       kl[j] * g.deriv(kl[j] * (fi - fl[j] - sl[j])) -
                       kd[j] * g.deriv(kd[j] * (fd[j] - fi - sd[j])) +
                       ku[j] * g.deriv(ku[j] * (fi - fu[j] - su[j]));
    const float k2 = kr[j] * kr[j] + kl[j] * kl[j] + kd[j] * kd[j] + ku[j] * ku[j];
    const float t = 2.0f * w + g.two_l2 * k2;
    fo[j] = fi - kOmega * grad / t;
  }
}

// The membrane on inverse range u = 1/ρ. Arrays are in red-black order: each row holds its even
// columns, then its odd columns, each part with an empty cell at either end, and an empty row
// pads the top and the bottom, so a half-sweep reads and writes contiguous runs and no pixel
// needs a border test. The link "right" of a pixel joins it to (r, c + 1), "down" to (r + 1, c);
// a link's k is 1/σ_u there (0: no link), so τ = k·(f_j − f_i − s) is its excess in noise units.
struct Membrane {
  enum Array { kU, kF, kSRight, kKRight, kSDown, kKDown, kArrays };
  int rows, cols, part, stride;
  std::size_t size;
  std::unique_ptr<float[]> storage;  // uninitialised: every cell, padding included, is written

  Membrane(int rows_, int cols_)
      : rows(rows_), cols(cols_), part((cols_ + 1) / 2 + 2), stride(2 * part),
        size(std::size_t(rows_ + 2) * std::size_t(stride)), storage(new float[kArrays * size]) {}
  float* a(Array k) const { return storage.get() + k * size; }
  std::size_t at(int r, int c) const {
    return std::size_t(r + 1) * stride + std::size_t((c & 1) * part + 1 + (c >> 1));
  }
  // Writes row r (−1 and `rows` are the padding rows) of array k from `natural`, the row's values
  // in image order (nullptr: all zero), zeroing the padding cells.
  void storeRow(Array k, int r, const float* natural) const {
    float* even = a(k) + std::size_t(r + 1) * stride;
    float* odd = even + part;
    std::fill_n(even, stride, 0.0f);
    if (!natural) return;
    for (int j = 0; j < (cols + 1) / 2; ++j) even[1 + j] = natural[2 * j];
    for (int j = 0; j < cols / 2; ++j) odd[1 + j] = natural[2 * j + 1];
  }
  // The links of row r broken by the line process, in image order: `right[c]` joins (r, c) and
  // (r, c + 1), `down[c]` joins (r, c) and (r + 1, c).
  void brokenLinks(int r, float t_break, unsigned char* right, unsigned char* down) const {
    const std::size_t even = at(r, 0), odd = even + part;
    const float *f = a(kF), *s = a(kSRight), *k = a(kKRight);
    for (int j = 0; j < (cols + 1) / 2; ++j) {
      const std::size_t i = even + j;
      right[2 * j] = std::abs(k[i] * (f[odd + j] - f[i] - s[i])) > t_break;
    }
    for (int j = 0; j < cols / 2; ++j) {
      const std::size_t i = odd + j;
      right[2 * j + 1] = std::abs(k[i] * (f[even + j + 1] - f[i] - s[i])) > t_break;
    }
    const float *sd = a(kSDown), *kd = a(kKDown);
    for (int c = 0; c < cols; ++c) {
      const std::size_t i = at(r, c);
      down[c] = std::abs(kd[i] * (f[i + stride] - f[i] - sd[i])) > t_break;
    }
  }

  // One half-sweep: the pixels of one colour of the checkerboard in rows [r0, r1). Each depends
  // only on pixels of the other colour, so rows and pixels are independent.
  void halfSweep(int r0, int r1, int colour, const NoiseU& noise, const Penalty& g) const {
    for (int r = r0; r < r1; ++r) {
      const std::size_t even = at(r, 0), odd = even + part;
      if ((r & 1) == colour)  // the even columns; their left and right neighbours are odd
        run(even, odd, odd - 1, (cols + 1) / 2, noise, g);
      else
        run(odd, even + 1, even, cols / 2, noise, g);
    }
  }
  // n pixels from index i; their right and left neighbours start at `right` and `left` (in the
  // other part of the row, which also holds their left links).
  void run(std::size_t i, std::size_t right, std::size_t left, int n, const NoiseU& noise,
           const Penalty& g) const {
    float* f = a(kF);
    const std::size_t up = i - std::size_t(stride);
    sorRun(f + i, f + right, f + left, f + i + stride, f + up, a(kU) + i, a(kSRight) + i,
           a(kKRight) + i, a(kSRight) + left, a(kKRight) + left, a(kSDown) + i, a(kKDown) + i,
           a(kSDown) + up, a(kKDown) + up, n, noise, g);
  }
};

// One row of the membrane in image order: x points at the row's first u (NaN: no data) in an array
// with `v` floats per row and three NaN cells padding every side. k = 2/(σ_u,i + σ_u,j) for a
// link between two pixels with data, else 0. Straight-line arithmetic (a missing pixel is u = 0
// with a mask m = 0) and restrict parameters, so that the loop vectorises.
void membraneRow(const float* __restrict x, std::ptrdiff_t v, int cols, const NoiseU noise,
                 float* __restrict u, float* __restrict f, float* __restrict s_right,
                 float* __restrict k_right, float* __restrict s_down, float* __restrict k_down) {
  auto mask = [](float y) { return y == y ? 1.0f : 0.0f; };
  auto value = [](float y) { return y == y ? y : 0.0f; };
  for (int c = 0; c < cols; ++c) {
    const float* d = x + c;  // the pixel, then its neighbours at ±1, ±2, ±3 columns or rows
    const float sr =
        restDifference(d[-1] - d[-2], d[0] - d[-1], d[1] - d[0], d[2] - d[1], d[3] - d[2]);
    const float sd = restDifference(d[-v] - d[-2 * v], d[0] - d[-v], d[v] - d[0], d[2 * v] - d[v],
                                    d[3 * v] - d[2 * v]);
    // σ_u of a pixel, offset by 1 where it has no data so that nothing divides by 0.
    const float m0 = mask(d[0]), mr = mask(d[1]), md = mask(d[v]);
    const float s0 = noise.sigma(value(d[0])) + 1.0f - m0;
    const float kr = 2.0f * m0 * mr / (s0 + noise.sigma(value(d[1])) + 1.0f - mr);
    const float kd = 2.0f * m0 * md / (s0 + noise.sigma(value(d[v])) + 1.0f - md);
    u[c] = f[c] = value(d[0]);
    s_right[c] = kr != 0.0f ? sr : 0.0f;
    k_right[c] = kr;
    s_down[c] = kd != 0.0f ? sd : 0.0f;
    k_down[c] = kd;
  }
}

// The edge's continuation along its line (docs/range_edges.md, "Continuing an edge"). A link
// parallel to a broken one and beside it across the edge's line (for a down link, the down links
// of the columns either side, one row up or down) is on the same occluding contour if its raw
// excess τ₀ = k·(u_j − u_i − s), the data's jump beyond the trend in noise units before the
// membrane smooths it, has the broken link's sign. Two rules, both on τ₀:
//  - bridging: a link with |τ₀| > bridge_h breaks when broken links of its sign lie on both
//    sides within bridge_span pixels along the line (a gap in a contour the detector found);
//  - growth: a link with |τ₀| > grow_h breaks beside a broken link of its sign, and so on along
//    the line (a contour that fades below h0, e.g. where quantisation rounds a lip's jump down).
// Both start from the membrane's links, so the result does not depend on the order of the scan.
void continueEdges(const Membrane& m, const GncConfig& config, RangeLinks& links) {
  const int rows = m.rows, cols = m.cols;
  const float* u = m.a(Membrane::kU);
  // Whether the link (down or right) from (r, c) exists.
  auto inside = [&](bool down, int r, int c) {
    return r >= 0 && c >= 0 && r < rows - (down ? 1 : 0) && c < cols - (down ? 0 : 1);
  };
  // τ₀ of the link from (r, c); 0 where the link does not exist.
  auto raw = [&](bool down, int r, int c) -> float {
    if (!inside(down, r, c)) return 0.0f;
    const std::size_t i = m.at(r, c);
    if (down) return m.a(Membrane::kKDown)[i] * (u[i + m.stride] - u[i] - m.a(Membrane::kSDown)[i]);
    return m.a(Membrane::kKRight)[i] * (u[m.at(r, c + 1)] - u[i] - m.a(Membrane::kSRight)[i]);
  };
  // Link (r, c) shifted j pixels along the line and b across it: for a down link the line runs
  // along the row, for a right link along the column.
  auto along = [](bool down, int r, int c, int j, int b) {
    return down ? std::pair{r + b, c + j} : std::pair{r + j, c + b};
  };
  // The links of one orientation.
  auto of = [](auto& l, bool down) -> auto& { return down ? l.down : l.right; };
  if (config.bridge_h > 0) {
    const RangeLinks found = links;
    const float t_low = float(config.bridge_h);
    // Whether a link the membrane broke, of τ₀'s sign, lies within bridge_span on side `dir`.
    auto flanked = [&](bool down, int r, int c, int dir, float t) {
      const Raster<std::uint8_t>& f = of(found, down);
      for (int j = 1; j <= config.bridge_span; ++j)
        for (int b = -1; b <= 1; ++b) {
          const auto [rr, cc] = along(down, r, c, dir * j, b);
          if (inside(down, rr, cc) && f(rr, cc) && (raw(down, rr, cc) > 0) == (t > 0)) return true;
        }
      return false;
    };
    for (const bool down : {true, false}) {
      // The candidates: links within bridge_span of a broken one along the line (most links of an
      // image are not, and skip τ₀).
      const Raster<std::uint8_t>& f = of(found, down);
      Raster<std::uint8_t> near = Raster<std::uint8_t>::Zero(rows, cols);
      for (int r = 0; r < rows; ++r)
        for (int c = 0; c < cols; ++c)
          if (f(r, c))
            for (int j = -config.bridge_span; j <= config.bridge_span; ++j)
              for (int b = -1; b <= 1; ++b) {
                const auto [rr, cc] = along(down, r, c, j, b);
                if (j != 0 && inside(down, rr, cc)) near(rr, cc) = 1;
              }
      for (int r = 0; r < rows; ++r)
        for (int c = 0; c < cols; ++c) {
          std::uint8_t& broken = of(links, down)(r, c);
          if (broken || !near(r, c)) continue;
          const float t = raw(down, r, c);
          if (std::abs(t) > t_low && flanked(down, r, c, -1, t) && flanked(down, r, c, 1, t)) broken = 1;
        }
    }
  }
  if (config.grow_h > 0) {
    const float t_low = float(config.grow_h);
    struct Link {
      int r, c;
      bool down;
      float t;
    };
    std::vector<Link> stack;
    for (const bool down : {true, false})
      for (int r = 0; r < rows; ++r)
        for (int c = 0; c < cols; ++c)
          if (of(links, down)(r, c)) stack.push_back({r, c, down, raw(down, r, c)});
    while (!stack.empty()) {
      const Link l = stack.back();
      stack.pop_back();
      for (const int j : {-1, 1})
        for (int b = -1; b <= 1; ++b) {
          const auto [r, c] = along(l.down, l.r, l.c, j, b);
          if (!inside(l.down, r, c)) continue;
          std::uint8_t& broken = of(links, l.down)(r, c);
          const float t = raw(l.down, r, c);
          if (broken || !(std::abs(t) > t_low) || (t > 0) != (l.t > 0)) continue;
          broken = 1;
          stack.push_back({r, c, l.down, t});
        }
    }
  }
}

// The median of w[0..n), n ≥ 1 (sorted in place; n is small).
inline double medianOf(double* w, int n) {
  for (int i = 1; i < n; ++i)
    for (int j = i; j > 0 && w[j] < w[j - 1]; --j) std::swap(w[j], w[j - 1]);
  return n % 2 ? w[n / 2] : 0.5 * (w[n / 2 - 1] + w[n / 2]);
}

// Unbreaks the links whose jump hides too little to matter (GncConfig::occlusion_depth_k,
// docs/range_edges.md, "Shallow occlusions"). Along a link's line, the seven range differences
// centred on it give its own, d, and the trend t, the median of the six others (a jump is one
// outlier among them, a mixed pixel's two halves two). Visible ground between two samples spans
// L = √(t² + (ρ·Δα)²) (along the ray the trend, across it the pixels' spacing) and meets the rays
// at sin β = ρ·Δα/L, so a jump J = |d − t| beyond the trend (or |d + d' − 2t| with a neighbour d'
// along the line) can hide J·sin β of depth below the surface the trend continues. That depth is
// compared with what the ground itself departs from a straight line over L, σ_s·(L/L0)^H. Only
// the image enters (no pose), so the edges of a scan stay those of every pose it is mapped at.
void dropShallowOcclusions(const RangeImage& image, const GncConfig& config, RangeLinks& links) {
  const int rows = image.rows(), cols = image.cols();
  if (rows < 2 || cols < 2) return;
  const double da_rows = std::abs(image.phi[1] - image.phi[0]), da_cols = std::abs(image.theta[1] - image.theta[0]);
  auto rho = [&](int r, int c) {
    return r < 0 || c < 0 || r >= rows || c >= cols || !image.valid(r, c) ? kNaND : double(image.range(r, c));
  };
  for (const bool down : {true, false}) {
    Raster<std::uint8_t>& l = down ? links.down : links.right;
    const Raster<std::uint8_t> found = l;
    const int dr = down ? 1 : 0, dc = down ? 0 : 1;
    const double da = down ? da_rows : da_cols;
    for (int r = 0; r < rows; ++r)
      for (int c = 0; c < cols; ++c) {
        if (!found(r, c)) continue;
        double d[7], w[6];
        int n = 0;
        for (int k = -3; k <= 3; ++k) {
          d[k + 3] = rho(r + (k + 1) * dr, c + (k + 1) * dc) - rho(r + k * dr, c + k * dc);
          if (k != 0 && !std::isnan(d[k + 3])) w[n++] = d[k + 3];
        }
        if (n < 2 || std::isnan(d[3])) continue;  // no trend to judge by: the link stays broken
        const double t = medianOf(w, n);
        double jump = std::abs(d[3] - t);
        if (!std::isnan(d[2])) jump = std::max(jump, std::abs(d[2] + d[3] - 2 * t));
        if (!std::isnan(d[4])) jump = std::max(jump, std::abs(d[3] + d[4] - 2 * t));
        const double across = std::min(rho(r, c), rho(r + dr, c + dc)) * da, L = std::hypot(t, across);
        const double relief = config.surface_sigma_m * std::pow(L / config.surface_scale_m, config.surface_hurst);
        if (jump * across / L < config.occlusion_depth_k * relief) l(r, c) = 0;
      }
  }
}

void requireConfig(bool ok, const char* what) {
  if (!ok) throw std::invalid_argument(std::string("GncConfig: ") + what);
}

}  // namespace

RangeLinks detectBrokenLinks(const RangeImage& image, const SensorModel& sensor, const GncConfig& config) {
  requireConfig(config.lambda > 0 && std::isfinite(config.lambda), "lambda must be positive");
  requireConfig(config.h0 > 0 && std::isfinite(config.h0), "h0 must be positive");
  requireConfig(config.surface_sigma_m >= 0 && std::isfinite(config.surface_sigma_m),
                "surface_sigma_m must be non-negative");
  requireConfig(config.occlusion_depth_k >= 0 && std::isfinite(config.occlusion_depth_k),
                "occlusion_depth_k must be non-negative");
  requireConfig(config.surface_scale_m > 0 && std::isfinite(config.surface_scale_m), "surface_scale_m must be positive");
  requireConfig(config.surface_hurst >= 0 && config.surface_hurst < 1, "surface_hurst must be in [0, 1)");
  requireConfig(config.sweeps >= 1, "sweeps must be at least 1");
  requireConfig(config.bridge_h >= 0 && std::isfinite(config.bridge_h), "bridge_h must be non-negative");
  requireConfig(config.bridge_span >= 1, "bridge_span must be at least 1");
  requireConfig(config.grow_h >= 0 && std::isfinite(config.grow_h), "grow_h must be non-negative");
  requireConfig(sensor.noise_k >= 0 && sensor.quantization_m >= 0,
                "sensor noise_k and quantization_m must be non-negative");
  const int rows = image.rows(), cols = image.cols();
  RangeLinks links{Raster<std::uint8_t>::Zero(rows, cols), Raster<std::uint8_t>::Zero(rows, cols)};
  if (rows == 0 || cols == 0) return links;
  const long pixels = long(rows) * cols;

  // u = 1/ρ in image order, NaN where there is no data, with three NaN rows and columns either
  // side so that every trend window stays in bounds.
  const int wn = cols + 6;
  std::vector<float> un(std::size_t(rows + 6) * wn, kNaN);
  auto nat = [&](int r, int c) { return &un[std::size_t(r + 3) * wn + std::size_t(c + 3)]; };
  forRows(rows, pixels, [&](int r0, int r1) {
    for (int r = r0; r < r1; ++r)
      for (int c = 0; c < cols; ++c) {
        const float rho = image.range(r, c);
        if (std::isfinite(rho) && rho > 0) *nat(r, c) = 1.0f / rho;
      }
  });

  // The membrane's data and links. σ_u (NoiseU) is the noise of u, so the data term is weighted
  // by 1/σ_u² and a link's k is 2/(σ_u,i + σ_u,j).
  Membrane m(rows, cols);
  const NoiseU noise(sensor, config.surface_sigma_m);
  for (int k = 0; k < Membrane::kArrays; ++k)
    m.storeRow(Membrane::Array(k), -1, nullptr), m.storeRow(Membrane::Array(k), rows, nullptr);
  forRows(rows, pixels, [&](int r0, int r1) {
    std::vector<float> buffer(std::size_t(Membrane::kArrays) * cols);
    float* row[Membrane::kArrays];
    for (int k = 0; k < Membrane::kArrays; ++k) row[k] = &buffer[std::size_t(k) * cols];
    for (int r = r0; r < r1; ++r) {
      membraneRow(nat(r, 0), wn, cols, noise, row[Membrane::kU], row[Membrane::kF],
                  row[Membrane::kSRight], row[Membrane::kKRight], row[Membrane::kSDown],
                  row[Membrane::kKDown]);
      for (int k = 0; k < Membrane::kArrays; ++k) m.storeRow(Membrane::Array(k), r, row[k]);
    }
  });

  // GNC: p = 1 (convex) halving down to 1/(2λ), each step's minimum starting the next.
  const double p_end = std::min(1.0, 0.5 / config.lambda);
  for (double p = 1.0;; p = std::max(0.5 * p, p_end)) {
    const Penalty g(config.lambda, config.h0, p);
    for (int s = 0; s < config.sweeps; ++s)
      for (int colour = 0; colour < 2; ++colour)
        forRows(rows, pixels, [&](int r0, int r1) { m.halfSweep(r0, r1, colour, noise, g); });
    if (p <= p_end) break;
  }

  // The line process: a link is broken where the final |τ| exceeds √α/λ = h0/√(2λ).
  const float t_break = float(config.h0 / std::sqrt(2.0 * config.lambda));
  forRows(rows, pixels, [&](int r0, int r1) {
    for (int r = r0; r < r1; ++r) m.brokenLinks(r, t_break, &links.right(r, 0), &links.down(r, 0));
  });
  continueEdges(m, config, links);
  if (config.occlusion_depth_k > 0) dropShallowOcclusions(image, config, links);
  return links;
}

Raster<std::uint8_t> detectRangeEdges(const RangeImage& image, const SensorModel& sensor, const GncConfig& config) {
  const RangeLinks links = detectBrokenLinks(image, sensor, config);
  const int rows = image.rows(), cols = image.cols();
  Raster<std::uint8_t> edges(rows, cols);
  // A pixel is an edge if any of its four links is broken; the broken ones say which way.
  forRows(rows, long(rows) * cols, [&](int r0, int r1) {
    for (int r = r0; r < r1; ++r)
      for (int c = 0; c < cols; ++c) {
        const bool across_rows = links.down(r, c) || (r > 0 && links.down(r - 1, c));
        const bool across_cols = links.right(r, c) || (c > 0 && links.right(r, c - 1));
        edges(r, c) = std::uint8_t((across_rows || across_cols ? kEdgePixel : 0) | (across_rows ? kEdgeAcrossRows : 0) |
                                   (across_cols ? kEdgeAcrossCols : 0));
      }
  });
  return edges;
}

long unwrapRanges(RangeImage& image, const SensorModel& sensor) {
  if (!(sensor.ambiguity_m > 0 && std::isfinite(sensor.ambiguity_m)))
    throw std::invalid_argument("unwrapRanges: the sensor's ambiguity_m must be positive");
  const double a = sensor.ambiguity_m;
  const int rows = image.rows(), cols = image.cols();
  // u = 1/ρ of the decided pixels (NaN: not decided). On a plane 1/ρ is linear in the beam
  // direction, so a linear prediction from two neighbours is nearly exact at any incidence.
  std::vector<double> u(std::size_t(rows) * cols, std::numeric_limits<double>::quiet_NaN());
  auto U = [&](int r, int c) -> double& { return u[std::size_t(r) * cols + c]; };
  auto measured = [&](int r, int c) {
    const float rho = image.range(r, c);
    return std::isfinite(rho) && rho > 0;  // 0 is a reading too (the top count), but not 1/ρ
  };
  // The continuity tolerance on u around a prediction u_pred: kUnwrapSigmas·√6·σ_u.
  auto tolerance = [&](double u_pred) {
    return kUnwrapSigmas * std::sqrt(6.0) * sensor.rangeSigma(1.0 / u_pred) * u_pred * u_pred;
  };

  // The seed, taken as unfolded: in the lowest row that has one, the longest run of at least three
  // pixels, each continuous with the linear prediction from the two before it. A folded stretch
  // of a continuous surface is continuous in the readings too, but where the surface crosses A
  // the reading drops from ~A to ~0, which ends a run. So the near-field assumption is only that
  // the row's longest continuous stretch is nearer than A, not every pixel of the row: on a plane
  // tilted 45° sideways the bottom row's far end is already past A.
  int seed_row = -1, seed_begin = 0, seed_end = 0;
  for (int r = rows - 1; r >= 0 && seed_row < 0; --r) {
    int begin = 0, best = 2;  // a run needs three pixels: two alone show no continuity
    for (int c = 0; c <= cols; ++c) {
      const bool ok = c < cols && measured(r, c);
      bool continues = ok && c - begin < 2;
      if (ok && c - begin >= 2) {
        const double u1 = 1.0 / image.range(r, c - 1), u2 = 1.0 / image.range(r, c - 2);
        const double u_pred = 2 * u1 - u2;
        continues = u_pred > 0 && std::abs(1.0 / image.range(r, c) - u_pred) <= tolerance(u_pred);
      }
      if (continues) continue;
      if (c - begin > best) best = c - begin, seed_row = r, seed_begin = begin, seed_end = c;
      begin = ok ? c : c + 1;
    }
  }
  if (seed_row < 0) {  // no continuous stretch anywhere: nothing can be decided
    image.range.setConstant(kNaN);
    return 0;
  }
  for (int c = seed_begin; c < seed_end; ++c) U(seed_row, c) = 1.0 / image.range(seed_row, c);

  long unwrapped = 0;
  // The multiple n of A that puts the measurement m + nA within tolerance of the predicted 1/ρ —
  // or, with `jump`, within a factor kUnwrapJumpRatio of the predicted ρ — if exactly one does.
  auto decide = [&](int r, int c, double u_pred, bool jump) {
    if (!(u_pred > 0)) return;
    const double m = image.range(r, c), rho_pred = 1.0 / u_pred;
    const double tol = tolerance(u_pred);
    const double lo = jump ? rho_pred / kUnwrapJumpRatio : 0;
    const double hi = jump ? rho_pred * kUnwrapJumpRatio : 0;
    const long n_hi = long(std::ceil((std::max(hi, rho_pred) - m) / a)) + 1;
    int hits = 0;
    long best = 0;
    for (long n = 0; n <= n_hi; ++n) {
      const double rho = m + double(n) * a;
      const bool fits = std::abs(1.0 / rho - u_pred) <= tol || (rho >= lo && rho <= hi);
      if (rho > 0 && fits) ++hits, best = n;
    }
    if (hits != 1) return;
    image.range(r, c) = float(m + double(best) * a);
    U(r, c) = 1.0 / image.range(r, c);
    unwrapped += best != 0;
  };
  // Row r from the decided row r + d and r + 2d (d = 1: below, d = −1: above), then along itself.
  auto unwrapRow = [&](int r, int d) {
    auto open = [&](int c) { return std::isfinite(image.range(r, c)) && std::isnan(U(r, c)); };
    auto decided = [&](int rr, int c) { return rr >= 0 && rr < rows && std::isfinite(U(rr, c)); };
    // Continuity from the row before, then along the row both ways; `jump` admits
    // discontinuities, and then one decided pixel before suffices (it only sets the scale).
    auto passes = [&](bool jump) {
      for (int c = 0; c < cols; ++c) {
        if (!open(c) || !decided(r + d, c)) continue;
        if (decided(r + 2 * d, c)) decide(r, c, 2 * U(r + d, c) - U(r + 2 * d, c), jump);
        else if (jump) decide(r, c, U(r + d, c), jump);
      }
      for (int c = 2; c < cols; ++c)
        if (open(c) && decided(r, c - 1) && decided(r, c - 2))
          decide(r, c, 2 * U(r, c - 1) - U(r, c - 2), jump);
      for (int c = cols - 3; c >= 0; --c)
        if (open(c) && decided(r, c + 1) && decided(r, c + 2))
          decide(r, c, 2 * U(r, c + 1) - U(r, c + 2), jump);
    };
    passes(false);  // continuous surfaces first: they are the surer path
    passes(true);
    for (int c = 0; c < cols; ++c)
      if (open(c)) image.range(r, c) = kNaN;  // never a wrapped range
  };
  unwrapRow(seed_row, 1);
  for (int r = seed_row - 1; r >= 0; --r) unwrapRow(r, 1);
  for (int r = seed_row + 1; r < rows; ++r) unwrapRow(r, -1);
  return unwrapped;
}

}  // namespace ambler::perception
