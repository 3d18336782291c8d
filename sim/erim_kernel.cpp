#include "sim/erim_kernel.hpp"

// GCC 12's AVX-512 headers initialise their "undefined" vectors from themselves, which
// -Wuninitialized reports at every use.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wuninitialized"
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include <immintrin.h>
#pragma GCC diagnostic pop

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>

namespace ambler::sim::kernel {

namespace {

std::atomic<bool> forced_scalar{false};

bool cpuHasAvx512() {
  __builtin_cpu_init();  // libgcc also checks that the OS saves the AVX-512 state
  return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512dq");
}

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

// Both versions compute R·(a, b, c) with b = cosφ·cosθ, c = sinφ·cosθ in this order: the first two
// rows left to right, the third right to left — Eigen's order for a Matrix3d times a Vector3d
// (two rows as one SSE2 packet, the last as a scalar reduction), which the scanner used before.
void directionsScalar(const AngleTables& t, const double* R, int r0, int c0, int rows, int cols,
                      float* fx, float* fy, float* fz, double* dx, double* dy, double* dz) {
  for (int i = 0; i < 16; ++i) {
    const int r = std::min(r0 + i / 4, rows - 1), c = std::min(c0 + i % 4, cols - 1);
    const double ct = t.cos_theta[c];
    const double a = t.sin_theta[c], b = t.cos_phi[r] * ct, s = t.sin_phi[r] * ct;
    const double x = (R[0] * a + R[1] * b) + R[2] * s;
    const double y = (R[3] * a + R[4] * b) + R[5] * s;
    const double z = R[6] * a + (R[7] * b + R[8] * s);
    fx[i] = float(x), fy[i] = float(y), fz[i] = float(z);
    if (dx) dx[i] = x, dy[i] = y, dz[i] = z;
  }
}

// A full tile: lanes 8h..8h+7 are rows r0 + 2h and r0 + 2h + 1, four columns each.
__attribute__((target("avx512f,avx512dq"))) void directionsAvx512(
    const AngleTables& t, const double* R, int r0, int c0, float* fx, float* fy, float* fz, double* dx,
    double* dy, double* dz) {
  const __m512d st = _mm512_broadcast_f64x4(_mm256_loadu_pd(t.sin_theta + c0));
  const __m512d ct = _mm512_broadcast_f64x4(_mm256_loadu_pd(t.cos_theta + c0));
  __m512d m[9];
  for (int j = 0; j < 9; ++j) m[j] = _mm512_set1_pd(R[j]);
  for (int h = 0; h < 2; ++h) {
    const int r = r0 + 2 * h;
    const __m512d cp = _mm512_insertf64x4(_mm512_set1_pd(t.cos_phi[r]), _mm256_set1_pd(t.cos_phi[r + 1]), 1);
    const __m512d sp = _mm512_insertf64x4(_mm512_set1_pd(t.sin_phi[r]), _mm256_set1_pd(t.sin_phi[r + 1]), 1);
    const __m512d a = st, b = _mm512_mul_pd(cp, ct), s = _mm512_mul_pd(sp, ct);
    const __m512d x = _mm512_add_pd(_mm512_add_pd(_mm512_mul_pd(m[0], a), _mm512_mul_pd(m[1], b)), _mm512_mul_pd(m[2], s));
    const __m512d y = _mm512_add_pd(_mm512_add_pd(_mm512_mul_pd(m[3], a), _mm512_mul_pd(m[4], b)), _mm512_mul_pd(m[5], s));
    const __m512d z = _mm512_add_pd(_mm512_mul_pd(m[6], a), _mm512_add_pd(_mm512_mul_pd(m[7], b), _mm512_mul_pd(m[8], s)));
    _mm256_storeu_ps(fx + 8 * h, _mm512_cvtpd_ps(x));
    _mm256_storeu_ps(fy + 8 * h, _mm512_cvtpd_ps(y));
    _mm256_storeu_ps(fz + 8 * h, _mm512_cvtpd_ps(z));
    if (dx) {
      _mm512_storeu_pd(dx + 8 * h, x);
      _mm512_storeu_pd(dy + 8 * h, y);
      _mm512_storeu_pd(dz + 8 * h, z);
    }
  }
}

// Three passes over the lanes, so the pixels' long dependency chains (hash, table lookup,
// measurement) overlap instead of queueing behind one another.
void measureScalar(const MeasureTile& t, const double* rho, float* out) {
  double normal[16];
  bool slow[16];
  std::uint64_t key[16];
  for (int i = 0; i < 16; ++i) {
    key[i] = noiseKey(t.stream, t.pixel0 + std::uint64_t(i / 4) * t.cols + i % 4);
    const std::uint64_t bits = base::mix64(key[i]);
    const std::uint64_t layer = bits & 127;
    const double u = base::signedUnit52(bits);
    slow[i] = t.noise && !(std::abs(u) < t.zig->ratio[layer]);
    normal[i] = t.noise ? u * t.zig->x[layer] : 0.0;
  }
  for (int i = 0; i < 16; ++i)  // the ziggurat's rare edges and tail
    if (slow[i]) normal[i] = base::normalFromKey(key[i]);
  for (int i = 0; i < 16; ++i) out[i] = rho[i] == rho[i] ? float((*t.measure)(rho[i], normal[i])) : kNaN;
}

__attribute__((target("avx512f,avx512dq"))) __m512i mix64Avx512(__m512i z) {
  z = _mm512_add_epi64(z, _mm512_set1_epi64(std::int64_t(0x9E3779B97F4A7C15ull)));
  z = _mm512_mullo_epi64(_mm512_xor_si512(z, _mm512_srli_epi64(z, 30)), _mm512_set1_epi64(std::int64_t(0xBF58476D1CE4E5B9ull)));
  z = _mm512_mullo_epi64(_mm512_xor_si512(z, _mm512_srli_epi64(z, 27)), _mm512_set1_epi64(std::int64_t(0x94D049BB133111EBull)));
  return _mm512_xor_si512(z, _mm512_srli_epi64(z, 31));
}

// Measurement::operator() on 8 lanes, step for step (a select for every ternary; the conditions
// on the config are uniform, so they stay branches).
__attribute__((target("avx512f,avx512dq"))) __m512d measureAvx512(const Measurement& mm, __m512d rho, __m512d normal) {
  const __m512d zero = _mm512_setzero_pd(), one = _mm512_set1_pd(1.0), magic = _mm512_set1_pd(0x1.8p52);
  const __m512d amb = _mm512_set1_pd(mm.ambiguity), q = _mm512_set1_pd(mm.q);
  __m512d m = _mm512_add_pd(rho, _mm512_mul_pd(_mm512_mul_pd(_mm512_mul_pd(_mm512_set1_pd(mm.k), rho), rho), normal));
  m = _mm512_mask_blend_pd(_mm512_cmp_pd_mask(m, zero, _CMP_GT_OQ), zero, m);
  __m512d n = _mm512_sub_pd(_mm512_add_pd(_mm512_mul_pd(m, _mm512_set1_pd(mm.inv_ambiguity)), magic), magic);
  n = _mm512_mask_blend_pd(_mm512_cmp_pd_mask(_mm512_mul_pd(n, amb), m, _CMP_GT_OQ), n, _mm512_sub_pd(n, one));
  m = _mm512_sub_pd(m, _mm512_mul_pd(n, amb));
  if (mm.ambiguity > 0.0) m = _mm512_mask_blend_pd(_mm512_cmp_pd_mask(m, amb, _CMP_GE_OQ), m, _mm512_sub_pd(m, amb));
  m = _mm512_mask_blend_pd(_mm512_cmp_pd_mask(m, zero, _CMP_LT_OQ), m, _mm512_add_pd(m, amb));
  const __m512d counts = _mm512_mul_pd(q, _mm512_sub_pd(_mm512_add_pd(_mm512_mul_pd(m, _mm512_set1_pd(mm.inv_q)), magic), magic));
  if (mm.q > 0.0) m = counts;
  if (mm.ambiguity > 0.0) m = _mm512_mask_blend_pd(_mm512_cmp_pd_mask(m, amb, _CMP_GE_OQ), m, zero);
  return m;
}

__attribute__((target("avx512f,avx512dq"))) void measureTileAvx512(const MeasureTile& t, const double* rho,
                                                                    unsigned lanes, float* out, SlowDraws& slow) {
  const std::int64_t cols = std::int64_t(t.cols);
  const __m512i lane = _mm512_set_epi64(cols + 3, cols + 2, cols + 1, cols, 3, 2, 1, 0);
  // key = stream + pixel·φ (mod 2^64) = (stream + pixel0·φ) + lane·φ: one multiply per lane per scan.
  const std::uint64_t golden = 0x9E3779B97F4A7C15ull;
  const __m512i lane_golden = _mm512_mullo_epi64(lane, _mm512_set1_epi64(std::int64_t(golden)));
  for (int h = 0; h < 2; ++h) {
    const std::uint64_t first = t.pixel0 + 2 * h * t.cols;
    const __m512i pixel = _mm512_add_epi64(_mm512_set1_epi64(std::int64_t(first)), lane);
    const __m512i key = _mm512_add_epi64(_mm512_set1_epi64(std::int64_t(noiseKey(t.stream, first))), lane_golden);
    const __m512d r = _mm512_loadu_pd(rho + 8 * h);
    const __mmask8 returns = _mm512_cmp_pd_mask(r, r, _CMP_ORD_Q);
    __m512d normal = _mm512_setzero_pd();
    if (t.noise) {
      const __m512i bits = mix64Avx512(key);
      const __m512i layer = _mm512_and_si512(bits, _mm512_set1_epi64(127));
      // signedUnit52: 2·d − 3 with d in [1, 2) assembled from the top 52 bits.
      const __m512d d = _mm512_castsi512_pd(
          _mm512_or_si512(_mm512_srli_epi64(bits, 12), _mm512_set1_epi64(0x3FF0000000000000ll)));
      const __m512d u = _mm512_sub_pd(_mm512_mul_pd(_mm512_set1_pd(2.0), d), _mm512_set1_pd(3.0));
      const __m512d ratio = _mm512_i64gather_pd(layer, t.zig->ratio, 8);
      const __m512d x = _mm512_i64gather_pd(layer, t.zig->x, 8);
      normal = _mm512_mul_pd(u, x);
      // Only a pixel that returns needs its draw: elsewhere the slow path would be wasted.
      const __mmask8 fast = _mm512_cmp_pd_mask(_mm512_abs_pd(u), ratio, _CMP_LT_OQ);
      const __mmask8 set_aside = ~fast & returns & __mmask8(lanes >> 8 * h);
      // Appended without a branch: a compressed store and a count.
      _mm512_storeu_si512(slow.pixel + slow.count, _mm512_maskz_compress_epi64(set_aside, pixel));
      _mm512_storeu_pd(slow.rho + slow.count, _mm512_maskz_compress_pd(set_aside, r));
      slow.count += __builtin_popcount(set_aside);
    }
    const __m512d m = measureAvx512(*t.measure, r, normal);
    const __m512d reported = _mm512_mask_blend_pd(returns, _mm512_set1_pd(kNaN), m);
    _mm256_storeu_ps(out + 8 * h, _mm512_cvtpd_ps(reported));
  }
}

constexpr unsigned kMiss = 0xFFFFFFFFu;

void centreHitsScalar(const float* t, const unsigned* geom, double max_range, float* true_range, int* geom_id,
                      double* rho) {
  for (int i = 0; i < 16; ++i) {
    true_range[i] = geom[i] != kMiss ? t[i] : kNaN;
    geom_id[i] = int(geom[i]);
  }
  if (rho)
    for (int i = 0; i < 16; ++i) {
      const double value = geom[i] != kMiss ? double(t[i]) : std::numeric_limits<double>::infinity();
      rho[i] = value <= max_range ? value : double(kNaN);
    }
}

__attribute__((target("avx512f,avx512dq"))) void centreHitsAvx512(const float* t, const unsigned* geom,
                                                                  double max_range, float* true_range,
                                                                  int* geom_id, double* rho) {
  const __m512i g = _mm512_loadu_si512(geom);
  const __mmask16 hit = _mm512_cmpneq_epu32_mask(g, _mm512_set1_epi32(-1));
  const __m512 tf = _mm512_loadu_ps(t);
  _mm512_storeu_ps(true_range, _mm512_mask_blend_ps(hit, _mm512_set1_ps(kNaN), tf));
  _mm512_storeu_si512(geom_id, g);
  if (!rho) return;
  const __m512d inf = _mm512_set1_pd(std::numeric_limits<double>::infinity()), nan = _mm512_set1_pd(kNaN);
  const __m512d max = _mm512_set1_pd(max_range);
  for (int h = 0; h < 2; ++h) {
    const __m512d d = _mm512_cvtps_pd(h ? _mm512_extractf32x8_ps(tf, 1) : _mm512_castps512_ps256(tf));
    const __m512d value = _mm512_mask_blend_pd(__mmask8(hit >> 8 * h), inf, d);
    _mm512_storeu_pd(rho + 8 * h, _mm512_mask_blend_pd(_mm512_cmp_pd_mask(value, max, _CMP_LE_OQ), nan, value));
  }
}

}  // namespace

void centreHits(Isa isa, const float* t, const unsigned* geom, double max_range, float* true_range, int* geom_id,
                double* rho) {
  if (isa == Isa::Avx512)
    centreHitsAvx512(t, geom, max_range, true_range, geom_id, rho);
  else
    centreHitsScalar(t, geom, max_range, true_range, geom_id, rho);
}

Isa activeIsa() {
  static const bool avx512 = cpuHasAvx512();
  return avx512 && !forced_scalar.load(std::memory_order_relaxed) ? Isa::Avx512 : Isa::Scalar;
}

void forceScalar(bool on) { forced_scalar.store(on, std::memory_order_relaxed); }

void tileDirections(Isa isa, const AngleTables& a, const double* R, int r0, int c0, int rows, int cols,
                    float* fx, float* fy, float* fz, double* dx, double* dy, double* dz) {
  if (isa == Isa::Avx512 && r0 + 4 <= rows && c0 + 4 <= cols)
    directionsAvx512(a, R, r0, c0, fx, fy, fz, dx, dy, dz);
  else
    directionsScalar(a, R, r0, c0, rows, cols, fx, fy, fz, dx, dy, dz);
}

void measureTile(Isa isa, const MeasureTile& t, const double* rho, unsigned lanes, float* reported,
                 SlowDraws& slow) {
  if (isa == Isa::Avx512)
    measureTileAvx512(t, rho, lanes, reported, slow);
  else
    measureScalar(t, rho, reported);
}

void finishSlowDraws(const MeasureTile& t, SlowDraws& slow, float* range) {
  for (int j = 0; j < slow.count; ++j) {
    const double normal = base::normalFromKey(noiseKey(t.stream, slow.pixel[j]));
    range[slow.pixel[j]] = float((*t.measure)(slow.rho[j], normal));
  }
  slow.count = 0;
}

}  // namespace ambler::sim::kernel
