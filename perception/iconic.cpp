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

// One map row's share of E and its gradient.
struct RowSum {
  double E = 0, sum_r2 = 0;
  PoseVector gradient = PoseVector::Zero();
  Matrix6d JtJ = Matrix6d::Zero();
  long overlap = 0;
};

double meanSquare(const IconicError& e) { return e.overlap ? e.E / double(e.overlap) : 0.0; }
double rms(const IconicError& e) { return e.overlap ? std::sqrt(e.sum_r2 / double(e.overlap)) : 0.0; }

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

void finishResult(IconicResult& res, const ElevationMap& map1, const LocusMapper& image2) {
  const IconicError e = iconicError(map1, image2, res.nu);
  res.overlap = e.overlap;
  // Rotations weigh as the motion they give at half the map's diagonal.
  const MapGrid& g = map1.grid();
  const Degeneracy d = degeneracy(e.JtJ, 0.5 * std::hypot(g.cols * g.cell, g.rows * g.cell));
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

Degeneracy degeneracy(const Matrix6d& JtJ, double length_m, double ratio) {
  PoseVector s;
  s << 1 / length_m, 1 / length_m, 1 / length_m, 1, 1, 1;  // ν = S·μ with μ in metres
  const Matrix6d M = s.asDiagonal() * JtJ * s.asDiagonal();
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

IconicError iconicError(const ElevationMap& map1, const LocusMapper& image2, const PoseVector& nu, bool with_gradient,
                        double cauchy_c, const std::vector<Eigen::Vector3d>* reference_normals, int stride) {
  const MapGrid& grid = map1.grid();
  const Eigen::Isometry3d T = poseFromVector(nu);
  const Eigen::Matrix3d R = T.linear();
  const Eigen::Vector3d t = T.translation();
  const Eigen::Vector3d v(0, 0, 1);
  Eigen::Matrix3d dR[3];
  if (with_gradient)
    for (int k = 0; k < 3; ++k) dR[k] = rotationDerivative(nu.head<3>(), k);
  std::vector<RowSum> rows(grid.rows);
  tbb::parallel_for(tbb::blocked_range<int>(0, grid.rows), [&](const tbb::blocked_range<int>& range) {
    for (int r = range.begin(); r != range.end(); ++r) {
      RowSum& sum = rows[r];
      if (r % stride != 0) continue;
      for (int c = 0; c < grid.cols; c += stride) {
        if (map1.stateAt(r, c) != CellState::Known) continue;
        const Eigen::Vector2d xy = grid.center(r, c);
        const Eigen::Vector3d u(xy.x(), xy.y(), 0.0);
        const Eigen::Vector3d u2 = R * u + t, v2 = R * v;
        const LocusHit hit = image2.intersect(u2, v2);
        if (hit.state != CellState::Known) continue;
        // g = T⁻¹·f₂ = u + s·v: f₁ − g is (z₁ − s)·v.
        const double diff = double(map1.elevation()(r, c)) - hit.s;
        const double w = cauchy_c > 0 ? 1.0 / (1.0 + diff * diff / (cauchy_c * cauchy_c)) : 1.0;
        sum.E += cauchy_c > 0 ? cauchy_c * cauchy_c * std::log1p(diff * diff / (cauchy_c * cauchy_c)) : diff * diff;
        sum.sum_r2 += diff * diff;
        ++sum.overlap;
        if (!with_gradient) continue;
        const Eigen::Vector3d* ref = reference_normals ? &(*reference_normals)[std::size_t(r) * grid.cols + c] : nullptr;
        const Eigen::Vector3d n = ref && std::isfinite(ref->x()) ? Eigen::Vector3d(R * *ref) : image2.surfaceNormal(hit);
        const double nv = n.dot(v2);
        if (std::abs(nv) < 1e-12) continue;  // the line grazes the surface: no derivative
        // The residual diff = z₁ − s has the Jacobian J = −∂s/∂ν.
        PoseVector J;
        for (int k = 0; k < 3; ++k) J(k) = n.dot(dR[k] * u + hit.s * (dR[k] * v)) / nv;
        for (int k = 0; k < 3; ++k) J(3 + k) = n(k) / nv;
        sum.gradient += 2 * w * diff * J;
        sum.JtJ += w * J * J.transpose();
      }
    }
  });
  IconicError out;
  for (const RowSum& s : rows) {  // in row order: the same sums whatever the threads did
    out.E += s.E;
    out.sum_r2 += s.sum_r2;
    out.gradient += s.gradient;
    out.JtJ += s.JtJ;
    out.overlap += s.overlap;
  }
  return out;
}

IconicResult iconicGradientDescent(const ElevationMap& map1, const LocusMapper& image2, const PoseVector& nu0,
                                   const IconicOptions& options) {
  IconicResult res;
  res.nu = nu0;
  IconicError e = iconicError(map1, image2, res.nu);
  res.rms_m.push_back(std::sqrt(meanSquare(e)));
  double k = 0.5;  // the step in units of the per-parameter scale below, adapted from there
  for (; res.iterations < options.max_iterations && e.overlap > 6; ++res.iterations) {
    if (std::sqrt(meanSquare(e)) < options.floor_m) {
      res.converged = true;
      break;
    }
    // k per parameter: 1/(JᵀJ)_ii, so that a rotation in radians and a translation in metres take
    // steps of their own scale (a scalar k would move one and not the other).
    const PoseVector g = (0.5 * e.gradient).cwiseQuotient(e.JtJ.diagonal().cwiseMax(1e-12));
    bool stepped = false;
    for (int halvings = 0; halvings < 40 && !stepped; ++halvings, k *= 0.5) {
      const PoseVector trial = res.nu - k * g;
      const IconicError t = iconicError(map1, image2, trial);
      if (t.overlap > 6 && meanSquare(t) < meanSquare(e)) {
        const double decrease = (meanSquare(e) - meanSquare(t)) / meanSquare(e);
        res.nu = trial, e = t, stepped = true;
        res.rms_m.push_back(std::sqrt(meanSquare(e)));
        if (decrease < options.min_relative_decrease) res.converged = true;
      }
    }
    if (!stepped || res.converged) {
      res.converged = true;  // no step lowers E: a minimum at this resolution
      ++res.iterations;
      break;
    }
    k *= 4;  // undo the last halving and try a longer step next time
  }
  finishResult(res, map1, image2);
  return res;
}

IconicResult iconicLevenbergMarquardt(const ElevationMap& map1, const LocusMapper& image2, const PoseVector& nu0,
                                      const IconicOptions& options) {
  IconicResult res;
  res.nu = nu0;
  const double c_noise = options.robust_sigmas * std::sqrt(2.0) * medianSigma(map1);
  const auto scale = [&](const IconicError& at) { return options.robust_sigmas > 0 ? std::max(c_noise, 2 * rms(at)) : 0.0; };
  const std::vector<Eigen::Vector3d> normals = referenceNormals(map1);
  const double half_diagonal = 0.5 * std::hypot(map1.grid().cols * map1.grid().cell, map1.grid().rows * map1.grid().cell);
  const std::vector<int> strides = options.strides.empty() ? std::vector<int>{1} : options.strides;
  for (std::size_t level = 0; level < strides.size(); ++level) {
    const int stride = std::max(1, strides[level]);
    const auto eval = [&](const PoseVector& nu, double c) { return iconicError(map1, image2, nu, true, c, &normals, stride); };
    IconicError e = eval(res.nu, 0.0);
    double c = scale(e);
    if (c > 0) e = eval(res.nu, c);
    if (level == 0) res.rms_m.push_back(rms(e));
    double lambda = 1e-3;
    bool converged = false;
    for (; res.iterations < options.max_iterations && e.overlap > 6;) {
      ++res.iterations;
      if (rms(e) < options.floor_m) {
        converged = true;
        break;
      }
      bool stepped = false;
      for (int tries = 0; tries < 12 && !stepped; ++tries) {
        Matrix6d A = e.JtJ;
        A.diagonal() += lambda * e.JtJ.diagonal();
        const PoseVector delta = A.ldlt().solve(-0.5 * e.gradient);  // Jᵀr = ∂E/∂ν / 2 (weighted)
        const IconicError t = eval(res.nu + delta, c);
        if (t.overlap > 6 && meanSquare(t) < meanSquare(e)) {
          const double decrease = (meanSquare(e) - meanSquare(t)) / meanSquare(e);
          res.nu += delta, e = t, stepped = true, lambda = std::max(lambda / 10, 1e-12);
          res.rms_m.push_back(rms(e));
          // The step's largest motion of a line point: its translation plus its rotation at the
          // map's half diagonal.
          const double moved = delta.tail<3>().norm() + delta.head<3>().norm() * half_diagonal;
          converged = decrease < options.min_relative_decrease || moved < options.min_step_m;
          // The loss narrows with the residuals; the cost at the new scale is evaluated afresh, and
          // a narrower loss can still move the estimate.
          const double c_next = scale(e);
          if (c_next < c) {
            c = c_next;
            e = eval(res.nu, c);
            converged = moved < options.min_step_m && c == c_noise;
          }
        } else {
          lambda *= 10;
        }
      }
      if (!stepped || converged) {
        converged = true;
        break;
      }
    }
    res.converged = converged;
  }
  finishResult(res, map1, image2);
  return res;
}

IconicResult registerIconic(const ElevationMap& map_i, const RangeImage& image_j, const Raster<std::uint8_t>* edges_j,
                            const LocusConfig& config, IconicMethod method, const IconicOptions& options) {
  // Image J in the frame the rover believes; ν starts at the identity (it trusts its belief).
  const LocusMapper mapper(image_j, edges_j, config);
  return method == IconicMethod::Descent ? iconicGradientDescent(map_i, mapper, PoseVector::Zero(), options)
                                         : iconicLevenbergMarquardt(map_i, mapper, PoseVector::Zero(), options);
}

Eigen::Isometry3d correctedPose(const IconicResult& result, const Eigen::Isometry3d& believed_WS) {
  return poseFromVector(result.nu).inverse() * believed_WS;
}

}  // namespace ambler::perception
