// The locus search (docs/locus.md): brackets, the Hermite estimate and the probe pair, the
// range-shadow decision, maps. The per-image tables and σ are in locus_tables.cpp.
#include "perception/locus_mapper.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "perception/locus_sample.hpp"

namespace ambler::perception {

using namespace locus;
using Sample = LocusSample;

namespace {

// The part [s0, s1] of the line u + s·v inside `box` (slab method); false if it misses.
bool clipToBox(const Eigen::AlignedBox3d& box, const Eigen::Vector3d& u, const Eigen::Vector3d& v,
               double& s0, double& s1) {
  if (v.x() == 0.0 && v.y() == 0.0 && v.z() == 1.0) {  // a map's vertical line: the loop below, unrolled
    if (u.x() < box.min().x() || u.x() > box.max().x() || u.y() < box.min().y() || u.y() > box.max().y()) return false;
    s0 = box.min().z() - u.z();  // (min − u)/1: the same bits
    s1 = box.max().z() - u.z();
    return s0 <= s1;
  }
  s0 = -std::numeric_limits<double>::infinity();
  s1 = std::numeric_limits<double>::infinity();
  for (int i = 0; i < 3; ++i) {
    if (std::abs(v[i]) < 1e-15) {
      if (u[i] < box.min()[i] || u[i] > box.max()[i]) return false;
      continue;
    }
    double a = (box.min()[i] - u[i]) / v[i], b = (box.max()[i] - u[i]) / v[i];
    if (a > b) std::swap(a, b);
    s0 = std::max(s0, a);
    s1 = std::min(s1, b);
  }
  return s0 <= s1;
}

// Crossing-number point-in-polygon test.
bool insidePolygon(const std::vector<Eigen::Vector2d>& poly, const Eigen::Vector2d& p) {
  bool inside = false;
  for (std::size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++) {
    const auto& a = poly[i];
    const auto& b = poly[j];
    if ((a.y() > p.y()) != (b.y() > p.y()) &&
        p.x() < (b.x() - a.x()) * (p.y() - a.y()) / (b.y() - a.y()) + a.x())
      inside = !inside;
  }
  return inside;
}

// sin and cos of φ_r − δ for |δ| within a scanline (≤ 0.01 rad): angle addition with Taylor series
// of sin δ and cos δ to δ⁵ and δ⁶ (error < 1e-16), cheaper than a libm call per evaluation. The
// lanes (locus_lanes.cpp) do the same operations.
void sinCosNear(double sr, double cr, double delta, double& sp, double& cp) {
  const double d2 = delta * delta;
  const double sd = delta * (1 - d2 * kInv6 * (1 - d2 * kInv20));
  const double cd = 1 - d2 * 0.5 * (1 - d2 * kInv12 * (1 - d2 * kInv30));
  sp = sr * cd - cr * sd;
  cp = cr * cd + sr * sd;
}

}  // namespace

Sample LocusMapper::evaluate(const Line& l, double rf, double sp, double cp, double inv_den) const {
  Sample out;
  if (inv_den == 0.0) return out;  // the line is parallel to the scan plane
  // The point of the line on the plane of scan angle φ, z·cosφ − y·sinφ = 0. There, (y, z) =
  // λ·(cosφ, sinφ) with λ = y·cosφ + z·sinφ = ρ·cosθ, so ρ = √(x² + λ²) and tan θ = x/λ: the
  // square root and the division do not wait for each other.
  out.s = -(l.a.z() * cp - l.a.y() * sp) * inv_den;
  const double x = l.a.x() + out.s * l.b.x();
  const double lambda = (l.a.y() + out.s * l.b.y()) * cp + (l.a.z() + out.s * l.b.z()) * sp;
  if (!(lambda > 0)) return out;  // behind the sensor
  out.rho = std::sqrt(x * x + lambda * lambda);
  out.column = column_of_(x / lambda);
  const double column = out.column;
  if (!(column >= 0.0 && column <= last_col_) || !(rf >= 0.0 && rf <= last_row_)) return out;
  out.r0 = std::min(int(rf), rows_ - 2);
  out.c0 = std::min(int(column), cols_ - 2);
  out.fr = rf - out.r0;
  out.fc = column - out.c0;
  const float* px = image_.range.data() + std::size_t(out.r0) * cols_ + out.c0;
  const unsigned flags = cell_flags_[cellIndex(out.r0, out.c0)];
  const double gr = 1 - out.fr, gc = 1 - out.fc;
  if (flags & kAllReturned) {  // the common case: all four pixels returned
    out.delta = out.rho - (gr * (gc * px[0] + out.fc * px[1]) + out.fr * (gc * px[cols_] + out.fc * px[cols_ + 1]));
    if (flags & 15u) {  // edge pixels: only those with weight count (bit k of `used`: w_k ≠ 0)
      const unsigned rows_used = (gr != 0.0 ? 3u : 0u) | (out.fr != 0.0 ? 12u : 0u);
      const unsigned cols_used = (gc != 0.0 ? 5u : 0u) | (out.fc != 0.0 ? 10u : 0u);
      out.edges = flags & rows_used & cols_used;
    }
    out.valid = true;
    return out;
  }
  const double w[4] = {gr * gc, gr * out.fc, out.fr * gc, out.fr * out.fc};
  const double q[4] = {px[0], px[1], px[cols_], px[cols_ + 1]};
  double I = 0;
  for (int k = 0; k < 4; ++k) {
    if (w[k] == 0.0) continue;  // a pixel with no weight is not used, returned or not
    if (!std::isfinite(q[k])) return out;  // never bridge a pixel that returned nothing
    I += w[k] * q[k];
    out.edges |= flags & (1u << k);
  }
  out.delta = out.rho - I;
  out.valid = true;
  return out;
}

double LocusMapper::slope(const Line& l, double sp, double cp, double inv_den, const Sample& m, double dI_dfr,
                          double dI_dfc) const {
  const double dnum = -l.a.z() * sp - l.a.y() * cp, dden = -l.b.z() * sp - l.b.y() * cp;
  const double ds = -(dnum + m.s * dden) * inv_den;  // s = −N/D, so s' = −(N' + s·D')/D
  const double px = l.a.x() + m.s * l.b.x(), py = l.a.y() + m.s * l.b.y(), pz = l.a.z() + m.s * l.b.z();
  const double lateral = py * cp + pz * sp;  // ρ·cos θ, on the scan plane
  const double inv = 1.0 / (m.rho * lateral);
  const double drho = (px * l.b.x() + py * l.b.y() + pz * l.b.z()) * ds * lateral * inv;  // p·b·s'/ρ
  const double dtheta = (l.b.x() * ds * m.rho - px * drho) * inv;
  // Rows run down as φ falls: dfr/dφ = −1/Δφ; dfc/dφ = θ'/Δθ.
  return drho - (dI_dfr * (-1.0 / dphi_) + dI_dfc * dtheta * inv_dtheta_);
}

// evaluate() at a scanline, rf = r: the weights of the other row are 0, so only row r's two pixels
// are read (the same value and the same edge bits as evaluate() gives there).
Sample LocusMapper::atRow(const Line& l, int r) const {
  Sample out;
  const double sp = sin_phi_[r], cp = cos_phi_[r];
  double inv_den;
  if (l.inv_den) {
    inv_den = l.inv_den[r];
  } else {
    const double den = l.b.z() * cp - l.b.y() * sp;
    inv_den = std::abs(den) < 1e-15 ? 0.0 : 1.0 / den;
  }
  if (inv_den == 0.0) return out;
  out.s = -(l.a.z() * cp - l.a.y() * sp) * inv_den;
  const double x = l.a.x() + out.s * l.b.x();
  const double lambda = (l.a.y() + out.s * l.b.y()) * cp + (l.a.z() + out.s * l.b.z()) * sp;
  if (!(lambda > 0)) return out;
  out.rho = std::sqrt(x * x + lambda * lambda);
  const double column = column_of_(x / lambda);
  out.column = column;
  if (!(column >= 0.0 && column <= last_col_)) return out;
  const bool bottom = r == rows_ - 1;  // the last scanline: the bottom row of the cell above it
  out.r0 = bottom ? r - 1 : r;
  out.fr = bottom ? 1.0 : 0.0;
  out.c0 = std::min(int(column), cols_ - 2);
  out.fc = column - out.c0;
  const float* px = image_.range.data() + std::size_t(r) * cols_ + out.c0;
  const unsigned flags = cell_flags_[cellIndex(out.r0, out.c0)];
  const unsigned used = (bottom ? 12u : 3u) & ((out.fc != 1.0 ? 5u : 0u) | (out.fc != 0.0 ? 10u : 0u));
  const double q0 = px[0], q1 = px[1], gc = 1 - out.fc;
  double I;
  if (flags & kAllReturned) {
    I = gc * q0 + out.fc * q1;
  } else {  // a pixel with no weight is not used; one that returned nothing is never bridged
    I = 0;
    if (gc != 0.0) {
      if (!std::isfinite(q0)) return out;
      I += gc * q0;
    }
    if (out.fc != 0.0) {
      if (!std::isfinite(q1)) return out;
      I += out.fc * q1;
    }
  }
  out.delta = out.rho - I;
  out.edges = flags & used;
  out.valid = true;
  return out;
}

Sample LocusMapper::atPhi(const Line& l, int r_ref, double phi) const {
  double sp, cp;
  sinCosNear(sin_phi_[r_ref], cos_phi_[r_ref], image_.phi[r_ref] - phi, sp, cp);
  const double den = l.b.z() * cp - l.b.y() * sp;
  return evaluate(l, (phi0_ - phi) * inv_dphi_, sp, cp, std::abs(den) < 1e-15 ? 0.0 : 1.0 / den);
}

LocusMapper::Line LocusMapper::lineOf(const Eigen::Vector3d& u, const Eigen::Vector3d& v) const {
  const bool vertical = v.x() == 0.0 && v.y() == 0.0 && v.z() == 1.0;
  const Eigen::Matrix3d& R = rot_SW_;
  const double ux = u.x(), uy = u.y(), uz = u.z();
  Line l;
  l.a = Eigen::Vector3d(((R(0, 0) * ux + R(0, 1) * uy) + R(0, 2) * uz) + trans_SW_.x(),
                        ((R(1, 0) * ux + R(1, 1) * uy) + R(1, 2) * uz) + trans_SW_.y(),
                        ((R(2, 0) * ux + R(2, 1) * uy) + R(2, 2) * uz) + trans_SW_.z());
  if (vertical) {
    l.b = up_;  // the same sums for v = (0, 0, 1): the constructor made up_ with this function
  } else {
    const double vx = v.x(), vy = v.y(), vz = v.z();
    l.b = Eigen::Vector3d((R(0, 0) * vx + R(0, 1) * vy) + R(0, 2) * vz, (R(1, 0) * vx + R(1, 1) * vy) + R(1, 2) * vz,
                          (R(2, 0) * vx + R(2, 1) * vy) + R(2, 2) * vz);
  }
  l.inv_den = vertical ? vertical_inv_den_.data() : nullptr;
  return l;
}

LocusHit LocusMapper::intersect(const Eigen::Vector3d& u, const Eigen::Vector3d& v) const {
  return intersect(u, v, nullptr);
}

LocusHit LocusMapper::intersect(const Eigen::Vector3d& u, const Eigen::Vector3d& v, int* hint) const {
  LocusHit hit;
  const Line line = lineOf(u, v);
  const int rows = rows_;
  auto at = [&](int r) {
    ++hit.evaluations;
    return atRow(line, r);
  };

  // Stage 1: two neighbouring scanlines between which Δ turns from negative (the line in front of
  // the surface) to non-negative (behind it). Along a line pointing up out of 2.5-D terrain, Δ
  // changes sign once: every point below the visible surface point is underground or hidden. So
  // a neighbouring cell's bracket (the hint) is the place to start, and any (−, +) pair of
  // consecutive scanlines is the crossing; without a hint, or when the hint's neighbourhood has
  // gaps, the walk goes down the line from its top (the paper's first stage).
  int r1 = -1, r2 = -1;
  Sample s1, s2;
  if (hint && *hint >= 0 && *hint + 1 < rows) {
    int r = *hint;
    Sample up = at(r), down = at(r + 1);
    int step = 0;
    if (up.valid && down.valid) {
      if (up.delta < 0 && down.delta >= 0) r1 = r, r2 = r + 1, s1 = up, s2 = down;
      else step = down.delta < 0 ? 1 : -1;  // the crossing is further down the image, or up
    }
    for (int k = 0; step != 0 && r1 < 0 && k < kHintSteps; ++k) {
      if (step > 0) {
        if (r + 2 >= rows) break;
        ++r, up = down, down = at(r + 1);
      } else {
        if (r - 1 < 0) break;
        --r, down = up, up = at(r);
      }
      if (!up.valid || !down.valid) break;
      if (up.delta < 0 && down.delta >= 0) r1 = r, r2 = r + 1, s1 = up, s2 = down;
    }
  }
  // A bracket near the hint is the crossing the walk from the line's top would find only if the
  // line above it is in front of everything seen: otherwise that walk decides.
  if (r1 >= 0) {
    double s_lo, s_hi;
    if (!(s1.s > s2.s) || bounds_.isEmpty() || !clipToBox(bounds_, u, v, s_lo, s_hi) || !(s2.s >= s_lo) ||
        !clearAbove(line, s_hi, r1, s1))
      r1 = r2 = -1;
  }
  if (r1 < 0) {
    double s_lo, s_hi;
    if (bounds_.isEmpty() || !clipToBox(bounds_, u, v, s_lo, s_hi)) return hit;
    // Keep the part of the segment between the image's sides, x/ρ = k with k = sin θ of the first
    // and last columns. Along a line, p̂ sweeps a great circle monotonically, so x/ρ = e_x·p̂ has
    // at most one extremum: the segment crosses a side at most twice, where
    // (a_x + s·b_x)² = k²·|a + s·b|² with a_x + s·b_x of the sign of k (a quadratic in s).
    for (const bool left : {true, false}) {
      const double k = left ? sin_theta_.front() : sin_theta_.back();
      const Eigen::Vector3d& a = line.a;
      const Eigen::Vector3d& b = line.b;
      const auto outside = [&](double s) {
        const Eigen::Vector3d p = a + s * b;
        return left ? p.x() < k * p.norm() : p.x() > k * p.norm();
      };
      const double qa = b.x() * b.x() - k * k * b.squaredNorm(), qb = 2 * (a.x() * b.x() - k * k * a.dot(b));
      const double qc = a.x() * a.x() - k * k * a.squaredNorm(), disc = qb * qb - 4 * qa * qc;
      double cuts[2];
      int n = 0;
      if (qa != 0 && disc >= 0)
        for (const double root : {(-qb - std::sqrt(disc)) / (2 * qa), (-qb + std::sqrt(disc)) / (2 * qa)})
          if (root > s_lo && root < s_hi && (a.x() + root * b.x()) * k >= 0) cuts[n++] = root;
      if (n == 2 && cuts[0] > cuts[1]) std::swap(cuts[0], cuts[1]);
      const bool out_lo = outside(s_lo), out_hi = outside(s_hi);
      if (n == 0 && out_lo && out_hi) return hit;  // wholly beside the image
      if (n > 0 && out_lo) s_lo = cuts[0];
      if (n > 0 && out_hi) s_hi = cuts[n - 1];
    }
    // Scan angles of the segment's ends; φ(s) is monotonic along a line.
    const Eigen::Vector3d top = line.a + s_hi * line.b, bottom = line.a + s_lo * line.b;
    // The row coordinates of the ends: φ = atan2(z, y), = asin(z/√(y² + z²)) in front (y > 0).
    const auto rowOf = [&](const Eigen::Vector3d& p) {
      return p.y() > 0 ? row_of_(p.z() / std::sqrt(p.y() * p.y() + p.z() * p.z()))
                       : (phi0_ - std::atan2(p.z(), p.y())) / dphi_;
    };
    const double rf_top = rowOf(top), rf_bottom = rowOf(bottom);
    const int step = rf_bottom >= rf_top ? 1 : -1;
    int r = step > 0 ? std::max(int(std::ceil(rf_top)), 0) : std::min(int(std::floor(rf_top)), rows - 1);
    const int r_end = step > 0 ? int(std::floor(rf_bottom)) : int(std::ceil(rf_bottom));
    Sample prev;
    int prev_row = -1;
    for (; step > 0 ? (r <= r_end && r < rows) : (r >= r_end && r >= 0); r += step) {
      const Sample cur = at(r);
      if (!cur.valid) {
        prev_row = -1;  // a gap (no return, out of view) is never bridged
        continue;
      }
      if (cur.delta >= 0) {
        // Below its first point behind the surface, a line stays behind it (single crossing):
        // either the scanline above brackets the crossing, or the line has no visible point.
        if (prev_row >= 0 && prev.delta < 0) r1 = prev_row, r2 = r, s1 = prev, s2 = cur;
        break;
      }
      prev = cur;
      prev_row = r;
    }
    if (r1 < 0) return hit;
  }
  hit.bracket_row = std::min(r1, r2);
  if (hint) *hint = hit.bracket_row;

  // Stage 2: search between the two scanlines until the bracket in φ is below ε (the paper's
  // stopping rule). The bracket is [lo, hi] with Δ(lo) < 0 ≤ Δ(hi). The first estimate is the root
  // of the Hermite cubic through Δ and dΔ/dφ at the two scanlines; after that, inverse quadratic
  // interpolation through the bracket's ends and the end dropped last, or the chord, or halving
  // whenever the last step did not halve the bracket. Around a trusted estimate (Hermite or
  // quadratic), Δ is evaluated ε/2 to either side — two independent evaluations — and the
  // bracket usually closes below ε at once. `bisection: true` halves every step, as the paper
  // does. docs/locus.md.
  const double eps = config_.epsilon_rad;
  double phi_lo = image_.phi[r1], phi_hi = image_.phi[r2];
  Sample lo = s1, hi = s2;
  double phi_x = 0, d_x = 0;  // the third point: the end most recently dropped from the bracket
  bool have_x = false;
  auto eval = [&](double phi) {
    ++hit.evaluations;
    return atPhi(line, r1, phi);
  };
  // Narrow the bracket with m at phi; false if m has no valid value (then the cell is unknown).
  auto take = [&](double phi, const Sample& m) {
    if (!m.valid) return false;
    if (m.delta < 0) {
      phi_x = phi_lo, d_x = lo.delta;
      phi_lo = phi, lo = m;
    } else {
      phi_x = phi_hi, d_x = hi.delta;
      phi_hi = phi, hi = m;
    }
    have_x = true;
    return true;
  };
  // Δ ε/2 (less a hair, so that the pair spans < ε) to either side of an estimate: two
  // independent evaluations that usually close the bracket at once. false: a pixel without a
  // return was reached (the cell is then unknown).
  auto probePair = [&](double phi) {
    const double h = 0.499 * eps;
    double pa = phi - h, pb = phi + h;  // pa: the one nearer lo
    if (std::abs(pa - phi_lo) > std::abs(pb - phi_lo)) std::swap(pa, pb);
    const bool in_a = (pa - phi_lo) * (pa - phi_hi) < 0, in_b = (pb - phi_lo) * (pb - phi_hi) < 0;
    if (!in_a && !in_b) return take(phi, eval(phi));
    const Sample ma = in_a ? eval(pa) : Sample{}, mb = in_b ? eval(pb) : Sample{};
    if ((in_a && !ma.valid) || (in_b && !mb.valid)) return false;
    if (in_a && in_b && ma.delta < 0 && mb.delta < 0) {  // taken in the order that narrows most
      take(pa, ma), take(pb, mb);
    } else {
      if (in_b) take(pb, mb);
      if (in_a) take(pa, ma);
    }
    return true;
  };
  // The first estimate (docs/locus.md): the root of the Hermite cubic through Δ and dΔ/dφ at the
  // bracket's ends, where Δ(φ) is smooth between them — the line stays in one returned 2×2 patch.
  // Where it crosses into the next column's patch, Δ has a kink at the column boundary: Δ is
  // evaluated first where the chord of the column coordinate meets that boundary, which leaves
  // the bracket on one side of it (up to the chord's error), and the cubic is fitted there with
  // that side's patch.
  double first = kNaN;
  const int r_cell = std::min(r1, r2);
  if (!config_.bisection && s1.delta < 0 && s2.delta > 0 && (cell_flags_[cellIndex(r_cell, s1.c0)] & kAllReturned) &&
      (cell_flags_[cellIndex(r_cell, s2.c0)] & kAllReturned)) {
    if (s1.c0 == s2.c0) {
      first = hermiteRoot(phi_lo, lo.delta, slopeInPatch(line, r1, phi_lo, r1, lo, r_cell, s1.c0), phi_hi, hi.delta,
                          slopeInPatch(line, r1, phi_hi, r2, hi, r_cell, s2.c0));
    } else if (std::abs(s1.c0 - s2.c0) == 1) {
      const int boundary = std::max(s1.c0, s2.c0);
      const double phi_b = phi_lo + (boundary - s1.column) / (s2.column - s1.column) * (phi_hi - phi_lo);
      if ((phi_b - phi_lo) * (phi_b - phi_hi) < 0) {
        if (!take(phi_b, eval(phi_b))) return hit;  // a pixel without a return: unknown
        // The side of the boundary the bracket is now on: its scanline end's patch.
        const bool near_side = phi_hi == phi_b;  // [φ(r1), φ_b]: r1's patch
        const int c_patch = near_side ? s1.c0 : s2.c0;
        if (lo.delta < 0 && hi.delta > 0)
          first = hermiteRoot(phi_lo, lo.delta,
                              slopeInPatch(line, r1, phi_lo, near_side ? r1 : -1, lo, r_cell, c_patch), phi_hi,
                              hi.delta, slopeInPatch(line, r1, phi_hi, near_side ? -1 : r2, hi, r_cell, c_patch));
      }
    }
  }
  double width_before = std::numeric_limits<double>::infinity();  // the width two steps ago
  for (int it = 0; it < 200 && std::abs(phi_hi - phi_lo) >= eps && hi.delta != 0.0; ++it) {
    const double width = std::abs(phi_hi - phi_lo);
    double phi = 0.5 * (phi_lo + phi_hi);
    bool trusted = false;
    if (it == 0 && !std::isnan(first)) {
      phi = first, trusted = true;
    } else if (!config_.bisection && !(width > 0.5 * width_before)) {
      // Interpolate only while the steps halve the bracket (else the midpoint above, so that the
      // search never does worse than bisection by more than a step in two).
      const double a = phi_lo, fa = lo.delta, b = phi_hi, fb = hi.delta;
      double est = a - fa * (b - a) / (fb - fa);
      if (have_x && d_x != fa && d_x != fb) {
        const double c = phi_x, fc = d_x;
        const double iqi = a * fb * fc / ((fa - fb) * (fa - fc)) + b * fa * fc / ((fb - fa) * (fb - fc)) +
                           c * fa * fb / ((fc - fa) * (fc - fb));
        if ((iqi - a) * (iqi - b) < 0) est = iqi, trusted = true;
      }
      if ((est - a) * (est - b) < 0) phi = est;
    }
    if (!(trusted && width >= 2 * eps ? probePair(phi) : take(phi, eval(phi))))
      return hit;  // the bracket reaches a pixel without a return: unknown
    width_before = width;
  }
  finish(line, u, v, r1, r2, s1, s2, phi_lo, lo, phi_hi, hi, hit);
  return hit;
}

double LocusMapper::slopeInPatch(const Line& l, int r1, double phi_m, int r_m, const Sample& m, int r_cell,
                                 int c_cell) const {
  double sp, cp, inv_den;
  if (r_m >= 0) {  // on scanline r_m: the tables
    sp = sin_phi_[r_m], cp = cos_phi_[r_m];
    inv_den = l.inv_den ? l.inv_den[r_m] : 1.0 / (l.b.z() * cp - l.b.y() * sp);
  } else {  // between scanlines: as atPhi(l, r1, φ) has it
    sinCosNear(sin_phi_[r1], cos_phi_[r1], image_.phi[r1] - phi_m, sp, cp);
    inv_den = 1.0 / (l.b.z() * cp - l.b.y() * sp);
  }
  const float* px = image_.range.data() + std::size_t(r_cell) * cols_ + c_cell;
  const double p00 = px[0], p01 = px[1], p10 = px[cols_], p11 = px[cols_ + 1];
  const double fr = r_m >= 0 ? double(r_m - r_cell) : (phi0_ - phi_m) * inv_dphi_ - r_cell;
  const double fc = m.column - c_cell;  // = m.fc where m is in that cell
  const double top = (1 - fc) * p00 + fc * p01, bottom = (1 - fc) * p10 + fc * p11;
  return slope(l, sp, cp, inv_den, m, bottom - top, (1 - fr) * (p01 - p00) + fr * (p11 - p10));
}

double LocusMapper::hermiteRoot(double phi_a, double y0, double g0, double phi_b, double y1, double g1) {
  const double h = phi_b - phi_a;
  const double m0 = g0 * h, m1 = g1 * h;
  const double c2 = -3 * y0 - 2 * m0 + 3 * y1 - m1, c3 = 2 * y0 + m0 - 2 * y1 + m1;
  // Two Newton steps on the cubic from the chord, each kept inside the part of [0, 1] where it
  // changes sign. The chord errs by ~1e-2 of the interval; Newton converges quadratically, so two
  // steps leave ~1e-8 of it (~1e-10 rad), far inside the probe pair's ε/2. Where they do not
  // (the probe pair then fails to straddle the root), the search goes on.
  double t = y0 / (y0 - y1), t_neg = 0, t_pos = 1;
  for (int k = 0; k < 2; ++k) {
    const double H = y0 + t * (m0 + t * (c2 + t * c3)), dH = m0 + t * (2 * c2 + 3 * t * c3);
    (H < 0 ? t_neg : t_pos) = t;
    const double next = t - H / dH;
    t = (next - t_neg) * (next - t_pos) < 0 ? next : 0.5 * (t_neg + t_pos);
  }
  return phi_a + t * h;
}

// At an occluding edge the line is in front of what scanline r1 saw and behind what r2 saw: the
// far surface (seen at r1 and beyond it) and the near one (seen at r2 and beyond it) each go on
// unseen into the gap between the two, the near one up to its edge and the far one back to where
// the edge's shadow on it ends, and the image cannot tell where exactly. Each surface is extended
// linearly in inverse range against row (exact for a plane to second order in the scanline
// spacing; range itself grows faster than linearly across a plane): the near one, fitted to its
// last clean samples, as far as its edge can be — one scanline (to r1's ray: r1 saw past it)
// plus its extension's noise — so that the visible top of a lip is kept out of the shadow; the
// far one half a scanline, to the middle of the gap, where the edge's shadow ends on it on
// average. A mixed pixel (its footprint straddled the edge: a range between the two surfaces,
// footprints one scanline wide) says the edge is inside its footprint, about 1.5 scanlines past
// the near surface's last clean sample, and its range says where: the fraction of the footprint on
// the near surface, read as a disk's, bounds how far the near surface reaches (with the emulator's
// cubature error and the fraction's noise; where that bound is the whole footprint, the next
// footprint, read as the far surface's within the same error, bounds it, short of 2 scanlines)
// and places the far surface's end. A line that meets either extension is unseen (maybe on that
// surface, visible but not sampled); every other line there is in the shadow.
double LocusMapper::rangeAt(int r, const Sample& s) const {
  if (r < 0 || r >= rows_) return kNaN;
  return (1 - s.fc) * double(image_.range(r, s.c0)) + s.fc * double(image_.range(r, s.c0 + 1));
}

bool LocusMapper::edgeAt(int r, const Sample& s) const {
  if (r < 0 || r >= rows_ || !edges_) return false;
  return ((*edges_)(r, s.c0) && s.fc != 1.0) || ((*edges_)(r, s.c0 + 1) && s.fc != 0.0);
}

LocusMapper::InverseRangeFit LocusMapper::fitInverseRange(double y0, int first, int step, const Sample& s) const {
  double sk = 0, sy = 0, skk = 0, sky = 0;
  int n = 0;
  for (int k = 0; k < 4; ++k) {
    const double y = k == 0 ? y0 : rangeAt(first + k * step, s);
    if (!std::isfinite(y)) break;
    sk += k, sy += 1 / y, skk += k * k, sky += k / y, ++n;
  }
  InverseRangeFit fit;
  fit.n = n;
  if (n == 0) return fit;
  fit.k_mean = sk / n, fit.s_kk = skk - sk * fit.k_mean;
  fit.slope = (sky - sk * sy / n) / fit.s_kk, fit.at_mean = sy / n;
  return fit;
}

bool LocusMapper::meetsSurfaceInGap(int r1, int r2, const Sample& s1, const Sample& s2) const {
  const int d = r2 - r1;  // from the far side to the near side
  // The line's range at (fractional) row r, linear between its samples at r1 and r2.
  const auto lineAt = [&](double r) { return s1.rho + (s2.rho - s1.rho) * (r - r1) / d; };
  // Edge pixels come in pairs across a discontinuity; a mixed pixel sits between two (far to
  // mixed, mixed to near), so it and both its neighbours across scanlines are edge pixels, and its
  // range lies between theirs.
  const double far0 = s1.rho - s1.delta, near0 = s2.rho - s2.delta;
  const double far1 = rangeAt(r1 - d, s1), far2 = rangeAt(r1 - 2 * d, s1);
  const double near1 = rangeAt(r2 + d, s2);
  const bool near_mixed = edgeAt(r2 + d, s2) && near1 < near0 && near0 < far0;  // r2 between the sides
  const bool far_mixed = !near_mixed && edgeAt(r1 - d, s1) && near0 < far0 && far0 < far1;
  const bool mix = near_mixed || far_mixed;
  // The near surface: its last clean sample at row n0, then up to three more past it, fitted by a
  // line in inverse range against row (least squares: the fit's error grows slower with the
  // distance it is carried than two samples' does).
  const int n0 = near_mixed ? r2 + d : r2;
  const InverseRangeFit fit = fitInverseRange(near_mixed ? near1 : near0, n0, d, s2);
  // (With a single sample the near surface's course past it is unknown, so is the edge's place.)
  if (fit.n < 2) return true;
  // Scanlines past n0 towards the far side (the near surface) and past f0 towards the near side
  // (the far surface); a mixed pixel lies one scanline past each.
  double t_near = mix ? 1.5 : 1.0, t_far = mix ? 1.0 : config_.far_gap_scanlines;
  // The far surface: last clean sample at f0, range a, the sample past it b; its inverse range
  // carried t scanlines past f0, linearly.
  const int f0 = far_mixed ? r1 - d : r1;
  const double fa = far_mixed ? far1 : far0, fb = far_mixed ? far2 : far1;
  const auto farInverseAt = [&](double t) { return 1 / fa + t * (1 / fa - 1 / fb); };
  if (mix && sensor_.mixed_pixels && std::isfinite(fb)) {
    // Where in its footprint the mixed pixel puts the edge: the near fraction of its footprint,
    // from its range between the two surfaces carried to it, read as a uniform disk's (radius
    // `radius` scanlines about its centre). The near surface reaches the far end of what that
    // fraction allows, with the cubature's error and 2σ of the fraction's noise; the far one, the
    // edge's estimate (docs/locus.md, "Range shadows").
    const double inv_n = fit.inverseAt(1.0), inv_f = farInverseAt(1.0);
    if (inv_f > 0 && inv_n > inv_f) {
      const double rho_m = near_mixed ? near0 : far0, rho_n = 1 / inv_n, rho_f = 1 / inv_f;
      const double A = SensorModel::nearFraction(rho_m, rho_n, rho_f);
      // dA/dρ_m ≈ −1/(ρ_f − ρ_n); the near extension's and the far extrapolation's (2·i_a − i_b:
      // five times a sample's variance) errors enter alike.
      const double sigma_n = fit.sigma(sensor_.rangeVariance(rho_n), 1.0);
      const double sigma_A = std::sqrt(sensor_.rangeVariance(rho_m) + sigma_n * sigma_n +
                                       5 * sensor_.rangeVariance(rho_f)) / (rho_f - rho_n);
      const double radius = 0.5 * sensor_.beamDivergence() / dphi_;
      // Where even the fraction's upper bound is the whole footprint, the pixel may lie wholly on
      // the near surface and does not bound the edge: the next scanline's footprint, which reads
      // as the far surface, does — its own near fraction is at most the cubature's error and 2σ.
      const double e = SensorModel::kCubatureFractionError + 2 * sigma_A;
      t_near = A + e < 1 ? 1 + radius * SensorModel::diskEdgeOffset(A + e)
                         : 2 + radius * SensorModel::diskEdgeOffset(e);
      t_far = 1 - radius * SensorModel::diskEdgeOffset(A);
    }
  }
  const double inv_near = fit.inverseAt(t_near);
  // The extension's range errs by σ_ext = σ_p·√(1/n + (t + k̄)²/S_kk) (σ_p at the near surface's
  // range); the near surface gets one σ_ext more, so that noise rarely puts a visible lip top into
  // the shadow (each σ_ext more costs shadow recall: docs/locus.md has the trade's figures).
  const double sigma_ext = fit.sigma(sensor_.rangeVariance(1 / fit.at_mean), t_near);
  if (!(inv_near > 0) || lineAt(n0 - t_near * d) < 1 / inv_near + sigma_ext) return true;
  // The far surface, carried t_far scanlines: the line behind it there.
  if (std::isfinite(fb) && lineAt(f0 + t_far * d) * farInverseAt(t_far) >= 1) return true;
  return false;
}

// A mixed pixel whose footprint straddled an occluding edge returns a range between the two
// surfaces, so the range image has two jumps there (far to mixed, mixed to near), and the edge
// detector can see the larger one only: it then takes the mixed pixel for part of the other
// surface, and a line crossing between the mixed pixel and that surface would be "known" on a
// surface that is not there. Such a pixel is an edge pixel (paired with its neighbour beyond it),
// and departs from the other surface, extrapolated linearly in inverse range from its two nearest
// samples, towards the first surface by more than three standard deviations of that departure's
// noise (√6·σ_p: the pixel and the extrapolation, 2·i₁ − i₂). Here r1 or r2 (the one with edge
// pixels) is checked.
bool LocusMapper::linkedMixedPixel(int r1, int r2, const Sample& s1, const Sample& s2) const {
  if (!edges_) return false;
  const int d = r2 - r1;
  const bool far_side = s1.edges != 0;  // r1 is the edge pixel: a mixed pixel linked to the near side
  const int m = far_side ? r1 : r2, beyond = far_side ? r1 - d : r2 + d, o1 = far_side ? r2 : r1,
            o2 = far_side ? r2 + d : r1 - d;
  const Sample& sm = far_side ? s1 : s2;
  if (beyond < 0 || beyond >= rows_ || o2 < 0 || o2 >= rows_) return false;
  if (!edgeAt(beyond, sm)) return false;  // paired
  const double i_m = rangeAt(m, sm), i1 = rangeAt(o1, sm), i2 = rangeAt(o2, sm);
  if (!std::isfinite(i_m) || !std::isfinite(i1) || !std::isfinite(i2)) return false;
  const double inv = 2 / i1 - 1 / i2;  // the other surface's inverse range extrapolated to m
  if (!(inv > 0)) return false;
  const double departure = (i_m - 1 / inv) * (far_side ? 1.0 : -1.0);  // towards the first surface
  return departure > 3 * std::sqrt(6 * sensor_.rangeVariance(i_m));
}

// A bracket with edge pixels on one scanline only, next to an occluding edge: its edge-side
// scanline m is the last sample of its surface before the edge (the scanline beyond m, across the
// edge, is an edge pixel past the near surface or in front of the far one), and the other, o, is
// clean. m's range cannot be trusted to be its surface's: a mixed pixel whose departure is below
// linkedMixedPixel's threshold (3·√6·σ_p, up to 18 cm of range at 6 m with the ERIM's
// quantisation) passes as clean, and it and its noise misplace the edge — on the near side
// (m = r1, the line in front of it) past the lip, over the shadow; on the far side (m = r2, the
// line behind it) in front of the far ground, over the shadow's end. So the line is taken to meet
// m's surface inside the bracket only where that is certain from the clean samples alone: the
// surface fitted to o and up to three scanlines past it (linear in inverse range against row, as
// in meetsSurfaceInGap) and carried to m, with three standard deviations of that extension's
// noise — the line in front of it there on the near side, behind it on the far side. Otherwise
// the line may pass the edge: the cell is unseen (docs/locus.md, "Range shadows").
bool LocusMapper::pastUntrustedEdgeSample(bool near_side, int r1, int r2, const Sample& s1, const Sample& s2) const {
  if (!edges_ || config_.trust_edge_samples) return false;
  const int m = near_side ? r1 : r2, o = near_side ? r2 : r1, into = o - m, beyond = m - into;
  const Sample& sm = near_side ? s1 : s2;
  const Sample& so = near_side ? s2 : s1;
  if (beyond < 0 || beyond >= rows_ || !edgeAt(beyond, sm)) return false;
  const InverseRangeFit fit = fitInverseRange(rangeAt(o, so), o, into, so);
  if (fit.n < 2) return false;  // no course to carry: the bracket decides, as before
  const double var_p = sensor_.rangeVariance(1 / fit.at_mean);
  // The surface carried t scanlines from o towards m and beyond, in range.
  const auto extension = [&](double t) {
    const double inv = fit.inverseAt(t);
    return inv > 0 ? 1 / inv : std::numeric_limits<double>::infinity();
  };
  const double at_beyond = extension(2), at_m = extension(1);
  const double sigma_b = fit.sigma(var_p, 2), sigma_m = fit.sigma(var_p, 1);
  const double range_beyond = rangeAt(beyond, sm);
  // The scanline beyond lies across the edge: past the near surface, in front of the far one.
  if (near_side ? !(range_beyond > at_beyond + 3 * sigma_b) : !(range_beyond < at_beyond - 3 * sigma_b)) return false;
  // sm.rho: the line's range on scanline m.
  return near_side ? !(sm.rho < at_m - 3 * sigma_m) : !(sm.rho > at_m + 3 * sigma_m);
}

bool LocusMapper::clearAbove(const Line& l, double s_top, int r1, const Sample& s1) const {
  if (!(s1.s <= s_top)) return false;
  const Eigen::Vector3d top = l.a + s_top * l.b;
  if (!(top.y() > 0)) return false;  // then the segment is in front of the sensor throughout
  // The columns the segment [s1.s, s_top] sweeps: x/ρ = sin θ has one extremum along a line, at
  // s* (|b| = 1), so θ lies between its values at the ends and at s*, if s* is inside.
  const auto column = [&](const Eigen::Vector3d& p) {
    return column_of_(p.x() / std::sqrt(p.y() * p.y() + p.z() * p.z()));
  };
  double c_min = s1.column, c_max = s1.column;
  const double c_top = column(top);
  c_min = std::min(c_min, c_top), c_max = std::max(c_max, c_top);
  const double ab = l.a.dot(l.b), den = l.b.x() * ab - l.a.x();
  if (den != 0.0) {
    const double s_ext = (l.a.x() * ab - l.b.x() * l.a.squaredNorm()) / den;
    if (s_ext > s1.s && s_ext < s_top) {
      const double c_ext = column(l.a + s_ext * l.b);
      c_min = std::min(c_min, c_ext), c_max = std::max(c_max, c_ext);
    }
  }
  if (!(c_min > -2.0 && c_max < cols_ + 1.0)) return false;  // also NaN
  // The pixels a scanline's interpolation can read there (c0 = ⌊column⌋ and c0 + 1), widened by far
  // more than the column tables' error (1.3e-10 rad) in case it moves column across a pixel boundary.
  const int c_lo = std::max(0, int(std::floor(c_min - 1e-6))), c_hi = std::min(cols_ - 1, int(std::floor(c_max + 1e-6)) + 1);
  if (c_lo > c_hi) return true;  // the segment is beside the image: nothing above is seen
  const int k = 31 - __builtin_clz(unsigned(c_hi - c_lo + 1));
  if (k >= above_levels_) return false;
  const float* level = above_min_.data() + std::size_t(k) * rows_ * cols_ + std::size_t(r1) * cols_;
  const double nearest = std::min(level[c_lo], level[c_hi - (1 << k) + 1]);
  // The line's range is convex along it: at most the larger of its ends' ranges.
  const double farthest = std::max(s1.rho, top.norm());
  return nearest > farthest * (1 + 1e-9) + 1e-9;
}

void LocusMapper::finish(const Line& line, const Eigen::Vector3d& u, const Eigen::Vector3d& v, int r1, int r2,
                         const Sample& s1, const Sample& s2, double phi_lo, const Sample& lo, double phi_hi,
                         const Sample& hi, LocusHit& hit) const {
  // The final bracket's chord root (its midpoint under plain bisection), and what the line has
  // there: s, ρ and θ vary linearly across a bracket narrower than ε; σ and the edge test use the
  // bracket end nearer the root.
  const double phi = config_.bisection || hi.delta == lo.delta
                         ? 0.5 * (phi_lo + phi_hi)
                         : phi_lo - lo.delta * (phi_hi - phi_lo) / (hi.delta - lo.delta);
  const double t = phi_hi == phi_lo ? 0.0 : (phi - phi_lo) / (phi_hi - phi_lo);
  const Sample& near = t <= 0.5 ? lo : hi;
  // The crossing is at an occluding edge when edge pixels lie on both sides of it — on both
  // scanlines of the bracket, or in both columns of the final cell. Edge pixels come in pairs
  // across a discontinuity, so a visible point beside one (on a ledge's lip) has edge pixels on
  // one side only and stays known. Which way the final cell's discontinuity runs: edge pixels
  // mark both sides of a break, so compare the cell's largest range jump across scanlines with
  // that across columns. A shadow across columns also needs edge pixels whose breaks run across
  // columns (range_edges.hpp: the mask's direction bits): beside a lip, whose edge pixels break
  // across scanlines, a column jump of a count or two of quantisation is no edge, and the cell is
  // then unseen (below), neither shadow nor known.
  const bool row1_edge = s1.edges != 0, row2_edge = s2.edges != 0;
  const unsigned e = near.edges;
  double jump_rows = 0, jump_cols = 0;
  if (e && (cell_flags_[cellIndex(near.r0, near.c0)] & kAllReturned)) {
    const auto rng = [&](int k) { return double(image_.range(near.r0 + k / 2, near.c0 + k % 2)); };
    jump_rows = std::max(std::abs(rng(0) - rng(2)), std::abs(rng(1) - rng(3)));
    jump_cols = std::max(std::abs(rng(0) - rng(1)), std::abs(rng(2) - rng(3)));
  }
  const bool across_rows = (row1_edge && row2_edge) || ((e & 3u) && (e & 12u) && jump_rows >= jump_cols) ||
                           (row1_edge != row2_edge && linkedMixedPixel(r1, r2, s1, s2));
  const bool beside_cols = (e & 5u) && (e & 10u) && jump_cols > jump_rows;
  unsigned e_cols = 0;  // the cell's edge pixels with a break across columns
  for (int k = 0; k < 4 && beside_cols; ++k)
    if ((e >> k & 1u) && edgeBreaksAcross((*edges_)(near.r0 + k / 2, near.c0 + k % 2), kEdgeAcrossCols))
      e_cols |= 1u << k;
  const bool across_cols = beside_cols && (e_cols & 5u) && (e_cols & 10u);
  if (across_rows && meetsSurfaceInGap(r1, r2, s1, s2)) {
    hit.state = CellState::Unseen;  // maybe on a surface past its last sample
    return;
  }
  if (across_rows || across_cols) {
    hit.state = CellState::Shadow;  // the locus meets the image at an occluding edge
    // The ceiling: under the lowest ray that went past the line beyond doubt — r1's, or, where
    // r1's range exceeds the line's by less than 3σ_p (that ray may have stopped at the line),
    // the next scanline's up the line.
    int rc = r1;
    Sample sc = s1;
    for (int k = 0; k < 4 && sc.valid; ++k) {
      if (sc.delta < -3 * sensor_.rangeSigma(sc.rho - sc.delta)) break;
      rc -= r2 - r1;
      sc = rc >= 0 && rc < rows_ ? atRow(line, rc) : Sample{};
      if (sc.valid && !(sc.delta < 0)) sc.valid = false;
    }
    if (sc.valid) hit.ceiling = u + sc.s * v;
    return;
  }
  if (beside_cols) {
    hit.state = CellState::Unseen;  // beside an edge, on a column jump no break explains
    return;
  }
  if (row1_edge != row2_edge && pastUntrustedEdgeSample(row1_edge, r1, r2, s1, s2)) {
    hit.state = CellState::Unseen;  // maybe past the edge, which its last sample may misplace
    return;
  }
  hit.state = CellState::Known;
  hit.s = lo.s + t * (hi.s - lo.s);
  hit.point = u + hit.s * v;
  hit.phi = phi;
  // Where the point is in the image: in the 2×2 cell between the bracket's two scanlines.
  const double column = lo.column + t * (hi.column - lo.column);
  const int r_cell = std::min(r1, r2), c_cell = std::clamp(int(column), 0, cols_ - 2);
  hit.theta = theta0_ + dtheta_ * column;
  hit.rho = lo.rho + t * (hi.rho - lo.rho);
  hit.sigma = sigmaAlongLine(r_cell, c_cell, std::clamp((phi0_ - phi) * inv_dphi_ - r_cell, 0.0, 1.0),
                             std::clamp(column - c_cell, 0.0, 1.0), hit.rho, line.a + hit.s * line.b, line.b);
}

ElevationMap LocusMapper::map(const MapGrid& grid, long* lane_cells) const {
  if (grid.T_WM.matrix() != T_WM_.matrix())
    throw std::invalid_argument("LocusMapper::map: the grid is not in the mapper's map frame");
  ElevationMap out(grid);
  std::atomic<long> by_lanes{0};
  const Eigen::Vector3d v = Eigen::Vector3d::UnitZ();
  const LaneIsa isa = config_.vectorized && !config_.bridge_sigma ? laneIsa() : LaneIsa::None;
  // Tasks of whole map rows, about 256 cells each: rows cost very different amounts (unseen rows
  // are cheap), small tasks keep both cores busy to the end, and tasks much smaller than that
  // cost more to hand out than they take (docs/benchmarks.md has the measurements). Rows are independent (each starts without a hint), so the map is
  // the same however it is split. Within a row, cells go in groups of kLanes: every
  // cell of a group starts its scanline search from the same hint — the last bracket found in the
  // groups before it, or, in a group that starts without one, the first found in the group — so
  // the lanes and the scalar search give the same map.
  tbb::parallel_for(
      tbb::blocked_range<int>(0, grid.rows, std::max(1, 256 / std::max(grid.cols, 1))),
      [&](const tbb::blocked_range<int>& rows) {
        CellResult res[kLanes];
        long task_lane_cells = 0;  // added to the total once per task: a shared counter would bounce
        for (int r = rows.begin(); r != rows.end(); ++r) {
          int hint = -1;
          for (int c0 = 0; c0 < grid.cols; c0 += kLanes) {
            const int n = std::min(kLanes, grid.cols - c0);
            const auto scalarCell = [&](int k, int* h) {
              const Eigen::Vector2d xy = grid.center(r, c0 + k);
              const LocusHit hit = intersect(Eigen::Vector3d(xy.x(), xy.y(), 0.0), v, h);
              const double z = hit.state == CellState::Shadow ? hit.ceiling.z() : hit.point.z();
              res[k] = {hit.state, float(z), float(hit.sigma), hit.bracket_row};
            };
            // Without a hint (the row's start, or nothing found yet), one cell at a time until
            // one finds a bracket; the rest of the group starts from it.
            int j = 0;
            for (; hint < 0 && j < n; ++j) scalarCell(j, &hint);
            const unsigned done = isa != LaneIsa::None && j < n ? mapLanes(isa, grid, r, c0 + j, n - j, hint, res + j) : 0u;
            task_lane_cells += __builtin_popcount(done);
            int next = hint;
            for (int k = 0; k < n; ++k) {
              if (k >= j && !(done >> (k - j) & 1u)) {
                int h = hint;
                scalarCell(k, &h);
              }
              if (res[k].state == CellState::Known) out.setKnown(r, c0 + k, res[k].z, res[k].sigma);
              else if (res[k].state == CellState::Shadow) out.setShadow(r, c0 + k, res[k].z);
              else out.setUnknown(r, c0 + k, res[k].state);
              if (res[k].bracket_row >= 0) next = res[k].bracket_row;
            }
            hint = next;
          }
        }
        if (task_lane_cells) by_lanes += task_lane_cells;
      },
      tbb::simple_partitioner());
  if (lane_cells) *lane_cells = by_lanes;
  return out;
}

Eigen::Vector3d LocusMapper::surfaceNormal(const LocusHit& hit) const {
  // The hit's place in the image: fractional row and column, inside the 2×2 cell (r0, c0).
  const double row = std::clamp((phi0_ - hit.phi) * inv_dphi_, 0.0, last_row_);
  const double col = std::clamp((hit.theta - theta0_) * inv_dtheta_, 0.0, last_col_);
  const int r0 = std::min(int(row), rows_ - 2), c0 = std::min(int(col), cols_ - 2);
  const double fr = row - r0, fc = col - c0;
  const double i00 = image_.range(r0, c0), i01 = image_.range(r0, c0 + 1);
  const double i10 = image_.range(r0 + 1, c0), i11 = image_.range(r0 + 1, c0 + 1);
  const double rho = (1 - fr) * ((1 - fc) * i00 + fc * i01) + fr * ((1 - fc) * i10 + fc * i11);
  // dρ/dφ and dρ/dθ of the bilinear patch (rows run down in φ, columns up in θ).
  const double drho_dphi = -((1 - fc) * (i10 - i00) + fc * (i11 - i01)) * inv_dphi_;
  const double drho_dtheta = ((1 - fr) * (i01 - i00) + fr * (i11 - i10)) * inv_dtheta_;
  const double sp = std::sin(hit.phi), cp = std::cos(hit.phi), st = std::sin(hit.theta), ct = std::cos(hit.theta);
  const Eigen::Vector3d d(st, cp * ct, sp * ct), d_phi(0, -sp * ct, cp * ct), d_theta(ct, -cp * st, -sp * st);
  Eigen::Vector3d n = (drho_dphi * d + rho * d_phi).cross(drho_dtheta * d + rho * d_theta);
  if (n.dot(d) > 0) n = -n;  // towards the sensor
  return rot_SW_.transpose() * n.normalized();  // sensor frame → map frame
}

ElevationMap LocusMapper::mapPolygon(const std::vector<Eigen::Vector2d>& polygon, double cell_m) const {
  if (polygon.size() < 3) throw std::invalid_argument("LocusMapper::mapPolygon: needs at least 3 vertices");
  Eigen::AlignedBox2d box;
  for (const auto& p : polygon) box.extend(p);
  const MapGrid grid = MapGrid::covering(box.min().x(), box.max().x(), box.min().y(), box.max().y(), cell_m, T_WM_);
  ElevationMap out(grid);
  tbb::parallel_for(tbb::blocked_range<int>(0, grid.rows), [&](const tbb::blocked_range<int>& rows) {
    for (int r = rows.begin(); r != rows.end(); ++r)
      for (int c = 0; c < grid.cols; ++c) {
        const Eigen::Vector2d xy = grid.center(r, c);
        if (!insidePolygon(polygon, xy)) continue;
        const LocusHit hit = elevationAt(xy.x(), xy.y());
        if (hit.state == CellState::Known) out.setKnown(r, c, float(hit.point.z()), float(hit.sigma));
        else if (hit.state == CellState::Shadow) out.setShadow(r, c, float(hit.ceiling.z()));
        else out.setUnknown(r, c, hit.state);
      }
  });
  return out;
}

}  // namespace ambler::perception
