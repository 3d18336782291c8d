#include "perception/iconic.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace ambler::perception {

namespace {

Eigen::Matrix3d skew(const Eigen::Vector3d& w) {
  Eigen::Matrix3d S;
  S << 0, -w.z(), w.y(), w.z(), 0, -w.x(), -w.y(), w.x(), 0;
  return S;
}

// The least σ of a residual in the weighted cost: the sensor model's floor, one 1 mm count's
// rounding (q²/12), so that a noise-free pair keeps finite weights.
constexpr double kSigmaFloor2 = 1e-6 / 12.0;

// One map row's share of E and its gradient.
struct RowSum {
  double E = 0, sum_r2 = 0, sum_u2 = 0;
  PoseVector gradient = PoseVector::Zero();
  Matrix6d JtJ = Matrix6d::Zero();
  long overlap = 0;
};

// One line's residual: the cell's vertical line moved by T and met with image 2.
struct LineTerm {
  Eigen::Vector3d base;  // u: the cell's centre at z = 0 in map 1's frame
  LocusHit hit;
  double diff = 0;   // r = z₁ − s
  double sigma = 1;  // σ of r (weighted: √(σ₁² + σ₂²)), else 1
  double u = 0;      // r/σ
};

// T and its derivatives, shared by every line of one evaluation.
struct LineModel {
  Eigen::Matrix3d R;
  Eigen::Vector3d t;
  Eigen::Matrix3d dR[3];
  const Eigen::Vector3d v{0, 0, 1};
  LineModel(const PoseVector& nu, bool with_gradient) {
    const Eigen::Isometry3d T = poseFromVector(nu);
    R = T.linear(), t = T.translation();
    if (with_gradient)
      for (int k = 0; k < 3; ++k) dR[k] = rotationDerivative(nu.head<3>(), k);
  }
  // False where map 1's cell or image 2's crossing is not Known.
  // hint: where this line's search starts (a bracket found before), updated; may be null.
  bool residual(const ElevationMap& map1, const LocusMapper& image2, int r, int c, bool weighted, LineTerm& l,
                int* hint = nullptr) const {
    if (map1.stateAt(r, c) != CellState::Known) return false;
    const Eigen::Vector2d xy = map1.grid().center(r, c);
    l.base = Eigen::Vector3d(xy.x(), xy.y(), 0.0);
    l.hit = image2.intersect(R * l.base + t, R * v, hint);
    if (l.hit.state != CellState::Known) return false;
    // g = T⁻¹·f₂ = u + s·v: f₁ − g is (z₁ − s)·v.
    l.diff = double(map1.elevation()(r, c)) - l.hit.s;
    if (weighted) {
      const double s1 = map1.sigma()(r, c);
      l.sigma = std::sqrt(std::max(s1 * s1 + l.hit.sigma * l.hit.sigma, kSigmaFloor2));
      if (!std::isfinite(l.sigma)) return false;
    }
    l.u = l.diff / l.sigma;
    return true;
  }
  // The residual's Jacobian J = −∂s/∂ν (unnormalized), with map 1's normal at cell `index` where
  // given; false where the line grazes the surface.
  bool jacobian(const LocusMapper& image2, const std::vector<Eigen::Vector3d>* normals, long index, const LineTerm& l,
                PoseVector& J) const {
    const Eigen::Vector3d* ref = normals ? &(*normals)[std::size_t(index)] : nullptr;
    const Eigen::Vector3d n = ref && std::isfinite(ref->x()) ? Eigen::Vector3d(R * *ref) : image2.surfaceNormal(l.hit);
    const Eigen::Vector3d v2 = R * v;
    const double nv = n.dot(v2);
    if (std::abs(nv) < 1e-12) return false;  // the line grazes the surface: no derivative
    for (int k = 0; k < 3; ++k) J(k) = n.dot(dR[k] * l.base + l.hit.s * (dR[k] * v)) / nv;
    for (int k = 0; k < 3; ++k) J(3 + k) = n(k) / nv;
    return true;
  }
};

double rms(const IconicError& e) { return e.overlap ? std::sqrt(e.sum_r2 / double(e.overlap)) : 0.0; }
// One iteration's entry of a result's trace.
void record(IconicResult& res, const IconicError& e) {
  res.rms_m.push_back(rms(e));
  res.E_m2.push_back(e.sum_r2);
  res.lines.push_back(e.overlap);
}
double rmsNormalized(const IconicError& e) { return e.overlap ? std::sqrt(e.sum_u2 / double(e.overlap)) : 0.0; }

// The median σ_z of a map's known cells, at least the sensor model's 1 mm floor.
double medianSigma(const ElevationMap& map) {
  std::vector<float> s;
  for (long i = 0; i < map.state().size(); ++i)
    if (map.state().data()[i] == std::uint8_t(CellState::Known) && std::isfinite(map.sigma().data()[i]))
      s.push_back(map.sigma().data()[i]);
  if (s.empty()) return 1e-3;
  std::nth_element(s.begin(), s.begin() + long(s.size() / 2), s.end());
  return std::max(1e-3, double(s[s.size() / 2]));
}

}  // namespace

Eigen::Vector3d knownCentroid(const ElevationMap& map) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  long n = 0;
  for (int r = 0; r < map.grid().rows; ++r)
    for (int c = 0; c < map.grid().cols; ++c)
      if (map.stateAt(r, c) == CellState::Known) {
        const Eigen::Vector2d xy = map.grid().center(r, c);
        sum += Eigen::Vector3d(xy.x(), xy.y(), map.elevation()(r, c));
        ++n;
      }
  return n ? Eigen::Vector3d(sum / double(n)) : sum;
}

namespace {

// e: the plain error at the estimate, with image 2's normals (iconicError's defaults).
void finishResult(IconicResult& res, const ElevationMap& map1, const IconicError& e) {
  res.overlap = e.overlap;
  // Rotations weigh as the motion they give at half the map's diagonal.
  const MapGrid& g = map1.grid();
  const Degeneracy d = degeneracy(e.JtJ, 0.5 * std::hypot(g.cols * g.cell, g.rows * g.cell), knownCentroid(map1));
  res.degenerate = d.degenerate;
  res.free_directions = d.free_directions;
  if (e.overlap > 6 && !d.degenerate) {
    const double s2 = e.E / double(e.overlap - 6);
    res.covariance = s2 * e.JtJ.ldlt().solve(Matrix6d::Identity());
  } else {
    res.covariance.setConstant(std::numeric_limits<double>::quiet_NaN());  // unbounded along a free direction
  }
}

}  // namespace

double stepMahalanobis2(const IconicError& e, double sigma2) {
  if (e.overlap <= 6 || !(sigma2 > 0)) return std::numeric_limits<double>::quiet_NaN();
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eig(e.JtJ);
  const double top = eig.eigenvalues()(5);
  if (!(top > 0)) return std::numeric_limits<double>::quiet_NaN();
  // δᵀHδ = (g/2)ᵀH⁻¹(g/2) = Σ_k (v_k·g/2)²/λ_k.
  const PoseVector p = eig.eigenvectors().transpose() * (0.5 * e.gradient);
  double t = 0;
  for (int k = 0; k < 6; ++k)
    if (eig.eigenvalues()(k) > 1e-12 * top) t += p(k) * p(k) / eig.eigenvalues()(k);
  return t / sigma2;
}

Degeneracy degeneracy(const Matrix6d& JtJ, double length_m, double ratio) {
  return degeneracy(JtJ, length_m, Eigen::Vector3d::Zero(), ratio);
}

Degeneracy degeneracy(const Matrix6d& JtJ, double length_m, const Eigen::Vector3d& pivot, double ratio) {
  Matrix6d A = Matrix6d::Identity();
  A.block<3, 3>(3, 0) = skew(pivot);  // rotations about the pivot
  PoseVector s;
  s << 1 / length_m, 1 / length_m, 1 / length_m, 1, 1, 1;  // and in metres at length_m
  const Matrix6d AS = A * s.asDiagonal();
  const Matrix6d M = AS.transpose() * JtJ * AS;
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eig(M);
  const double top = eig.eigenvalues()(5);
  static const char* kNames[6] = {"rx", "ry", "rz", "tx", "ty", "tz"};
  Degeneracy d;
  // The weak subspace, and each parameter's share of it: a parameter mostly inside it is free
  // (the solver may return any basis of a subspace of equal eigenvalues, so name by projection).
  std::vector<int> weak;
  for (int i = 0; i < 6; ++i)
    if (!(top > 0) || eig.eigenvalues()(i) < ratio * top) weak.push_back(i);
  if (weak.empty()) return d;
  d.degenerate = true;
  Matrix6d P = Matrix6d::Zero();
  for (const int i : weak) P += eig.eigenvectors().col(i) * eig.eigenvectors().col(i).transpose();
  std::vector<bool> named(6, false);
  for (int k = 0; k < 6; ++k) named[k] = P(k, k) > 0.5;
  // A weak direction that mixes parameters (yaw about a point off the origin) is named by its
  // largest component.
  if (std::count(named.begin(), named.end(), true) < long(weak.size()))
    for (const int i : weak) {
      int k = 0;
      eig.eigenvectors().col(i).cwiseAbs().maxCoeff(&k);
      named[k] = true;
    }
  for (int k = 0; k < 6; ++k)
    if (named[k]) d.free_directions.push_back(kNames[k]);
  return d;
}

Eigen::Matrix3d rotationDerivative(const Eigen::Vector3d& r, int k) {
  const Eigen::Vector3d e = Eigen::Vector3d::Unit(k);
  const double n2 = r.squaredNorm();
  if (n2 < 1e-24) return skew(e);
  const Eigen::Matrix3d R = poseFromVector((PoseVector() << r, Eigen::Vector3d::Zero()).finished()).linear();
  return (r(k) * skew(r) + skew(r.cross((Eigen::Matrix3d::Identity() - R) * e))) * R / n2;
}

std::vector<Eigen::Vector3d> referenceNormals(const ElevationMap& map) {
  const MapGrid& g = map.grid();
  std::vector<Eigen::Vector3d> n(std::size_t(g.cells()), Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN()));
  const auto known = [&](int r, int c) {
    return r >= 0 && c >= 0 && r < g.rows && c < g.cols && map.stateAt(r, c) == CellState::Known;
  };
  // dz per metre across cells (r, c ± k) or (r ± k, c), the widest span of 2 or 1 that is known.
  const auto slope = [&](int r, int c, int dr, int dc, double& out) {
    for (int k = 2; k >= 1; --k)
      if (known(r - k * dr, c - k * dc) && known(r + k * dr, c + k * dc)) {
        out = (double(map.elevation()(r + k * dr, c + k * dc)) - map.elevation()(r - k * dr, c - k * dc)) /
              (2 * k * g.cell);
        return true;
      }
    return false;
  };
  for (int r = 0; r < g.rows; ++r)
    for (int c = 0; c < g.cols; ++c) {
      double zx = 0, zy = 0;
      if (!known(r, c) || !slope(r, c, 0, 1, zx) || !slope(r, c, -1, 0, zy)) continue;  // row − 1 is +y
      n[std::size_t(r) * g.cols + c] = Eigen::Vector3d(-zx, -zy, 1).normalized();
    }
  return n;
}

namespace {

// One line of an evaluation: its residual r, r/σ and the Jacobian of r/σ (has_J: the line does
// not graze the surface; only with a gradient).
struct LineSample {
  int col;  // the cell's column (its row is the list's)
  double diff, u;
  PoseVector J;
  bool has_J;
};

// An evaluation's lines per map row: what the searches found, from which E, its gradient and
// JᵀWJ follow for any loss scale without meeting the lines with image 2 again (sumLines).
struct LineSamples {
  std::vector<std::vector<LineSample>> rows;
};

// hints (one per cell of map 1, −1: none), if given, start each line's search at the bracket its
// last search found, and are updated: between nearby poses the bracket moves by a scanline or
// none, and the walk down the line from its top is spared.
LineSamples sampleLines(const ElevationMap& map1, const LocusMapper& image2, const PoseVector& nu, bool with_gradient,
                        const std::vector<Eigen::Vector3d>* reference_normals, int stride, bool weighted,
                        std::vector<int>* hints = nullptr, std::vector<double>* model_u = nullptr) {
  const MapGrid& grid = map1.grid();
  const LineModel model(nu, with_gradient);
  LineSamples out;
  out.rows.resize(std::size_t(grid.rows));
  tbb::parallel_for(tbb::blocked_range<int>(0, grid.rows), [&](const tbb::blocked_range<int>& range) {
    for (int r = range.begin(); r != range.end(); ++r) {
      if (r % stride != 0) continue;
      std::vector<LineSample>& row = out.rows[std::size_t(r)];
      for (int c = 0; c < grid.cols; c += stride) {
        LineTerm l;
        int* hint = hints ? &(*hints)[std::size_t(r) * grid.cols + c] : nullptr;
        if (!model.residual(map1, image2, r, c, weighted, l, hint)) continue;
        LineSample& sample = row.emplace_back();
        sample.col = c, sample.diff = l.diff, sample.u = l.u;
        sample.has_J = with_gradient && model.jacobian(image2, reference_normals, r * grid.cols + c, l, sample.J);
        if (sample.has_J) sample.J /= l.sigma;  // the normalized residual's (σ = 1 unweighted)
        if (model_u) {  // r/σ with the model's σ, σ² = σ₁² + σ₂² (normalizedResiduals'), per cell
          const double s1 = map1.sigma()(r, c);
          const double s = weighted ? l.sigma : std::sqrt(std::max(s1 * s1 + l.hit.sigma * l.hit.sigma, kSigmaFloor2));
          if (std::isfinite(s)) (*model_u)[std::size_t(r) * grid.cols + c] = l.diff / s;
        }
      }
    }
  });
  return out;
}

// E (robust with cauchy_c > 0), its gradient and JᵀWJ from an evaluation's lines, summed per row
// and the rows in order: the same sums whatever the threads did.
IconicError sumLines(const LineSamples& lines, double cauchy_c) {
  IconicError out;
  for (const std::vector<LineSample>& row : lines.rows) {
    RowSum sum;
    for (const LineSample& l : row) {
      const double w = cauchy_c > 0 ? 1.0 / (1.0 + l.u * l.u / (cauchy_c * cauchy_c)) : 1.0;
      sum.E += cauchy_c > 0 ? cauchy_c * cauchy_c * std::log1p(l.u * l.u / (cauchy_c * cauchy_c)) : l.u * l.u;
      sum.sum_r2 += l.diff * l.diff;
      sum.sum_u2 += l.u * l.u;
      ++sum.overlap;
      if (!l.has_J) continue;
      sum.gradient += 2 * w * l.u * l.J;
      sum.JtJ += w * l.J * l.J.transpose();
    }
    out.E += sum.E;
    out.sum_r2 += sum.sum_r2;
    out.sum_u2 += sum.sum_u2;
    out.gradient += sum.gradient;
    out.JtJ += sum.JtJ;
    out.overlap += sum.overlap;
  }
  return out;
}

// The cost (Cauchy scale c) of two evaluations over the lines both have: lines that enter or leave
// the overlap between them do not decide which is lower.
std::pair<double, double> commonCost(const LineSamples& a, const LineSamples& b, double c) {
  const auto rho = [&](double u) { return c > 0 ? c * c * std::log1p(u * u / (c * c)) : u * u; };
  double ea = 0, eb = 0;
  for (std::size_t r = 0; r < a.rows.size(); ++r) {
    const std::vector<LineSample>& ra = a.rows[r];
    const std::vector<LineSample>& rb = b.rows[r];
    std::size_t i = 0, j = 0;
    while (i < ra.size() && j < rb.size()) {
      if (ra[i].col < rb[j].col) ++i;
      else if (rb[j].col < ra[i].col) ++j;
      else ea += rho(ra[i++].u), eb += rho(rb[j++].u);
    }
  }
  return {ea, eb};
}

}  // namespace

IconicError iconicError(const ElevationMap& map1, const LocusMapper& image2, const PoseVector& nu, bool with_gradient,
                        double cauchy_c, const std::vector<Eigen::Vector3d>* reference_normals, int stride,
                        bool weighted) {
  return sumLines(sampleLines(map1, image2, nu, with_gradient, reference_normals, stride, weighted), cauchy_c);
}

std::vector<double> normalizedResiduals(const ElevationMap& map1, const LocusMapper& image2, const PoseVector& nu,
                                        int stride, const std::vector<int>* hints) {
  const MapGrid& g = map1.grid();
  std::vector<double> u(std::size_t(g.cells()), std::numeric_limits<double>::quiet_NaN());
  std::vector<int> start;
  if (hints && hints->size() == std::size_t(g.cells())) start = *hints;
  const LineSamples lines =
      sampleLines(map1, image2, nu, false, nullptr, std::max(1, stride), true, start.empty() ? nullptr : &start);
  for (int r = 0; r < g.rows; ++r)
    for (const LineSample& l : lines.rows[std::size_t(r)]) u[std::size_t(r) * g.cols + l.col] = l.u;
  return u;
}

IconicResult iconicGradientDescent(const ElevationMap& map1, const LocusMapper& image2, const PoseVector& nu0,
                                   const IconicOptions& options) {
  IconicResult res;
  res.nu = nu0;
  // LM's two departures (map 1's normals in the gradient, the annealed Cauchy loss) and its scale.
  const std::vector<Eigen::Vector3d> normals =
      options.descent_reference_normals ? referenceNormals(map1) : std::vector<Eigen::Vector3d>{};
  const double sigma_noise = medianSigma(map1);
  const double sigmas = options.descent_robust_loss ? options.robust_sigmas : 0.0;
  const double c_noise = sigmas * std::sqrt(2.0) * sigma_noise;
  const auto scale = [&](const IconicError& at) { return sigmas > 0 ? std::max(c_noise, 2 * rms(at)) : 0.0; };
  // The lines of the current estimate: E at a narrower loss is summed from them again, not searched.
  std::vector<int> hints(std::size_t(map1.grid().cells()), -1);  // each line's last bracket
  // One level, on the lines of the finest stride given (1 by default).
  const int stride = options.strides.empty() ? 1 : std::max(1, options.strides.back());
  const auto sample = [&](const PoseVector& nu) {
    return sampleLines(map1, image2, nu, true, options.descent_reference_normals ? &normals : nullptr, stride, false, &hints);
  };
  LineSamples lines = sample(res.nu);
  IconicError e = sumLines(lines, 0.0);
  record(res, e);
  double c = scale(e);
  if (c > 0) e = sumLines(lines, c);
  // The gain K = A·diag(AᵀHA)⁻¹·Aᵀ: ν = A·μ, μ = (r, t′) with the rotation about the centroid of
  // map 1's known cells (t = t′ + centroid × r), so that a yaw does not drag a translation with it
  // through the map's far-away origin; each μ_i then steps on its own scale 1/(AᵀHA)_ii.
  // Without it (descent_centroid_gain off) K is the identity. g = K·∂E/∂ν/2.
  Matrix6d A = Matrix6d::Identity();
  A.block<3, 3>(3, 0) = skew(knownCentroid(map1));
  const auto direction = [&](const IconicError& at) -> PoseVector {
    if (!options.descent_centroid_gain) return 0.5 * at.gradient;
    const PoseVector scaled = (A.transpose() * at.JtJ * A).diagonal().cwiseMax(1e-12);
    return A * (0.5 * A.transpose() * at.gradient).cwiseQuotient(scaled);
  };
  if (!options.descent_backtracking && e.overlap > 6) {
    // One gain for the run and the paper descent's stop rules (iconicPaperDescent): ν ← ν − gain·K·∂E/∂ν,
    // gain = paper_gain/λ_max(K·H at ν0), whose eigenvalues are H's, or with the centroid gain those of
    // D^-½·AᵀHA·D^-½, D = diag(AᵀHA). With every departure off this is iconicPaperDescent, bit for bit.
    Matrix6d M = e.JtJ;
    if (options.descent_centroid_gain) {
      const PoseVector d = (A.transpose() * e.JtJ * A).diagonal().cwiseMax(1e-12).cwiseSqrt().cwiseInverse();
      M = d.asDiagonal() * (A.transpose() * e.JtJ * A) * d.asDiagonal();
    }
    const double lambda_max = Eigen::SelfAdjointEigenSolver<Matrix6d>(M).eigenvalues()(5);
    const double gain = lambda_max > 0 ? options.paper_gain / lambda_max : 0.0;
    while (gain > 0) {
      if (rms(e) < options.floor_m) {
        res.converged = true;
        break;
      }
      if (res.iterations >= options.paper_max_iterations) break;
      ++res.iterations;
      const PoseVector next = res.nu - 2 * gain * direction(e);
      LineSamples next_lines = sample(next);
      const IconicError t = sumLines(next_lines, c);
      if (t.overlap <= 6) break;
      if (!(t.E < e.E)) {  // E as printed, each pose's over its own lines; the lower E kept
        res.converged = (t.E - e.E) / e.E < options.min_relative_decrease;
        break;
      }
      const double decrease = (e.E - t.E) / e.E;
      res.nu = next, e = t, lines = std::move(next_lines);
      record(res, e);
      if (decrease < options.min_relative_decrease) {
        res.converged = true;
        break;
      }
      const double c_next = scale(e);
      if (c_next < c) c = c_next, e = sumLines(lines, c);  // the loss narrows with the residuals
    }
  }
  double k = 0.5;  // the step in units of that gain, adapted from there
  for (; options.descent_backtracking && res.iterations < options.max_iterations && e.overlap > 6; ++res.iterations) {
    if (rms(e) < options.floor_m) {
      res.converged = true;
      break;
    }
    const PoseVector g = direction(e);
    bool stepped = false;
    for (int halvings = 0; halvings < 40 && !stepped; ++halvings, k *= 0.5) {
      const PoseVector trial = res.nu - k * g;
      LineSamples trial_lines = sample(trial);
      const IconicError t = sumLines(trial_lines, c);
      const auto [e_now, e_trial] = commonCost(lines, trial_lines, c);
      if (t.overlap > 6 && e_trial < e_now) {
        const double decrease = (e_now - e_trial) / e_now;
        res.nu = trial, e = t, lines = std::move(trial_lines), stepped = true;
        record(res, e);
        res.converged = decrease < options.min_relative_decrease && c == c_noise;
        const double c_next = scale(e);
        if (c_next < c) c = c_next, e = sumLines(lines, c);  // the loss narrows with the residuals
      }
    }
    if (!stepped || res.converged) {
      res.converged = true;  // no step lowers E: a minimum at this resolution
      ++res.iterations;
      break;
    }
    k *= 4;  // undo the last halving and try a longer step next time
  }
  // Its own cost (map 1's normals, the loss's last scale) in metres: σ of a line's residual, the
  // difference of two maps, √2·σ̃.
  res.step_mahalanobis2 = stepMahalanobis2(e, 2 * sigma_noise * sigma_noise);
  res.residuals_u.assign(std::size_t(map1.grid().cells()), std::numeric_limits<double>::quiet_NaN());
  finishResult(res, map1,
               sumLines(sampleLines(map1, image2, res.nu, true, nullptr, 1, false, &hints, &res.residuals_u), 0.0));
  res.hints = std::move(hints);
  return res;
}

IconicResult iconicPaperDescent(const ElevationMap& map1, const LocusMapper& image2, const PoseVector& nu0,
                                const IconicOptions& options) {
  IconicResult res;
  res.nu = nu0;
  // Eq. 6–8 as printed: plain squares, image 2's normals, every line.
  const auto evaluate = [&](const PoseVector& nu) { return iconicError(map1, image2, nu, true, 0, nullptr, 1, false); };
  IconicError e = evaluate(res.nu);
  record(res, e);
  // One gain for the run, from JᵀJ at ν0: k·λ_max = paper_gain (stable below 1).
  const double lambda_max = e.overlap > 6 ? Eigen::SelfAdjointEigenSolver<Matrix6d>(e.JtJ).eigenvalues()(5) : 0.0;
  const double k = lambda_max > 0 ? options.paper_gain / lambda_max : 0.0;
  while (e.overlap > 6 && k > 0) {
    if (rms(e) < options.floor_m) {  // E as small as the sensor allows
      res.converged = true;
      break;
    }
    if (res.iterations >= options.paper_max_iterations) break;
    ++res.iterations;
    const PoseVector next = res.nu - k * e.gradient;  // eq. 4 with its sign corrected
    const IconicError t = evaluate(next);
    if (t.overlap <= 6) break;  // no match left to compare
    if (!(t.E < e.E)) {
      // ΔE ≥ 0: keep the lower E; converged if ΔE is small.
      res.converged = (t.E - e.E) / e.E < options.min_relative_decrease;
      break;
    }
    const double decrease = (e.E - t.E) / e.E;
    res.nu = next, e = t;
    record(res, e);
    if (decrease < options.min_relative_decrease) {
      res.converged = true;
      break;
    }
  }
  finishResult(res, map1, e);  // e: the plain error at res.nu
  const double sigma_noise = medianSigma(map1);
  res.step_mahalanobis2 = stepMahalanobis2(e, 2 * sigma_noise * sigma_noise);
  return res;
}

namespace {

// weightedCovariance with each line's search started at its hint (one per cell of map 1).
Matrix6d covarianceWithHints(const ElevationMap& map1, const LocusMapper& image2, const PoseVector& nu, double c,
                             const std::vector<Eigen::Vector3d>& reference_normals, const LocusMapper* map1_source,
                             std::vector<int>* hints, bool influence_bread);

// LM on the plain residuals (weighted = false) or on r/σ; `c_final` receives the loss's last scale.
// hints: one per cell of map 1 (−1 at first), each line's last bracket, for the caller's last
// evaluation too.
IconicResult levenbergMarquardt(const ElevationMap& map1, const LocusMapper& image2, const PoseVector& nu0,
                                const IconicOptions& options, const std::vector<Eigen::Vector3d>& normals,
                                bool weighted, double& c_final, std::vector<int>& hints) {
  IconicResult res;
  res.nu = nu0;
  // The loss's narrowest scale: robust_sigmas σ of a residual, σ of the difference of two maps
  // (√2·σ̃ in metres), or 1 for r/σ.
  // σ of a line's residual in the cost's units: a difference of two maps, √2·σ̃ (metres), or 1.
  const double sigma_line = weighted ? 1.0 : std::sqrt(2.0) * medianSigma(map1);
  const double c_noise = options.robust_sigmas * sigma_line;
  const auto spread = [&](const IconicError& at) { return weighted ? rmsNormalized(at) : rms(at); };
  const auto scale = [&](const IconicError& at) { return options.robust_sigmas > 0 ? std::max(c_noise, 2 * spread(at)) : 0.0; };
  const double half_diagonal = 0.5 * std::hypot(map1.grid().cols * map1.grid().cell, map1.grid().rows * map1.grid().cell);
  const std::vector<int> strides = options.strides.empty() ? std::vector<int>{1} : options.strides;
  double c = 0;
  for (std::size_t level = 0; level < strides.size(); ++level) {
    const int stride = std::max(1, strides[level]);
    // The lines of the current estimate: E at a narrower loss is summed from them again, not searched.
    const auto sample = [&](const PoseVector& nu) {
      return sampleLines(map1, image2, nu, true, &normals, stride, weighted, &hints);
    };
    LineSamples lines = sample(res.nu);
    IconicError e = sumLines(lines, 0.0);
    c = scale(e);
    if (c > 0) e = sumLines(lines, c);
    if (level == 0) record(res, e);
    // A step's largest motion of a line point: its translation plus its rotation at the map's half
    // diagonal.
    const auto motion = [&](const PoseVector& d) { return d.tail<3>().norm() + d.head<3>().norm() * half_diagonal; };
    double lambda = 1e-3;
    bool converged = false;
    const bool polish = weighted && level + 1 == strides.size() && options.polish_iterations > 0;
    for (; res.iterations < options.max_iterations && e.overlap > 6;) {
      ++res.iterations;
      if (rms(e) < options.floor_m) {
        converged = true;
        break;
      }
      bool stepped = false;
      double rejected = std::numeric_limits<double>::infinity();  // the motion of the last step refused
      for (int tries = 0; tries < 12 && !stepped; ++tries) {
        PoseVector delta;
        // A retry at least halves the refused step: a larger λ that hardly shortens it (λ ≪ 1 next to
        // diag JᵀJ) would evaluate the same step again.
        for (int grow = 0; grow < 24; ++grow, lambda *= 10) {
          Matrix6d A = e.JtJ;
          A.diagonal() += lambda * e.JtJ.diagonal();
          delta = A.ldlt().solve(-0.5 * e.gradient);  // Jᵀr = ∂E/∂ν / 2 (weighted)
          if (motion(delta) <= 0.5 * rejected) break;
        }
        // A retry that moves no line point more than min_step_m: converged (the rule for steps taken).
        if (tries > 0 && motion(delta) < options.min_step_m) break;
        LineSamples trial_lines = sample(res.nu + delta);
        const IconicError t = sumLines(trial_lines, c);
        const auto [e_now, e_trial] = commonCost(lines, trial_lines, c);
        if (t.overlap > 6 && e_trial < e_now) {
          const double decrease = (e_now - e_trial) / e_now;
          res.nu += delta, e = t, lines = std::move(trial_lines), stepped = true, lambda = std::max(lambda / 10, 1e-12);
          record(res, e);
          const double moved = motion(delta);
          converged = decrease < options.min_relative_decrease || moved < options.min_step_m;
          // The loss narrows with the residuals; the cost at the new scale is evaluated afresh, and
          // a narrower loss can still move the estimate.
          const double c_next = scale(e);
          if (c_next < c) {
            c = c_next;
            e = sumLines(lines, c);
            converged = moved < options.min_step_m && c == c_noise;
          }
        } else {
          rejected = motion(delta);
          lambda *= 10;
          // At the narrowest loss on the last level, a step the cost refuses hands over to the
          // polish below: the cost's staircase, not the estimate, refused it, and the retries LM
          // would spend shortening it are what the polish's steps cost instead.
          if (polish && c == c_noise) break;
        }
      }
      if (!stepped || converged) {
        converged = true;
        break;
      }
    }
    if (polish && e.overlap > 6) {
      // The root of the estimating equation Σ g·r = 0 that the covariance describes, not the local
      // minimum of the cost LM stopped in: image 2's counts make the cost a staircase with a
      // minimum every few millimetres, so LM stops wherever it first meets one, and where that is
      // depends on where it started (docs/matching.md, "Calibration"). Gauss–Newton steps taken
      // whatever the cost says, kept only if they contract (each shorter than the one before) and
      // the first is inside the estimate's own 99.9 % region (IconicOptions).
      // (`lines` is not read after the last level: the polish samples its own.)
      const PoseVector before = res.nu;
      const IconicError e_before = e;
      const int iterations_before = res.iterations;
      const std::size_t recorded = res.rms_m.size();
      double last = std::numeric_limits<double>::infinity();
      bool revert = false;
      for (int it = 0; it < options.polish_iterations; ++it) {
        const PoseVector delta = e.JtJ.ldlt().solve(-0.5 * e.gradient);
        const double moved = motion(delta);
        if (!(moved < last) || (it == 0 && !(delta.dot(e.JtJ * delta) <= options.polish_max_mahalanobis2))) {
          revert = true;
          break;
        }
        const IconicError t = sumLines(sample(res.nu + delta), c);
        if (t.overlap <= 6) {
          revert = true;
          break;
        }
        ++res.iterations;
        res.nu += delta, e = t, last = moved;
        record(res, e);
        if (moved < options.min_step_m) break;
      }
      if (revert) {
        res.nu = before, e = e_before, res.iterations = iterations_before;
        res.rms_m.resize(recorded), res.E_m2.resize(recorded), res.lines.resize(recorded);
      }
    }
    res.converged = converged;
    // Its own cost at the level's end (the last level's is kept).
    res.step_mahalanobis2 = stepMahalanobis2(e, sigma_line * sigma_line);
  }
  c_final = c;
  return res;
}

}  // namespace

IconicResult iconicLevenbergMarquardt(const ElevationMap& map1, const LocusMapper& image2, const PoseVector& nu0,
                                      const IconicOptions& options) {
  double c = 0;
  std::vector<int> hints(std::size_t(map1.grid().cells()), -1);
  IconicResult res = levenbergMarquardt(map1, image2, nu0, options, referenceNormals(map1), false, c, hints);
  res.residuals_u.assign(std::size_t(map1.grid().cells()), std::numeric_limits<double>::quiet_NaN());
  finishResult(res, map1,
               sumLines(sampleLines(map1, image2, res.nu, true, nullptr, 1, false, &hints, &res.residuals_u), 0.0));
  res.hints = std::move(hints);
  return res;
}

IconicResult iconicWeighted(const ElevationMap& map1, const LocusMapper& image2, const PoseVector& nu0,
                            const IconicOptions& options) {
  const std::vector<Eigen::Vector3d> normals = referenceNormals(map1);
  double c = 0;
  std::vector<int> hints(std::size_t(map1.grid().cells()), -1);
  IconicResult res = levenbergMarquardt(map1, image2, nu0, options, normals, true, c, hints);
  // Whether the surface constrains every motion is a matter of its shape, not of the σ's: the
  // unweighted JᵀJ decides it (weights that differ by 100 between level ground and a rock's
  // flank would otherwise name the rock's directions free).
  res.residuals_u.assign(std::size_t(map1.grid().cells()), std::numeric_limits<double>::quiet_NaN());
  const IconicError e =
      sumLines(sampleLines(map1, image2, res.nu, true, &normals, 1, false, &hints, &res.residuals_u), 0.0);
  res.overlap = e.overlap;
  const MapGrid& g = map1.grid();
  const Degeneracy d = degeneracy(e.JtJ, 0.5 * std::hypot(g.cols * g.cell, g.rows * g.cell), knownCentroid(map1));
  res.degenerate = d.degenerate;
  res.free_directions = d.free_directions;
  if (e.overlap > 6 && !d.degenerate)
    res.covariance =
        covarianceWithHints(map1, image2, res.nu, c, normals, options.map1_source, &hints, options.influence_bread);
  else res.covariance.setConstant(std::numeric_limits<double>::quiet_NaN());
  res.hints = std::move(hints);
  return res;
}

namespace {

// A crossing's pixels in `image`: the 2×2 cell around (φ, θ) and its bilinear weights, scaled to
// unit length (Σw² = 1), as flat pixel indices.
struct PixelShare {
  long index[4];
  double weight[4];
};

PixelShare pixelShare(const RangeImage& image, double phi, double theta) {
  const int rows = image.rows(), cols = image.cols();
  const double dphi = rows > 1 ? image.phi[0] - image.phi[1] : 1.0, dtheta = cols > 1 ? image.theta[1] - image.theta[0] : 1.0;
  const double row = std::clamp((image.phi[0] - phi) / dphi, 0.0, double(rows - 1));
  const double col = std::clamp((theta - image.theta[0]) / dtheta, 0.0, double(cols - 1));
  const int r0 = std::min(int(row), std::max(rows - 2, 0)), c0 = std::min(int(col), std::max(cols - 2, 0));
  const double fr = row - r0, fc = col - c0;
  PixelShare p;
  const double w[4] = {(1 - fr) * (1 - fc), (1 - fr) * fc, fr * (1 - fc), fr * fc};
  const double norm = std::sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2] + w[3] * w[3]);
  for (int k = 0; k < 4; ++k) {
    p.index[k] = long(r0 + k / 2) * cols + (c0 + k % 2);
    p.weight[k] = w[k] / norm;
  }
  return p;
}

// One line's share of the sandwich: its weighted Jacobian g = w·J/σ², its two σ's, and the pixels
// of each image it reads.
struct LineShare {
  PoseVector g;
  double sigma1, sigma2;
  PixelShare pixels1, pixels2;
};

}  // namespace

Matrix6d weightedCovariance(const ElevationMap& map1, const LocusMapper& image2, const PoseVector& nu, double c,
                            const std::vector<Eigen::Vector3d>& reference_normals, const LocusMapper* map1_source,
                            bool influence_bread) {
  return covarianceWithHints(map1, image2, nu, c, reference_normals, map1_source, nullptr, influence_bread);
}

namespace {

Matrix6d covarianceWithHints(const ElevationMap& map1, const LocusMapper& image2, const PoseVector& nu, double c,
                             const std::vector<Eigen::Vector3d>& reference_normals, const LocusMapper* map1_source,
                             std::vector<int>* hints, bool influence_bread) {
  const MapGrid& grid = map1.grid();
  const LineModel model(nu, true);
  std::vector<std::vector<LineShare>> rows(grid.rows);
  std::vector<Matrix6d> A_rows(grid.rows, Matrix6d::Zero());
  tbb::parallel_for(tbb::blocked_range<int>(0, grid.rows), [&](const tbb::blocked_range<int>& range) {
    for (int r = range.begin(); r != range.end(); ++r)
      for (int col = 0; col < grid.cols; ++col) {
        LineTerm l;
        PoseVector J;
        int* hint = hints ? &(*hints)[std::size_t(r) * grid.cols + col] : nullptr;
        if (!model.residual(map1, image2, r, col, true, l, hint) ||
            !model.jacobian(image2, &reference_normals, long(r) * grid.cols + col, l, J))
          continue;
        const double w = c > 0 ? 1.0 / (1.0 + l.u * l.u / (c * c)) : 1.0;
        LineShare share;
        share.g = w * J / (l.sigma * l.sigma);
        share.sigma1 = map1.sigma()(r, col);
        share.sigma2 = std::sqrt(std::max(l.sigma * l.sigma - share.sigma1 * share.sigma1, 0.0));
        share.pixels2 = pixelShare(image2.image(), l.hit.phi, l.hit.theta);
        share.pixels1 = share.pixels2;  // without map 1's image: its lines share as image 2's do
        if (map1_source) {
          const LocusHit h1 = map1_source->intersect(l.base, model.v);
          if (h1.state == CellState::Known) share.pixels1 = pixelShare(map1_source->image(), h1.phi, h1.theta);
        }
        // How r moves with ν where the line actually meets image 2: its own bilinear patch's normal
        // (the counts' staircase, the noise), not map 1's smooth one that g takes.
        PoseVector J2;
        if (!model.jacobian(image2, nullptr, long(r) * grid.cols + col, l, J2)) J2 = J;
        // influence_bread: A as the derivative of the estimating equation Σ ψ(u)·J/σ, the Cauchy
        // influence ψ(u) = u/(1 + u²/c²) having ψ′(u) = w·(1 − u²/c²)/(1 + u²/c²), instead of the
        // weight w that the Gauss–Newton matrix holds fixed (docs/matching.md, "Calibration").
        const double q = influence_bread && c > 0 ? l.u * l.u / (c * c) : 0.0;
        A_rows[r] += ((1 - q) / (1 + q)) * share.g * J2.transpose();
        rows[r].push_back(share);
      }
  });
  // Per pixel, the sum of σ·(its weight)·g over the lines that read it; S = Σ G·Gᵀ over the pixels
  // of both images.
  const RangeImage& im2 = image2.image();
  const RangeImage& im1 = map1_source ? map1_source->image() : im2;
  std::vector<PoseVector> G1(std::size_t(im1.rows()) * im1.cols(), PoseVector::Zero()),
      G2(std::size_t(im2.rows()) * im2.cols(), PoseVector::Zero());
  Matrix6d A = Matrix6d::Zero();
  for (int r = 0; r < grid.rows; ++r) {  // in row order: deterministic sums
    A += A_rows[r];
    for (const LineShare& l : rows[r])
      for (int k = 0; k < 4; ++k) {
        G1[std::size_t(l.pixels1.index[k])] += l.sigma1 * l.pixels1.weight[k] * l.g;
        G2[std::size_t(l.pixels2.index[k])] += l.sigma2 * l.pixels2.weight[k] * l.g;
      }
  }
  Matrix6d S = Matrix6d::Zero();
  for (const PoseVector& g : G1) S += g * g.transpose();
  for (const PoseVector& g : G2) S += g * g.transpose();
  const Matrix6d Ainv = A.partialPivLu().solve(Matrix6d::Identity());
  const Matrix6d P = Ainv * S * Ainv.transpose();
  return 0.5 * (P + P.transpose());
}

}  // namespace

}  // namespace ambler::perception
