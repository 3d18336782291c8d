// The locus search's common case for maps, eight cells at a time in AVX-512 (docs/locus.md,
// "Lanes"). Lane k is map cell (row, c0 + k), a vertical line. Each lane repeats, operation for
// operation, what the scalar search (locus_mapper.cpp) does when
//   - the scanline walk from the hint finds the bracket within kHintSteps steps, every sample on the
//     way valid (in front, inside the image, its pixels returned, tan θ inside the table),
//   - the bracket's 2×2 cell has all four pixels returned and no edge pixel,
//   - the Hermite estimate's probe pair falls inside that cell and closes the bracket,
// so the lane's cell gets the same bits as the scalar search would give it: the same IEEE
// additions, multiplications, divisions and square roots in the same order, no fused multiply-add
// (-ffp-contract=off), selects for branches. A lane that leaves that path is left to the scalar
// search, which starts again from the hint. ErimScanner's kernels follow the same rule.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wuninitialized"
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include <immintrin.h>
#pragma GCC diagnostic pop

#include <cstdint>

#include "perception/locus_mapper.hpp"
#include "perception/locus_sample.hpp"

namespace ambler::perception {

using namespace locus;

bool LocusMapper::lanesAvailable() {
  static const bool available = [] {
    __builtin_cpu_init();  // libgcc also checks that the OS saves the AVX-512 state
    return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512dq");
  }();
  return available;
}

namespace {

#define AMBLER_AVX512 __attribute__((target("avx512f,avx512dq"), always_inline)) inline

typedef double v8d __attribute__((vector_size(64)));
typedef long long v8l __attribute__((vector_size(64)));
typedef int v8i __attribute__((vector_size(32)));


AMBLER_AVX512 v8d splat(double x) { return v8d{x, x, x, x, x, x, x, x}; }
AMBLER_AVX512 v8i splati(int x) { return v8i{x, x, x, x, x, x, x, x}; }
AMBLER_AVX512 v8d gather(const double* base, v8i index) {
  return (v8d)_mm512_i32gather_pd((__m256i)index, base, 8);
}
AMBLER_AVX512 v8d gatherFloat(const float* base, v8i index) {
  return (v8d)_mm512_cvtps_pd(_mm256_i32gather_ps(base, (__m256i)index, 4));
}
// Bytes at base[index] (the array must have 3 bytes of padding past its end).
AMBLER_AVX512 v8i gatherByte(const std::uint8_t* base, v8i index) {
  return (v8i)_mm256_i32gather_epi32(reinterpret_cast<const int*>(base), (__m256i)index, 1) & splati(0xFF);
}
AMBLER_AVX512 v8d vsqrt(v8d x) { return (v8d)_mm512_sqrt_pd((__m512d)x); }
AMBLER_AVX512 v8d vabs(v8d x) { return (v8d)_mm512_abs_pd((__m512d)x); }
AMBLER_AVX512 v8i toInt(v8d x) { return __builtin_convertvector(x, v8i); }  // truncation, as int(x)
AMBLER_AVX512 v8d toDouble(v8i x) { return __builtin_convertvector(x, v8d); }
AMBLER_AVX512 v8l widen(v8i m) { return __builtin_convertvector(m, v8l); }  // an int mask as a double mask
AMBLER_AVX512 v8d select(v8l m, v8d a, v8d b) { return m ? a : b; }
AMBLER_AVX512 v8i selecti(v8i m, v8i a, v8i b) { return m ? a : b; }
AMBLER_AVX512 v8i narrow(v8l m) { return __builtin_convertvector(m, v8i); }
AMBLER_AVX512 bool any(v8l m) { return _mm512_test_epi64_mask((__m512i)m, (__m512i)m) != 0; }
AMBLER_AVX512 unsigned bits(v8l m) { return _mm512_test_epi64_mask((__m512i)m, (__m512i)m); }
// std::clamp(x, lo, hi) and std::min for ints.
AMBLER_AVX512 v8d clamp(v8d x, v8d lo, v8d hi) { return select(x < lo, lo, select(hi < x, hi, x)); }
AMBLER_AVX512 v8i mini(v8i a, v8i b) { return selecti(b < a, b, a); }

// A sample of Δ in eight lanes (LocusSample's numbers; `ok`: valid and on the lanes' path).
struct Lanes {
  v8d s, rho, cf, fc, delta;
  v8i c0;
  v8l ok;
};

AMBLER_AVX512 Lanes selectLanes(v8l m, const Lanes& a, const Lanes& b) {
  const v8i mi = narrow(m);
  return {select(m, a.s, b.s),         select(m, a.rho, b.rho),       select(m, a.cf, b.cf),
          select(m, a.fc, b.fc),       select(m, a.delta, b.delta),   selecti(mi, a.c0, b.c0),
          m ? a.ok : b.ok};
}

// The mapper's tables and constants as the lanes read them.
struct Ctx {
  const double *sin_phi, *cos_phi, *inv_den, *phi, *poly, *sigma, *g;
  const float* range;
  const std::uint8_t* flags;
  double bx, by, bz, limit, index_scale, step, last_col, last_row, phi0, inv_dphi, neg_inv_dphi, inv_dtheta;
  int rows, cols;
};

// (asin/atan table) AngleTable::operator() inside its range: c0 + d·(c1 + d·c2), d = t − x.
AMBLER_AVX512 v8d columnOf(const Ctx& k, v8d t, v8l in) {
  const v8i i = toInt((select(in, t, splat(0.0)) + splat(k.limit)) * splat(k.index_scale)), idx = i * splati(4);
  // The interval's middle as the table's constructor computed it (one gather fewer).
  const v8d ex = splat(-k.limit) + (toDouble(i) + splat(0.5)) * splat(k.step);
  const v8d c0 = gather(k.poly, idx + 1), c1 = gather(k.poly, idx + 2), c2 = gather(k.poly, idx + 3);
  const v8d d = t - ex;
  return c0 + d * (c1 + d * c2);
}

// LocusMapper::atRow on scanline r (per lane), for lanes whose 2×2 cell has all pixels returned.
AMBLER_AVX512 Lanes rowLanes(const Ctx& k, v8d ax, v8d ay, v8d az, v8i r) {
  Lanes out;
  const v8d sp = gather(k.sin_phi, r), cp = gather(k.cos_phi, r), inv = gather(k.inv_den, r);
  v8l ok = inv != splat(0.0);
  out.s = -(az * cp - ay * sp) * inv;
  const v8d x = ax + out.s * splat(k.bx);
  const v8d lambda = (ay + out.s * splat(k.by)) * cp + (az + out.s * splat(k.bz)) * sp;
  ok &= lambda > splat(0.0);
  out.rho = vsqrt(x * x + lambda * lambda);
  const v8d t = x / lambda;
  ok &= vabs(t) <= splat(k.limit);
  out.cf = columnOf(k, t, ok);
  ok &= (out.cf >= splat(0.0)) & (out.cf <= splat(k.last_col));
  const v8i last = r == splati(k.rows - 1);
  const v8i r0 = selecti(last, r - splati(1), r);
  out.c0 = mini(toInt(select(ok, out.cf, splat(0.0))), splati(k.cols - 2));
  out.fc = out.cf - toDouble(out.c0);
  const v8i px = selecti(narrow(ok), r * splati(k.cols) + out.c0, splati(0));
  const v8d q0 = gatherFloat(k.range, px), q1 = gatherFloat(k.range, px + splati(1));
  const v8i flags = gatherByte(k.flags, selecti(narrow(ok), r0 * splati(k.cols - 1) + out.c0, splati(0)));
  ok &= widen((flags & splati(kAllReturned)) != splati(0));
  const v8d gc = splat(1.0) - out.fc;
  out.delta = out.rho - (gc * q0 + out.fc * q1);
  out.ok = ok;
  return out;
}


// The four pixels of a 2×2 cell whose top-left pixel is at index i of the image.
struct Patch {
  v8d p00, p01, p10, p11;
};
AMBLER_AVX512 Patch patchOf(const Ctx& k, v8i i) {
  return {gatherFloat(k.range, i), gatherFloat(k.range, i + splati(1)), gatherFloat(k.range, i + splati(k.cols)),
          gatherFloat(k.range, i + splati(k.cols + 1))};
}
AMBLER_AVX512 Patch selectPatch(v8l m, const Patch& a, const Patch& b) {
  return {select(m, a.p00, b.p00), select(m, a.p01, b.p01), select(m, a.p10, b.p10), select(m, a.p11, b.p11)};
}

struct Line8 {
  v8d ax, ay, az, bx, by, bz;
};

// A sample between scanlines and the scan plane's sine and cosine it was taken on.
struct PhiSample {
  Lanes m;
  v8d sp, cp;
};

// LocusMapper::atPhi(line, r1, φ) (sinCosNear, then evaluate), for samples inside the 2×2 cell
// (r1, ca) or (r1, cb), whose pixels are pa and pb (returned, no edge pixels).
AMBLER_AVX512 PhiSample atPhiLanes(const Ctx& k, const Line8& l, v8i r1, v8d phi1, v8d sr, v8d cr, v8d phi, v8i ca,
                                   v8i cb, const Patch& pa, const Patch& pb) {
  PhiSample out;
  const v8d delta = phi1 - phi, d2 = delta * delta;
  const v8d sd = delta * (splat(1.0) - d2 * splat(kInv6) * (splat(1.0) - d2 * splat(kInv20)));
  const v8d cd = splat(1.0) - d2 * splat(0.5) * (splat(1.0) - d2 * splat(kInv12) * (splat(1.0) - d2 * splat(kInv30)));
  const v8d sp = sr * cd - cr * sd, cp = cr * cd + sr * sd;
  out.sp = sp, out.cp = cp;
  const v8d den = l.bz * cp - l.by * sp;
  v8l ok = vabs(den) >= splat(1e-15);
  const v8d inv = splat(1.0) / den;
  const v8d rf = (splat(k.phi0) - phi) * splat(k.inv_dphi);
  Lanes& m = out.m;
  m.s = -(l.az * cp - l.ay * sp) * inv;
  const v8d x = l.ax + m.s * l.bx;
  const v8d lambda = (l.ay + m.s * l.by) * cp + (l.az + m.s * l.bz) * sp;
  ok &= lambda > splat(0.0);
  m.rho = vsqrt(x * x + lambda * lambda);
  const v8d t = x / lambda;
  ok &= vabs(t) <= splat(k.limit);
  m.cf = columnOf(k, t, ok);
  ok &= (m.cf >= splat(0.0)) & (m.cf <= splat(k.last_col)) & (rf >= splat(0.0)) & (rf <= splat(k.last_row));
  const v8i r0 = mini(toInt(select(ok, rf, splat(0.0))), splati(k.rows - 2));
  m.c0 = mini(toInt(select(ok, m.cf, splat(0.0))), splati(k.cols - 2));
  ok &= widen(r0 == r1) & widen((m.c0 == ca) | (m.c0 == cb));  // inside the bracket's cells
  const Patch p = selectPatch(widen(m.c0 == ca), pa, pb);
  const v8d fr = rf - toDouble(r0);
  m.fc = m.cf - toDouble(m.c0);
  const v8d gr = splat(1.0) - fr, gc = splat(1.0) - m.fc;
  m.delta = m.rho - (gr * (gc * p.p00 + m.fc * p.p01) + fr * (gc * p.p10 + m.fc * p.p11));
  m.ok = ok;
  return out;
}

}  // namespace

__attribute__((target("avx512f,avx512dq"))) unsigned LocusMapper::mapLanes(const MapGrid& grid, int row, int c0,
                                                                             int n, int hint, CellResult* out) const {
  static_assert(sizeof(CellSigma) == 5 * sizeof(double), "CellSigma is gathered as five doubles");
  static_assert(sizeof(AngleTable::Poly) == 4 * sizeof(double), "Poly is gathered as four doubles");
  if (hint < 0 || hint + 1 >= rows_ || config_.bisection) return 0;
  Ctx k{};
  k.sin_phi = sin_phi_.data(), k.cos_phi = cos_phi_.data(), k.inv_den = vertical_inv_den_.data();
  k.phi = image_.phi.data(), k.poly = &column_of_.polys[0].x, k.sigma = &cell_sigma_[0].normal.x();
  k.g = roughness_g_.data(), k.range = image_.range.data(), k.flags = cell_flags_.data();
  k.bx = up_.x(), k.by = up_.y(), k.bz = up_.z();
  k.limit = column_of_.limit, k.index_scale = column_of_.index_scale, k.step = column_of_.step;
  k.last_col = last_col_, k.last_row = last_row_, k.phi0 = phi0_, k.inv_dphi = inv_dphi_;
  k.neg_inv_dphi = -1.0 / dphi_, k.inv_dtheta = inv_dtheta_;
  k.rows = rows_, k.cols = cols_;

  // The lines: u = grid.center(row, c), a = R·u + t (LocusMapper::lineOf).
  const v8i lane{0, 1, 2, 3, 4, 5, 6, 7};
  const v8d ux = splat(grid.x_min) + (toDouble(splati(c0) + lane) + splat(0.5)) * splat(grid.cell);
  const double uy = grid.y_max - (row + 0.5) * grid.cell;
  const Eigen::Matrix3d& R = rot_SW_;
  v8d a[3];
  for (int i = 0; i < 3; ++i)
    a[i] = ((splat(R(i, 0)) * ux + splat(R(i, 1) * uy)) + splat(R(i, 2) * 0.0)) + splat(trans_SW_[i]);
  const v8d ax = a[0], ay = a[1], az = a[2];

  // Stage 1: the scanline pair at the hint, then the walk in the direction Δ says.
  v8i r = splati(hint);
  Lanes up = rowLanes(k, ax, ay, az, r), down = rowLanes(k, ax, ay, az, r + splati(1));
  v8l active = up.ok & down.ok;
  v8l found = active & (up.delta < splat(0.0)) & (down.delta >= splat(0.0));
  const v8i step = selecti(narrow(down.delta < splat(0.0)), splati(1), splati(-1));
  for (int it = 0; it < kHintSteps; ++it) {
    v8l walking = active & ~found;
    if (!any(walking)) break;
    const v8l downward = widen(step > splati(0));
    // The scalar walk stops (and the clip walk takes over) at the image's first or last scanline.
    const v8l inside = widen(selecti(narrow(downward), r + splati(2) < splati(rows_), r - splati(1) >= splati(0)));
    active &= ~walking | inside;
    walking &= inside;
    const v8i wi = narrow(walking);
    r = selecti(wi, r + step, r);
    const v8i at = selecti(wi, selecti(narrow(downward), r + splati(1), r), splati(hint));
    const Lanes fresh = rowLanes(k, ax, ay, az, at);
    const Lanes new_up = selectLanes(walking & downward, down, selectLanes(walking, fresh, up));
    const Lanes new_down = selectLanes(walking & downward, fresh, selectLanes(walking, up, down));
    up = new_up, down = new_down;
    active &= ~walking | (up.ok & down.ok);
    found |= walking & active & (up.delta < splat(0.0)) & (down.delta >= splat(0.0));
  }
  v8l ok = active & found & widen(lane < splati(n));  // lanes past the row's end are not cells
  if (!any(ok)) return 0;

  // Stage 2, the first estimate (intersect): the bracket's 2×2 patches (one, or two next to each
  // other where the line crosses a column boundary) returned and without edge pixels.
  const v8i r1 = r, r2 = r + splati(1);
  const v8i ca = up.c0, cb = down.c0;
  const v8l cross = widen(ca != cb);
  const v8i okc = narrow(ok);
  ok &= widen(gatherByte(k.flags, selecti(okc, r1 * splati(cols_ - 1) + ca, splati(0))) == splati(kAllReturned));
  ok &= widen(gatherByte(k.flags, selecti(okc, r1 * splati(cols_ - 1) + cb, splati(0))) == splati(kAllReturned));
  ok &= (up.delta < splat(0.0)) & (down.delta > splat(0.0));
  ok &= ~cross | widen((ca - cb == splati(1)) | (cb - ca == splati(1)));
  Patch pa_patch = patchOf(k, selecti(narrow(ok), r1 * splati(cols_) + ca, splati(0)));
  Patch pb_patch = patchOf(k, selecti(narrow(ok), r1 * splati(cols_) + cb, splati(0)));
  const v8d phi1 = gather(k.phi, r1), phi2 = gather(k.phi, r2);
  const v8d sr = gather(k.sin_phi, r1), cr = gather(k.cos_phi, r1);
  const v8d bx = splat(k.bx), by = splat(k.by), bz = splat(k.bz);
  const Line8 line{ax, ay, az, bx, by, bz};
  // Across a column boundary: Δ where the chord of the column coordinate meets it, taken into
  // the bracket.
  const v8d boundary = toDouble(selecti(cb < ca, ca, cb));
  const v8d phi_b = phi1 + (boundary - up.cf) / (down.cf - up.cf) * (phi2 - phi1);
  ok &= ~cross | ((phi_b - phi1) * (phi_b - phi2) < splat(0.0));
  const PhiSample mid = atPhiLanes(k, line, r1, phi1, sr, cr, phi_b, ca, cb, pa_patch, pb_patch);
  ok &= ~cross | mid.m.ok;
  const v8l mid_lo = cross & (mid.m.delta < splat(0.0));  // [φ_b, φ(r2)]: r2's patch
  const v8l mid_hi = cross & ~mid_lo;                      // [φ(r1), φ_b]: r1's patch
  v8d phi_lo = select(mid_lo, phi_b, phi1), phi_hi = select(mid_hi, phi_b, phi2);
  const Lanes lo0 = selectLanes(mid_lo, mid.m, up), hi0 = selectLanes(mid_hi, mid.m, down);
  ok &= (lo0.delta < splat(0.0)) & (hi0.delta > splat(0.0));
  const v8i c_patch = selecti(narrow(mid_lo), cb, ca);
  const Patch patch = selectPatch(widen(c_patch == ca), pa_patch, pb_patch);
  // dΔ/dφ at both ends in that patch (LocusMapper::slopeInPatch).
  v8d g[2];
  for (int e = 0; e < 2; ++e) {
    const Lanes& m = e == 0 ? lo0 : hi0;
    const v8l at_mid = e == 0 ? mid_lo : mid_hi;
    const v8i rr = e == 0 ? r1 : r2;
    const v8d sp = select(at_mid, mid.sp, gather(k.sin_phi, rr)), cp = select(at_mid, mid.cp, gather(k.cos_phi, rr));
    const v8d inv_den = select(at_mid, splat(1.0) / (bz * mid.cp - by * mid.sp), gather(k.inv_den, rr));
    const v8d fr = select(at_mid, (splat(k.phi0) - phi_b) * splat(k.inv_dphi) - toDouble(r1), splat(double(e)));
    const v8d fc = select(at_mid | widen(m.c0 != c_patch), m.cf - toDouble(c_patch), m.fc);
    const v8d top = (splat(1.0) - fc) * patch.p00 + fc * patch.p01, bottom = (splat(1.0) - fc) * patch.p10 + fc * patch.p11;
    const v8d dI_dfr = bottom - top, dI_dfc = (splat(1.0) - fr) * (patch.p01 - patch.p00) + fr * (patch.p11 - patch.p10);
    const v8d dnum = -az * sp - ay * cp, dden = -bz * sp - by * cp;
    const v8d ds = -(dnum + m.s * dden) * inv_den;
    const v8d qx = ax + m.s * bx, qy = ay + m.s * by, qz = az + m.s * bz;
    const v8d lateral = qy * cp + qz * sp;
    const v8d inv = splat(1.0) / (m.rho * lateral);
    const v8d drho = ((qx * bx + qy * by) + qz * bz) * ds * lateral * inv;
    const v8d dtheta = (bx * ds * m.rho - qx * drho) * inv;
    g[e] = drho - (dI_dfr * splat(k.neg_inv_dphi) + dI_dfc * dtheta * splat(k.inv_dtheta));
  }
  // LocusMapper::hermiteRoot.
  const v8d h = phi_hi - phi_lo;
  const v8d y0 = lo0.delta, y1 = hi0.delta;
  const v8d m0 = g[0] * h, m1 = g[1] * h;
  const v8d c2 = splat(-3.0) * y0 - splat(2.0) * m0 + splat(3.0) * y1 - m1;
  const v8d c3 = splat(2.0) * y0 + m0 - splat(2.0) * y1 + m1;
  v8d t = y0 / (y0 - y1), t_neg = splat(0.0), t_pos = splat(1.0);
  for (int it = 0; it < 2; ++it) {
    const v8d H = y0 + t * (m0 + t * (c2 + t * c3)), dH = m0 + t * (splat(2.0) * c2 + splat(3.0) * t * c3);
    const v8l neg = H < splat(0.0);
    t_neg = select(neg, t, t_neg);
    t_pos = select(neg, t_pos, t);
    const v8d next = t - H / dH;
    t = select((next - t_neg) * (next - t_pos) < splat(0.0), next, splat(0.5) * (t_neg + t_pos));
  }
  const v8d first = phi_lo + t * h;
  const double eps = config_.epsilon_rad;
  ok &= vabs(phi_hi - phi_lo) >= splat(2 * eps);

  // The probe pair (intersect's probePair): pa the one nearer φ_lo.
  const v8d hp = splat(0.499 * eps);
  v8d pa = first - hp, pb = first + hp;
  const v8l swap = vabs(pa - phi_lo) > vabs(pb - phi_lo);
  const v8d pa0 = pa;
  pa = select(swap, pb, pa), pb = select(swap, pa0, pb);
  ok &= ((pa - phi_lo) * (pa - phi_hi) < splat(0.0)) & ((pb - phi_lo) * (pb - phi_hi) < splat(0.0));
  const PhiSample probe_a = atPhiLanes(k, line, r1, phi1, sr, cr, pa, ca, cb, pa_patch, pb_patch);
  const PhiSample probe_b = atPhiLanes(k, line, r1, phi1, sr, cr, pb, ca, cb, pa_patch, pb_patch);
  const Lanes probe[2] = {probe_a.m, probe_b.m};
  const Lanes& lo = probe[0];
  const Lanes& hi = probe[1];
  // The bracket closes: Δ(pa) < 0 ≤ Δ(pb), and intersect's loop would stop.
  ok &= lo.ok & hi.ok & (lo.delta < splat(0.0)) & (hi.delta >= splat(0.0));
  ok &= ~((vabs(pb - pa) >= splat(eps)) & (hi.delta != splat(0.0)));
  if (!any(ok)) return 0;

  // LocusMapper::finish (no edge pixel: the cell is known) and sigmaAlongLine.
  const v8d phi = pa - lo.delta * (pb - pa) / (hi.delta - lo.delta);
  const v8d tt = (phi - pa) / (pb - pa);
  const v8d s = lo.s + tt * (hi.s - lo.s);
  const v8d z = splat(0.0) + s * splat(1.0);
  const v8d cf = lo.cf + tt * (hi.cf - lo.cf);
  const v8i c_cell = selecti(narrow(ok), selecti(toInt(cf) < splati(0), splati(0), mini(toInt(cf), splati(cols_ - 2))),
                             splati(0));
  const v8d rho = lo.rho + tt * (hi.rho - lo.rho);
  const v8d fr = clamp((splat(k.phi0) - phi) * splat(k.inv_dphi) - toDouble(r1), splat(0.0), splat(1.0));
  const v8d fc = clamp(cf - toDouble(c_cell), splat(0.0), splat(1.0));
  const v8d qx = ax + s * bx, qy = ay + s * by, qz = az + s * bz;
  const v8d gr = splat(1.0) - fr, gc = splat(1.0) - fc;
  const v8d sum_w2 = (gr * gr + fr * fr) * (gc * gc + fc * fc);
  const v8d noise = splat(config_.noise_k) * rho * rho;
  const v8d var_pixel = noise * noise + splat(quantization_var_);
  const v8i cs = selecti(narrow(ok), (r1 * splati(cols_ - 1) + c_cell) * splati(5), splati(0));
  const v8d nx = gather(k.sigma, cs), ny = gather(k.sigma, cs + splati(1)), nz = gather(k.sigma, cs + splati(2));
  v8d rough = splat(0.0);
  for (int e = 0; e < 2; ++e) {  // roughnessVariance across scanlines (fr), then along them (fc)
    const v8d mean_d2 = gather(k.sigma, cs + splati(3 + e));
    const v8d f = e == 0 ? fr : fc;
    const v8d x = select(ok, f * splat(double(kRoughnessSteps)), splat(0.0));
    const v8i i = mini(toInt(x), splati(kRoughnessSteps - 1));
    const v8d g0 = gather(k.g, i), g1 = gather(k.g, i + splati(1));
    const v8d g = g0 + (x - toDouble(i)) * (g1 - g0);
    const v8d excess = mean_d2 - splat(6.0) * var_pixel;
    const v8d term = g * select(splat(0.0) < excess, excess, splat(0.0));
    rough = e == 0 ? select(mean_d2 != mean_d2, splat(0.0), term)
                   : rough + select(mean_d2 != mean_d2, splat(0.0), term);
  }
  const v8d var_rho = var_pixel * sum_w2 + rough;
  const v8d pn = (qx * nx + qy * ny) + qz * nz, bn = (bx * nx + by * ny) + bz * nz;
  const v8d abs_bn = vabs(bn);
  const v8d sigma = vsqrt(var_rho) * vabs(pn) / (rho * select(abs_bn < splat(0.05), splat(0.05), abs_bn));

  const unsigned done = bits(ok);
  alignas(64) double zs[8], sigmas[8];
  alignas(32) int brackets[8];
  _mm512_store_pd(zs, (__m512d)z);
  _mm512_store_pd(sigmas, (__m512d)sigma);
  _mm256_store_si256(reinterpret_cast<__m256i*>(brackets), (__m256i)r1);
  for (int l = 0; l < kLanes; ++l)
    if (done >> l & 1u) out[l] = {CellState::Known, float(zs[l]), float(sigmas[l]), brackets[l]};
  return done;
}

}  // namespace ambler::perception
