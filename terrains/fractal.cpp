#include "terrains/fractal.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

#include "base/random.hpp"

namespace ambler::terrains {
namespace {

constexpr double kPi = std::numbers::pi;

// One plane wave A·cos(kx·x + ky·y + φ).
struct Mode {
  double kx, ky, phase, amplitude;
};

// Random-phase spectral synthesis with one mode per logarithmic bin of |k|. Drawing |k| inside
// a bin from the bin's share of the spectrum (density ∝ P(k)·k ∝ k^−(1+2H)) and giving the mode
// the bin's whole variance makes the expected structure function exactly that of the continuous
// band-limited spectrum, not a staircase of it.
std::vector<Mode> drawModes(const FractalBand& band, double hurst, base::Rng& rng) {
  const double octaves = std::log2(band.k_max / band.k_min);
  const int bins = std::max(1, int(std::ceil(kFractalModesPerOctave * octaves)));
  const double ratio = std::pow(band.k_max / band.k_min, 1.0 / bins);
  const double e = 2.0 * hurst;
  std::vector<Mode> modes;
  modes.reserve(bins);
  double ka = band.k_min;
  for (int j = 0; j < bins; ++j) {
    const double kb = (j + 1 == bins) ? band.k_max : ka * ratio;
    const double pa = std::pow(ka, -e), pb = std::pow(kb, -e);
    const double k = std::pow(pa - rng.uniform() * (pa - pb), -1.0 / e);  // inverse CDF
    const double theta = rng.uniform(0.0, 2.0 * kPi);
    const double phase = rng.uniform(0.0, 2.0 * kPi);
    const double variance = (pa - pb) / e;  // ∫ k^−(1+2H) dk over the bin, up to a constant
    modes.push_back({k * std::cos(theta), k * std::sin(theta), phase, std::sqrt(2.0 * variance)});
    ka = kb;
  }
  return modes;
}

}  // namespace

FractalBand fractalBand(const Heightfield& grid) {
  const double side = std::max(grid.xMax() - grid.xMin(), grid.yMax() - grid.yMin());
  const double k_min = 2.0 * kPi / side;
  // A 2×2 grid has no room for an octave: give it one anyway rather than an empty band.
  return {k_min, std::max(kPi / grid.cell(), 2.0 * k_min)};
}

void addFractal(Heightfield& ground, double relief_m, double hurst, std::uint64_t key) {
  if (!(hurst > 0.0 && hurst < 1.0))
    throw std::invalid_argument("fractal: hurst must be in (0, 1), got " + std::to_string(hurst));
  if (!(relief_m >= 0.0) || !std::isfinite(relief_m))
    throw std::invalid_argument("fractal: relief_m must be finite and >= 0");
  if (relief_m == 0.0) return;

  base::Rng rng(key);
  const std::vector<Mode> modes = drawModes(fractalBand(ground), hurst, rng);
  const int rows = ground.rows(), cols = ground.cols();

  // cos(kx·x + φ + ky·y) = cx·cos(ky·y) − sx·sin(ky·y): per-mode column and row tables turn the
  // sum into two multiply-adds per mode and sample, with no trigonometry in the inner loop.
  const std::size_t n = modes.size();
  std::vector<double> cx(n * cols), sx(n * cols);
  for (std::size_t j = 0; j < n; ++j)
    for (int c = 0; c < cols; ++c) {
      const double a = modes[j].kx * ground.position(0, c).x() + modes[j].phase;
      cx[j * cols + c] = modes[j].amplitude * std::cos(a);
      sx[j * cols + c] = modes[j].amplitude * std::sin(a);
    }
  std::vector<double> cy(n * rows), sy(n * rows);
  for (std::size_t j = 0; j < n; ++j)
    for (int r = 0; r < rows; ++r) {
      const double b = modes[j].ky * ground.position(r, 0).y();
      cy[r * n + j] = std::cos(b);
      sy[r * n + j] = std::sin(b);
    }
  // Blocks of columns keep the tables' working set in cache on wide grids.
  constexpr int kBlock = 256;
  HeightMatrix z = HeightMatrix::Zero(rows, cols);
  for (int c0 = 0; c0 < cols; c0 += kBlock) {
    const int width = std::min(kBlock, cols - c0);
    for (int r = 0; r < rows; ++r) {
      double* out = z.row(r).data() + c0;
      for (std::size_t j = 0; j < n; ++j) {
        const double cr = cy[r * n + j], sr = sy[r * n + j];
        const double* cj = &cx[j * cols + c0];
        const double* sj = &sx[j * cols + c0];
        for (int c = 0; c < width; ++c) out[c] += cj[c] * cr - sj[c] * sr;
      }
    }
  }

  const double lo = z.minCoeff(), hi = z.maxCoeff();
  if (!(hi > lo)) return;
  const double scale = relief_m / (hi - lo), mid = 0.5 * (lo + hi);
  ground.heights().array() += (z.array() - mid) * scale;
}

}  // namespace ambler::terrains
