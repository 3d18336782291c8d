#pragma once
// Fractional Brownian surfaces by spectral synthesis (docs/terrains.md, "Fractal").
#include <cstdint>

#include "terrains/heightfield.hpp"

namespace ambler::terrains {

// The band of wavenumbers (rad/m) the fractal spans on a grid: the largest wavelength is the
// grid's larger side, the smallest two cells (Nyquist).
struct FractalBand {
  double k_min = 0.0;
  double k_max = 0.0;
};
FractalBand fractalBand(const Heightfield& grid);

// Spectral modes per octave of wavenumber: enough that the sum is close to Gaussian and the
// spectrum smooth, few enough that a 25M-sample grid takes seconds.
inline constexpr int kFractalModesPerOctave = 32;

// Adds an isotropic fBm surface with Hurst exponent `hurst` (0 < H < 1; power spectrum
// ∝ k^−(2+2H) over fractalBand(ground)), shifted and scaled so that its own minimum and maximum
// over the grid are −relief_m/2 and +relief_m/2. Every random number comes from `key`.
// Throws std::invalid_argument for hurst outside (0, 1) or a negative relief.
void addFractal(Heightfield& ground, double relief_m, double hurst, std::uint64_t key);

}  // namespace ambler::terrains
