// The locus search's common case for maps, several cells at a time in SIMD lanes (docs/locus.md,
// "Maps: groups of eight and the lanes"): eight AVX-512 lanes, or two passes of four AVX2 lanes.
// Lane j is map cell (row, c0 + j), a vertical line. Each lane repeats, operation for operation,
// what the scalar search (locus_mapper.cpp) does when
//   - the scanline walk from the hint finds the bracket within kHintSteps steps, every sample on
//     the way valid (in front, inside the image, its pixels returned, tan θ inside the table),
//   - the bracket's 2×2 cells (one, or two where the line crosses a column boundary) have all
//     four pixels returned and no edge pixel,
//   - the first estimate's probe pair falls inside those cells and closes the bracket,
// so the lane's cell gets the same bits as the scalar search would give it: the same IEEE
// additions, multiplications, divisions and square roots in the same order, no fused multiply-add
// (-ffp-contract=off), gathers for table lookups, selects for branches. A lane that leaves that
// path is left to the scalar search, which starts again from the hint. ErimScanner's kernels
// follow the same rule. The kernel is written once (locus_lanes_kernel.inc) and compiled here for
// each ISA.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wuninitialized"
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include <immintrin.h>
#pragma GCC diagnostic pop

#include <atomic>
#include <cstdint>

#include "perception/locus_mapper.hpp"
#include "perception/locus_sample.hpp"

namespace ambler::perception {

using namespace locus;

namespace {

std::atomic<int> g_lane_cap{int(LaneIsa::Avx512)};

LaneIsa detectLaneIsa() {
  __builtin_cpu_init();  // libgcc also checks that the OS saves the AVX/AVX-512 state
  if (__builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512dq")) return LaneIsa::Avx512;
  if (__builtin_cpu_supports("avx2")) return LaneIsa::Avx2;
  return LaneIsa::None;
}

// The mapper's tables and constants as the lanes read them, and the map row's geometry.
struct Ctx {
  const double *sin_phi, *cos_phi, *inv_den, *phi, *poly, *sigma, *g;
  const float* range;
  const float* above_min;  // LocusMapper::above_min_ (clearAbove)
  const std::uint8_t* flags;
  double bx, by, bz, limit, index_scale, step, last_col, last_row, phi0, inv_dphi, neg_inv_dphi, inv_dtheta;
  double eps, noise_k, qvar;
  double R[3][3], t[3];   // T_SW
  double x_min, cell, uy;  // the map row: cell c's centre is (x_min + (c + 0.5)·cell, uy)
  double s_top, s_bottom, box_x0, box_x1;  // the returns' bounds: the vertical lines' clip
  int rows, cols, hint, above_levels;
};

// What the lanes finished, by lane of the group.
struct Out {
  double z[LocusMapper::kLanes], sigma[LocusMapper::kLanes];
  int bracket[LocusMapper::kLanes];
};

}  // namespace

#pragma GCC push_options
#pragma GCC target("avx512f,avx512dq")
namespace lanes_avx512 {
namespace {
#define AMBLER_LANE_FN __attribute__((always_inline)) inline
constexpr int kWidth = 8;
typedef double vd __attribute__((vector_size(64)));
typedef long long vl __attribute__((vector_size(64)));
typedef int vi __attribute__((vector_size(32)));
AMBLER_LANE_FN vd splat(double x) { return vd{} + x; }
AMBLER_LANE_FN vi splati(int x) { return vi{} + x; }
AMBLER_LANE_FN vi iota() { return vi{0, 1, 2, 3, 4, 5, 6, 7}; }
AMBLER_LANE_FN vd gather(const double* base, vi index) { return (vd)_mm512_i32gather_pd((__m256i)index, base, 8); }
AMBLER_LANE_FN vd gatherFloat(const float* base, vi index) {
  return (vd)_mm512_cvtps_pd(_mm256_i32gather_ps(base, (__m256i)index, 4));
}
// Bytes at base[index] (the array has 3 bytes of padding past its end).
AMBLER_LANE_FN vi gatherByte(const std::uint8_t* base, vi index) {
  return (vi)_mm256_i32gather_epi32(reinterpret_cast<const int*>(base), (__m256i)index, 1) & splati(0xFF);
}
AMBLER_LANE_FN vd vsqrt(vd x) { return (vd)_mm512_sqrt_pd((__m512d)x); }
AMBLER_LANE_FN vd vabs(vd x) { return (vd)_mm512_abs_pd((__m512d)x); }
AMBLER_LANE_FN unsigned bits(vl m) { return _mm512_test_epi64_mask((__m512i)m, (__m512i)m); }
AMBLER_LANE_FN bool any(vl m) { return bits(m) != 0; }
AMBLER_LANE_FN void store(double* p, vd x) { _mm512_store_pd(p, (__m512d)x); }
AMBLER_LANE_FN void storei(int* p, vi x) { _mm256_store_si256(reinterpret_cast<__m256i*>(p), (__m256i)x); }
#include "perception/locus_lanes_kernel.inc"
#undef AMBLER_LANE_FN
}  // namespace
}  // namespace lanes_avx512
#pragma GCC pop_options

#pragma GCC push_options
#pragma GCC target("avx2")
namespace lanes_avx2 {
namespace {
#define AMBLER_LANE_FN __attribute__((always_inline)) inline
constexpr int kWidth = 4;
typedef double vd __attribute__((vector_size(32)));
typedef long long vl __attribute__((vector_size(32)));
typedef int vi __attribute__((vector_size(16)));
AMBLER_LANE_FN vd splat(double x) { return vd{} + x; }
AMBLER_LANE_FN vi splati(int x) { return vi{} + x; }
AMBLER_LANE_FN vi iota() { return vi{0, 1, 2, 3}; }
AMBLER_LANE_FN vd gather(const double* base, vi index) { return (vd)_mm256_i32gather_pd(base, (__m128i)index, 8); }
AMBLER_LANE_FN vd gatherFloat(const float* base, vi index) {
  return (vd)_mm256_cvtps_pd(_mm_i32gather_ps(base, (__m128i)index, 4));
}
AMBLER_LANE_FN vi gatherByte(const std::uint8_t* base, vi index) {
  return (vi)_mm_i32gather_epi32(reinterpret_cast<const int*>(base), (__m128i)index, 1) & splati(0xFF);
}
AMBLER_LANE_FN vd vsqrt(vd x) { return (vd)_mm256_sqrt_pd((__m256d)x); }
AMBLER_LANE_FN vd vabs(vd x) { return (vd)_mm256_andnot_pd(_mm256_set1_pd(-0.0), (__m256d)x); }  // fabs's bits
AMBLER_LANE_FN unsigned bits(vl m) { return unsigned(_mm256_movemask_pd((__m256d)m)); }
AMBLER_LANE_FN bool any(vl m) { return bits(m) != 0; }
AMBLER_LANE_FN void store(double* p, vd x) { _mm256_store_pd(p, (__m256d)x); }
AMBLER_LANE_FN void storei(int* p, vi x) { _mm_store_si128(reinterpret_cast<__m128i*>(p), (__m128i)x); }
#include "perception/locus_lanes_kernel.inc"
#undef AMBLER_LANE_FN
}  // namespace
}  // namespace lanes_avx2
#pragma GCC pop_options

LaneIsa LocusMapper::laneIsa() {
  static const LaneIsa detected = detectLaneIsa();
  return LaneIsa(std::min(int(detected), g_lane_cap.load()));
}

LaneIsaCap::LaneIsaCap(LaneIsa cap) : previous_(LaneIsa(g_lane_cap.exchange(int(cap)))) {}
LaneIsaCap::~LaneIsaCap() { g_lane_cap = int(previous_); }

unsigned LocusMapper::mapLanes(LaneIsa isa, const MapGrid& grid, int row, int c0, int n, int hint,
                               CellResult* out) const {
  static_assert(sizeof(CellSigma) == 5 * sizeof(double), "CellSigma is gathered as five doubles");
  static_assert(sizeof(AngleTable::Poly) == 4 * sizeof(double), "Poly is gathered as four doubles");
  if (hint < 0 || hint + 1 >= rows_ || config_.bisection || isa == LaneIsa::None) return 0;
  const double uy = grid.y_max - (row + 0.5) * grid.cell;
  if (bounds_.isEmpty() || uy < bounds_.min().y() || uy > bounds_.max().y()) return 0;  // the walk decides
  Ctx k{};
  k.sin_phi = sin_phi_.data(), k.cos_phi = cos_phi_.data(), k.inv_den = vertical_inv_den_.data();
  k.phi = image_.phi.data(), k.poly = &column_of_.polys[0].x, k.sigma = &cell_sigma_[0].normal.x();
  k.g = roughness_g_.data(), k.range = image_.range.data(), k.flags = cell_flags_.data();
  k.above_min = above_min_.data(), k.above_levels = above_levels_;
  k.s_top = bounds_.max().z(), k.s_bottom = bounds_.min().z();  // u.z = 0: clipToBox's s for v = z
  k.box_x0 = bounds_.min().x(), k.box_x1 = bounds_.max().x();
  k.bx = up_.x(), k.by = up_.y(), k.bz = up_.z();
  k.limit = column_of_.limit, k.index_scale = column_of_.index_scale, k.step = column_of_.step;
  k.last_col = last_col_, k.last_row = last_row_, k.phi0 = phi0_, k.inv_dphi = inv_dphi_;
  k.neg_inv_dphi = -1.0 / dphi_, k.inv_dtheta = inv_dtheta_;
  k.eps = config_.epsilon_rad, k.noise_k = sensor_.noise_k, k.qvar = quantization_var_;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) k.R[i][j] = rot_SW_(i, j);
    k.t[i] = trans_SW_[i];
  }
  k.x_min = grid.x_min, k.cell = grid.cell, k.uy = uy;
  k.rows = rows_, k.cols = cols_, k.hint = hint;
  Out o;
  unsigned done = 0;
  if (isa == LaneIsa::Avx512) {
    done = lanes_avx512::run(k, c0, n, o, 0);
  } else {
    done = lanes_avx2::run(k, c0, std::min(n, 4), o, 0);
    if (n > 4) done |= lanes_avx2::run(k, c0 + 4, n - 4, o, 4) << 4;
  }
  for (int j = 0; j < n; ++j)
    if (done >> j & 1u) out[j] = {CellState::Known, float(o.z[j]), float(o.sigma[j]), o.bracket[j]};
  return done;
}

}  // namespace ambler::perception
