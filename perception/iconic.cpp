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
  double E = 0;
  PoseVector gradient = PoseVector::Zero();
  Matrix6d JtJ = Matrix6d::Zero();
  long overlap = 0;
};

double meanSquare(const IconicError& e) { return e.overlap ? e.E / double(e.overlap) : 0.0; }

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

IconicError iconicError(const ElevationMap& map1, const LocusMapper& image2, const PoseVector& nu, bool with_gradient) {
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
      for (int c = 0; c < grid.cols; ++c) {
        if (map1.stateAt(r, c) != CellState::Known) continue;
        const Eigen::Vector2d xy = grid.center(r, c);
        const Eigen::Vector3d u(xy.x(), xy.y(), 0.0);
        const Eigen::Vector3d u2 = R * u + t, v2 = R * v;
        const LocusHit hit = image2.intersect(u2, v2);
        if (hit.state != CellState::Known) continue;
        // g = T⁻¹·f₂ = u + s·v: f₁ − g is (z₁ − s)·v.
        const double diff = double(map1.elevation()(r, c)) - hit.s;
        sum.E += diff * diff;
        ++sum.overlap;
        if (!with_gradient) continue;
        const Eigen::Vector3d n = image2.surfaceNormal(hit);
        const double nv = n.dot(v2);
        if (std::abs(nv) < 1e-12) continue;  // the line grazes the surface: no derivative
        // The residual diff = z₁ − s has the Jacobian J = −∂s/∂ν.
        PoseVector J;
        for (int k = 0; k < 3; ++k) J(k) = n.dot(dR[k] * u + hit.s * (dR[k] * v)) / nv;
        for (int k = 0; k < 3; ++k) J(3 + k) = n(k) / nv;
        sum.gradient += 2 * diff * J;
        sum.JtJ += J * J.transpose();
      }
    }
  });
  IconicError out;
  for (const RowSum& s : rows) {  // in row order: the same sums whatever the threads did
    out.E += s.E;
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
  IconicError e = iconicError(map1, image2, res.nu);
  res.rms_m.push_back(std::sqrt(meanSquare(e)));
  double lambda = 1e-3;
  for (; res.iterations < options.max_iterations && e.overlap > 6; ++res.iterations) {
    if (std::sqrt(meanSquare(e)) < options.floor_m) {
      res.converged = true;
      break;
    }
    bool stepped = false;
    for (int tries = 0; tries < 12 && !stepped; ++tries) {
      Matrix6d A = e.JtJ;
      A.diagonal() += lambda * e.JtJ.diagonal();
      const PoseVector delta = A.ldlt().solve(-0.5 * e.gradient);  // Jᵀr = ∂E/∂ν / 2
      const IconicError t = iconicError(map1, image2, res.nu + delta);
      if (t.overlap > 6 && meanSquare(t) < meanSquare(e)) {
        const double decrease = (meanSquare(e) - meanSquare(t)) / meanSquare(e);
        res.nu += delta, e = t, stepped = true, lambda = std::max(lambda / 10, 1e-12);
        res.rms_m.push_back(std::sqrt(meanSquare(e)));
        if (decrease < options.min_relative_decrease) res.converged = true;
      } else {
        lambda *= 10;
      }
    }
    if (!stepped || res.converged) {
      res.converged = true;
      ++res.iterations;
      break;
    }
  }
  finishResult(res, map1, image2);
  return res;
}

}  // namespace ambler::perception
