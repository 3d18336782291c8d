#pragma once
// Deterministic random numbers that do not depend on the standard library's distributions
// (whose algorithms are implementation-defined), so the same seed gives the same terrain and
// the same noise on every platform and with any thread schedule.
#include <bit>
#include <cmath>
#include <cstdint>
#include <numbers>

namespace ambler::base {

// SplitMix64 finaliser: a strong 64-bit mix, the basis of the counter-based draws below.
constexpr std::uint64_t mix64(std::uint64_t z) {
  z += 0x9E3779B97F4A7C15ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

// A key for an independent stream, derived from a seed and a list of integers
// (e.g. seed, view index, pixel index).
constexpr std::uint64_t streamKey(std::uint64_t seed, std::uint64_t a, std::uint64_t b = 0) {
  return mix64(mix64(mix64(seed) ^ a) ^ (b * 0xD6E8FEB86659FD93ull));
}

// The seed of view `view`'s scan noise: a stream of the scenario's seed apart from the terrain's.
constexpr std::uint64_t viewSeed(std::uint64_t seed, int view) { return streamKey(seed, std::uint64_t(1000 + view)); }

// Uniform double in [0, 1) from 53 random bits.
constexpr double toUnit(std::uint64_t bits) { return double(bits >> 11) * 0x1.0p-53; }

// Uniform double in [−1, 1) from the top 52 bits, by bit assembly (exact, and vectorisable
// without 64-bit integer conversions): 2·d − 3 with d in [1, 2).
inline double signedUnit52(std::uint64_t bits) {
  return 2.0 * std::bit_cast<double>((bits >> 12) | 0x3FF0000000000000ull) - 3.0;
}

// A small sequential generator (SplitMix64 stream).
class Rng {
 public:
  explicit Rng(std::uint64_t seed) : state_(mix64(seed)) {}
  std::uint64_t next() { return mix64(state_ += 0x9E3779B97F4A7C15ull); }
  double uniform() { return toUnit(next()); }
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  // Integer in [0, n).
  std::uint64_t below(std::uint64_t n) { return n ? next() % n : 0; }
  // Standard normal by Box-Muller (one of the pair; simple and exact in distribution).
  double normal() {
    const double u1 = 1.0 - uniform();  // (0, 1]
    const double u2 = uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * std::numbers::pi * u2);
  }

 private:
  std::uint64_t state_;
};

// Standard normal drawn from a counter (stateless): the same key always gives the same value.
// An exact ziggurat sampler (Marsaglia & Tsang's 128 layers in Doornik's form): one 64-bit draw
// and no transcendental function in 97.2 % of calls (the mean of the layers' ratios), which
// matters at millions of pixels a scan.
double normalFromKey(std::uint64_t key);

// The ziggurat's tables, for callers that run the fast path over many keys at once: with
// bits = mix64(key), layer i = bits & 127 and u = signedUnit52(bits), if |u| < ratio[i] the draw
// is u·x[i] (exactly what normalFromKey returns); otherwise call normalFromKey(key).
struct ZigguratTables {
  const double* x;      // 129 layer edges
  const double* ratio;  // 128 ratios x[i+1]/x[i]
};
const ZigguratTables& zigguratTables();

}  // namespace ambler::base
