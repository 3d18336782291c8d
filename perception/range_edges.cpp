#include "perception/range_edges.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

namespace ambler::perception {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
// Over-relaxation of the SOR sweeps (Blake & Zisserman's update f ← f − ω·∂E/∂f / T).
constexpr float kOmega = 1.5f;
// Below this many pixels a pass runs on one thread: TBB's scheduling would cost more than it saves.
constexpr long kSerialPixels = 1L << 15;
// Unwrapping accepts a fold when the candidate is within this many σ of the prediction.
constexpr double kUnwrapSigmas = 5.0;

// Runs body(begin, end) over [0, n) rows, in parallel for large images.
template <class Body>
void forRows(int n, long pixels, const Body& body) {
  if (pixels < kSerialPixels) {
    body(0, n);
    return;
  }
  tbb::parallel_for(tbb::blocked_range<int>(0, n, 8),
                    [&](const tbb::blocked_range<int>& b) { body(b.begin(), b.end()); });
}

// Median of five by Devillard's seven compare-exchanges (branch-free, so rows of it vectorise).
inline void sort2(float& a, float& b) {
  const float lo = std::min(a, b);
  b = std::max(a, b);
  a = lo;
}
inline float median5(float a, float b, float c, float d, float e) {
  sort2(a, b), sort2(d, e), sort2(a, d), sort2(b, e), sort2(b, c), sort2(c, d), sort2(b, c);
  return c;
}

// A link's rest difference. The trend s is the median of its own first difference of u and the
// two either side along the same scanline (a missing neighbour — border, invalid pixel — is
// replaced by its mirror image about the link, or by the link itself, so the window stays
// centred). On a plane u = n·d/c is linear in the beam direction and its differences vary slowly,
// so the median follows them; a jump is one outlier among five (a mixed pixel splits it in two),
// so the trend ignores it and the jump stands out in full. An occlusion makes the range change
// faster than the surface does (towards grazing), never slower: a difference between the trend
// and 0 (a face turned towards the sensor, e.g. a rock's front between ground and top) is smooth
// surface, so the rest difference is the data's own difference clamped to [0, s].
inline float restDifference(float a, float b, float x, float e, float g) {
  const float b2 = b == b ? b : (e == e ? e : x), e2 = e == e ? e : (b == b ? b : x);
  const float a2 = a == a ? a : (g == g ? g : x), g2 = g == g ? g : (a == a ? a : x);
  const float s = median5(a2, b2, x, e2, g2);
  return std::clamp(x, std::min(s, 0.0f), std::max(s, 0.0f));
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
  float deriv(float t) const {
    const float a = std::abs(t);
    const float v = a < q ? two_l2 * a : (a < r ? c * (r - a) : 0.0f);
    return std::copysign(v, t);
  }
};

// The membrane on inverse range u = 1/ρ, on a padded grid (one ring of empty pixels, so no pixel
// needs a border test). Link "right" of pixel i joins i and i+1, link "down" joins i and i+w; a
// link's k is 1/σ_u there (0: no link), so τ = k·(f_j − f_i − s) is its excess in units of the noise.
struct Membrane {
  int rows, cols, w;
  std::vector<float> u, f, weight, inv_t, s_right, k_right, s_down, k_down;

  Membrane(int rows_, int cols_) : rows(rows_), cols(cols_), w(cols_ + 2) {
    const std::size_t n = std::size_t(rows + 2) * w;
    for (auto* v : {&u, &f, &weight, &inv_t, &s_right, &k_right, &s_down, &k_down}) v->assign(n, 0.0f);
  }
  std::size_t at(int r, int c) const { return std::size_t(r + 1) * w + (c + 1); }

  // One half-sweep: the pixels of one colour of the checkerboard in rows [r0, r1). Each depends
  // only on the other colour, so rows and pixels are independent.
  void halfSweep(int r0, int r1, int colour, const Penalty& g) {
    for (int r = r0; r < r1; ++r) {
      const std::size_t base = at(r, 0);
      for (int c = (r + colour) & 1; c < cols; c += 2) {
        const std::size_t i = base + c;
        const float fi = f[i];
        const float grad = 2.0f * weight[i] * (fi - u[i]) -
                           k_right[i] * g.deriv(k_right[i] * (f[i + 1] - fi - s_right[i])) +
                           k_right[i - 1] * g.deriv(k_right[i - 1] * (fi - f[i - 1] - s_right[i - 1])) -
                           k_down[i] * g.deriv(k_down[i] * (f[i + w] - fi - s_down[i])) +
                           k_down[i - w] * g.deriv(k_down[i - w] * (fi - f[i - w] - s_down[i - w]));
        f[i] = fi - kOmega * inv_t[i] * grad;
      }
    }
  }
};

void requireConfig(bool ok, const char* what) {
  if (!ok) throw std::invalid_argument(std::string("GncConfig: ") + what);
}

}  // namespace

double RangeNoise::sigma(double rho) const {
  return quantization_m / std::sqrt(12.0) + k * rho * rho;
}

EdgeMask detectRangeEdges(const RangeImage& image, const GncConfig& config) {
  requireConfig(config.lambda > 0 && std::isfinite(config.lambda), "lambda must be positive");
  requireConfig(config.h0 > 0 && std::isfinite(config.h0), "h0 must be positive");
  requireConfig(config.sweeps >= 1, "sweeps must be at least 1");
  requireConfig(config.noise.k >= 0 && config.noise.quantization_m >= 0 &&
                    config.noise.k + config.noise.quantization_m > 0,
                "noise k and quantization_m must be non-negative, not both zero");
  const int rows = image.rows(), cols = image.cols();
  EdgeMask edges = EdgeMask::Zero(rows, cols);
  if (rows == 0 || cols == 0) return edges;
  const long pixels = long(rows) * cols;
  Membrane m(rows, cols);
  // σ_u = σ(ρ)/ρ² is the noise of u = 1/ρ; each pixel's data term is weighted by 1/σ_u².
  std::vector<float> sigma_u(m.u.size(), 0.0f);
  forRows(rows, pixels, [&](int r0, int r1) {
    for (int r = r0; r < r1; ++r)
      for (int c = 0; c < cols; ++c) {
        const double rho = image.range(r, c);
        if (!(std::isfinite(rho) && rho > 0)) continue;
        const std::size_t i = m.at(r, c);
        const double su = config.noise.sigma(rho) / (rho * rho);
        m.u[i] = m.f[i] = float(1.0 / rho);
        sigma_u[i] = float(su);
        m.weight[i] = float(1.0 / (su * su));
      }
  });
  // First differences of u along rows and columns, NaN where a link touches an invalid pixel; two
  // NaN links pad every scanline's ends so the trend window needs no bounds.
  const int wd = cols + 4;
  std::vector<float> diff_right(std::size_t(rows) * wd, kNaN);
  std::vector<float> diff_down(std::size_t(rows + 4) * cols, kNaN);
  forRows(rows, pixels, [&](int r0, int r1) {
    for (int r = r0; r < r1; ++r)
      for (int c = 0; c < cols; ++c) {
        const std::size_t i = m.at(r, c);
        if (!(m.weight[i] > 0)) continue;
        if (m.weight[i + 1] > 0) diff_right[std::size_t(r) * wd + c + 2] = m.u[i + 1] - m.u[i];
        if (m.weight[i + m.w] > 0) diff_down[std::size_t(r + 2) * cols + c] = m.u[i + m.w] - m.u[i];
      }
  });
  // Links: the trend s, and k = 1/σ_u with σ_u the mean of the two pixels' (0 for no link).
  forRows(rows, pixels, [&](int r0, int r1) {
    for (int r = r0; r < r1; ++r) {
      const float* dr = &diff_right[std::size_t(r) * wd + 2];
      const float* dd = &diff_down[std::size_t(r + 2) * cols];
      for (int c = 0; c < cols; ++c) {
        const std::size_t i = m.at(r, c);
        const bool right = dr[c] == dr[c], down = dd[c] == dd[c];
        m.s_right[i] = right ? restDifference(dr[c - 2], dr[c - 1], dr[c], dr[c + 1], dr[c + 2]) : 0.0f;
        m.k_right[i] = right ? 2.0f / (sigma_u[i] + sigma_u[i + 1]) : 0.0f;
        m.s_down[i] = down ? restDifference(dd[c - 2 * cols], dd[c - cols], dd[c], dd[c + cols], dd[c + 2 * cols]) : 0.0f;
        m.k_down[i] = down ? 2.0f / (sigma_u[i] + sigma_u[i + m.w]) : 0.0f;
      }
    }
  });
  // T bounds ∂²E/∂f_i² (Blake & Zisserman's SOR step).
  const float lambda2 = float(config.lambda * config.lambda);
  forRows(rows, pixels, [&](int r0, int r1) {
    for (int r = r0; r < r1; ++r)
      for (int c = 0; c < cols; ++c) {
        const std::size_t i = m.at(r, c), up = i - m.w;
        const float k2 = m.k_right[i] * m.k_right[i] + m.k_right[i - 1] * m.k_right[i - 1] +
                         m.k_down[i] * m.k_down[i] + m.k_down[up] * m.k_down[up];
        m.inv_t[i] = m.weight[i] > 0 ? 1.0f / (2.0f * m.weight[i] + 2.0f * lambda2 * k2) : 0.0f;
      }
  });
  // GNC: p = 1 (convex) halving down to 1/(2λ), each step's minimum starting the next.
  const double p_end = std::min(1.0, 0.5 / config.lambda);
  for (double p = 1.0;; p = std::max(0.5 * p, p_end)) {
    const Penalty g(config.lambda, config.h0, p);
    for (int s = 0; s < config.sweeps; ++s)
      for (int colour = 0; colour < 2; ++colour)
        forRows(rows, pixels, [&](int r0, int r1) { m.halfSweep(r0, r1, colour, g); });
    if (p <= p_end) break;
  }
  // The line process: a link is broken where the final |τ| exceeds √α/λ = h0/√(2λ).
  const float h0 = float(config.h0 / std::sqrt(2.0 * config.lambda));
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) {
      const std::size_t i = m.at(r, c);
      if (std::abs(m.k_right[i] * (m.f[i + 1] - m.f[i] - m.s_right[i])) > h0)
        edges(r, c) = edges(r, c + 1) = 1;
      if (std::abs(m.k_down[i] * (m.f[i + m.w] - m.f[i] - m.s_down[i])) > h0)
        edges(r, c) = edges(r + 1, c) = 1;
    }
  return edges;
}

long unwrapRanges(RangeImage& image, double ambiguity_m, const RangeNoise& noise) {
  if (!(ambiguity_m > 0 && std::isfinite(ambiguity_m)))
    throw std::invalid_argument("unwrapRanges: ambiguity_m must be positive");
  const double a = ambiguity_m;
  const int rows = image.rows(), cols = image.cols();
  // u = 1/ρ of the decided pixels (NaN: not decided). On a plane 1/ρ is linear in the beam
  // direction, so a linear prediction from two neighbours is nearly exact at any incidence.
  std::vector<double> u(std::size_t(rows) * cols, std::numeric_limits<double>::quiet_NaN());
  auto U = [&](int r, int c) -> double& { return u[std::size_t(r) * cols + c]; };
  // The near field: the bottom two rows look down at the closest ground, taken as unfolded.
  for (int r = std::max(0, rows - 2); r < rows; ++r)
    for (int c = 0; c < cols; ++c) {
      float& rho = image.range(r, c);
      if (std::isfinite(rho) && rho > 0) U(r, c) = 1.0 / rho;
      else rho = std::numeric_limits<float>::quiet_NaN();
    }
  long unwrapped = 0;
  // The multiple of A that puts the measurement m within tolerance of the predicted 1/ρ, if
  // exactly one does.
  auto decide = [&](int r, int c, double u_pred) {
    if (!(u_pred > 0)) return;
    const double m = image.range(r, c), rho_pred = 1.0 / u_pred;
    const double tol = kUnwrapSigmas * std::sqrt(6.0) * noise.sigma(rho_pred) * u_pred * u_pred;
    const long n0 = std::lround((rho_pred - m) / a);
    int hits = 0;
    long best = 0;
    for (long n = std::max(0L, n0 - 1); n <= std::max(0L, n0 + 1); ++n) {
      const double rho = m + double(n) * a;
      if (rho > 0 && std::abs(1.0 / rho - u_pred) <= tol) ++hits, best = n;
    }
    if (hits != 1) return;
    image.range(r, c) = float(m + double(best) * a);
    U(r, c) = 1.0 / image.range(r, c);
    unwrapped += best != 0;
  };
  for (int r = rows - 3; r >= 0; --r) {
    auto open = [&](int c) { return std::isfinite(image.range(r, c)) && std::isnan(U(r, c)); };
    for (int c = 0; c < cols; ++c)  // from below
      if (open(c) && std::isfinite(U(r + 1, c)) && std::isfinite(U(r + 2, c)))
        decide(r, c, 2 * U(r + 1, c) - U(r + 2, c));
    for (int c = 2; c < cols; ++c)  // from the left
      if (open(c) && std::isfinite(U(r, c - 1)) && std::isfinite(U(r, c - 2)))
        decide(r, c, 2 * U(r, c - 1) - U(r, c - 2));
    for (int c = cols - 3; c >= 0; --c)  // from the right
      if (open(c) && std::isfinite(U(r, c + 1)) && std::isfinite(U(r, c + 2)))
        decide(r, c, 2 * U(r, c + 1) - U(r, c + 2));
    for (int c = 0; c < cols; ++c)
      if (open(c)) image.range(r, c) = std::numeric_limits<float>::quiet_NaN();
  }
  return unwrapped;
}

}  // namespace ambler::perception
