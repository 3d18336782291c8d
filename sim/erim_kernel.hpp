#pragma once
// The scanner's per-tile kernels (ray directions of a 4×4 tile of pixels; noise and measurement
// of its 16 ranges) in two versions: portable scalar code and AVX-512, picked at run time. Both
// give the same bits: the same IEEE operations (add, multiply, divide, compare, select, round to
// nearest) in the same order, with no fused multiply-add (the project builds with
// -ffp-contract=off). Lane i of a tile is pixel (r0 + i / 4, c0 + i % 4).
#include <cstdint>

#include "base/random.hpp"
#include "perception/sensor_model.hpp"

namespace ambler::sim::kernel {

enum class Isa { Scalar, Avx512 };

// The kernels to run: AVX-512 if the CPU and OS support AVX-512F/DQ, unless forceScalar is on.
Isa activeIsa();
// For tests: run the scalar kernels even where AVX-512 is available (false restores the default).
void forceScalar(bool on);

// sin and cos of the scan angles of one footprint sample, per row (φ) and per column (θ).
struct AngleTables {
  const double *sin_phi, *cos_phi, *sin_theta, *cos_theta;
};

// The 16 unit directions R·(sinθ, cosφ cosθ, sinφ cosθ) of the tile at (r0, c0), in float into
// fx, fy, fz and, if dx is not null, in double into dx, dy, dz. R is row-major. Pixels past
// `rows`/`cols` repeat the last row/column (their lanes are cast as invalid).
void tileDirections(Isa isa, const AngleTables& a, const double* R, int r0, int c0, int rows, int cols,
                    float* fx, float* fy, float* fz, double* dx, double* dy, double* dz);

// From the central packet's hits (distance t, geom id; kMiss = 0xFFFFFFFF for none): the true
// range (NaN for none) and geom id (-1 for none) per lane, and, if rho is not null, the range the
// measurement starts from: t as a double, NaN for none or beyond max_range.
void centreHits(Isa isa, const float* t, const unsigned* geom, double max_range, float* true_range,
                int* geom_id, double* rho);

// The measurement model with its reciprocals precomputed (a division costs more than the rest).
// Straight-line: every branch a select, with uniform conditions on the config.
struct Measurement {
  double k, ambiguity, inv_ambiguity, q, inv_q;
  explicit Measurement(const perception::SensorModel& s)
      : k(s.noise_k),
        ambiguity(s.ambiguity_m),
        inv_ambiguity(s.ambiguity_m > 0 ? 1.0 / s.ambiguity_m : 0.0),
        q(s.quantization_m),
        inv_q(s.quantization_m > 0 ? 1.0 / s.quantization_m : 0.0) {}

  // Round to nearest (ties to even) for 0 <= x < 2^51 with two additions: no libm call and no
  // integer conversion on the critical path. (IEEE semantics: never -ffast-math, which could
  // fold this to x.)
  static double roundNearest(double x) {
    constexpr double kMagic = 0x1.8p52;
    return (x + kMagic) - kMagic;
  }

  // The reported range for true range rho and standard normal draw `normal`: noise, wrap,
  // quantisation. With ambiguity or q zero the reciprocals are zero and those steps leave m alone.
  double operator()(double rho, double normal) const {
    double m = rho + k * rho * rho * normal;  // σ = SensorModel::noiseSigma(ρ), inlined
    m = m > 0.0 ? m : 0.0;
    double n = roundNearest(m * inv_ambiguity);
    n = n * ambiguity > m ? n - 1.0 : n;  // floor(m / ambiguity)
    m -= n * ambiguity;
    m = ambiguity > 0.0 && m >= ambiguity ? m - ambiguity : m;
    m = m < 0.0 ? m + ambiguity : m;
    const double counts = q * roundNearest(m * inv_q);
    m = q > 0.0 ? counts : m;
    // The top count rounds onto the interval's end, which is range 0 again.
    return ambiguity > 0.0 && m >= ambiguity ? 0.0 : m;
  }
};

// Noise and measurement of one tile.
struct MeasureTile {
  const Measurement* measure;
  const base::ZigguratTables* zig;
  std::uint64_t stream;  // the scan's noise stream: mix64(seed)
  bool noise;            // noise_k > 0
  std::uint64_t pixel0;  // the index r0·cols + c0 of lane 0; lane i is pixel0 + (i/4)·cols + i%4
  std::uint64_t cols;
};

// The noise draw of pixel `pixel`: SplitMix64's own stream, so the pixel index picks the draw,
// independent of threads.
inline std::uint64_t noiseKey(std::uint64_t stream, std::uint64_t pixel) {
  return stream + pixel * 0x9E3779B97F4A7C15ull;
}

// Pixels whose noise draw takes the ziggurat's slow path (its wedges and tail, ~3 % of draws).
// The AVX-512 kernel sets them aside, so that a rare and unpredictable branch (and its libm calls)
// stays out of the tile loop, where a mispredicted branch would throw away the ray cast behind it.
struct SlowDraws {
  static constexpr int kCapacity = 64;
  alignas(64) std::uint64_t pixel[kCapacity + 16];  // room for one more tile past capacity
  alignas(64) double rho[kCapacity + 16];
  int count = 0;
  bool nearlyFull() const { return count > kCapacity - 16; }
};

// reported[i] = the measurement of true range rho[i] (NaN where nothing returns, and then NaN).
// A pixel in `lanes` (bit i: lane i is in the image) whose draw is slow may instead be appended to
// `slow`, its reported value left provisional until finishSlowDraws.
void measureTile(Isa isa, const MeasureTile& t, const double* rho, unsigned lanes, float* reported,
                 SlowDraws& slow);

// Completes the set-aside draws exactly as measureTile would have: writes each one's reported
// range to range[pixel] (the row-major image) and empties `slow`. Call it after the provisional
// values are stored.
void finishSlowDraws(const MeasureTile& t, SlowDraws& slow, float* range);

}  // namespace ambler::sim::kernel
