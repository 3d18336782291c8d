#include "perception/feature_matching.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>

namespace ambler::perception {

namespace {

constexpr double kPi = 3.14159265358979323846;

void checkConfig(const FeatureMatchConfig& c) {
  const bool ok = c.max_rotation_deg > 0 && c.max_rotation_deg <= 180 && c.max_shift_m > 0 && c.strength_ratio >= 0 &&
                  c.strength_ratio <= 1 && c.length_ratio >= 0 && c.length_ratio <= 1 && c.length_slack_m >= 0 &&
                  c.tolerance_m > 0 && c.search_features >= 1 && c.pairs_per_hypothesis >= 2 &&
                  c.min_spread_m >= 0 && c.max_nodes >= 1 && c.d_max_m > 0 && c.inlier_m > 0 && c.refits >= 0 && c.keep_ranked >= 0;
  if (!ok) throw std::invalid_argument("FeatureMatchConfig: a value is out of range");
}

// Predict: whether features a (map 1) and b (map 2) may be the same.
bool similar(const Feature& a, const Feature& b, const FeatureMatchConfig& c) {
  if (a.type != b.type) return false;
  if (std::abs(a.strength - b.strength) > c.strength_ratio * std::max(a.strength, b.strength)) return false;
  if (a.type == FeatureType::Line &&
      std::abs(a.length_m - b.length_m) > c.length_ratio * std::max(a.length_m, b.length_m) + c.length_slack_m)
    return false;
  return true;
}

// The closed-form fit of a pairing: point and region centres paired; a line contributes its
// centre and its direction, scaled by half its (shorter) length so that an angle costs what it
// moves the line's ends. Line 2's direction is signed to agree with line 1's under `T_guess`.
std::optional<Eigen::Isometry3d> fitPairing(const std::vector<Feature>& f1, const std::vector<Feature>& f2,
                                            const std::vector<std::pair<int, int>>& pairs,
                                            const Eigen::Isometry3d& T_guess, bool project_lines) {
  std::vector<Eigen::Vector3d> a, b, d, e;
  for (const auto& [i, j] : pairs) {
    const Feature& p = f1[i];
    const Feature& q = f2[j];
    a.push_back(p.position);
    if (p.type == FeatureType::Line) {
      Eigen::Vector3d dq = q.direction;
      if ((T_guess.linear() * p.direction).dot(dq) < 0) dq = -dq;
      // Where line 1's centre lands along line 2: its foot there (a line's ends, hence its centre,
      // depend on what each view saw of it), once a transform is known.
      Eigen::Vector3d target = q.position;
      if (project_lines) {
        const Eigen::Vector3d m = T_guess * p.position;
        target = q.position + dq * dq.dot(m - q.position);
      }
      b.push_back(target);
      const double half = 0.5 * std::min(p.length_m, q.length_m);
      d.push_back(half * p.direction);
      e.push_back(half * dq);
    } else {
      b.push_back(q.position);
    }
  }
  return fitRigid(a, b, d, e, 1.0);
}

}  // namespace

Feature transformed(const Feature& f, const Eigen::Isometry3d& T) {
  Feature g = f;
  g.position = T * f.position;
  g.direction = T.linear() * f.direction;
  return g;
}

double featureDistance(const Feature& a, const Feature& b) {
  const Eigen::Vector3d delta = a.position - b.position;
  if (a.type != FeatureType::Line || b.type != FeatureType::Line) return delta.norm();
  const Eigen::Vector3d& u = b.direction;
  const double along = delta.dot(u);
  const double perpendicular = (delta - along * u).norm();
  const double sin_angle = a.direction.cross(u).norm();
  const double beyond = std::max(0.0, std::abs(along) - 0.5 * b.length_m);
  return perpendicular + 0.5 * std::min(a.length_m, b.length_m) * sin_angle + beyond;
}

double featureDistanceSum(const std::vector<Feature>& features1, const std::vector<Feature>& features2,
                          const ElevationMap& map2, const Eigen::Isometry3d& T, const FeatureMatchConfig& config,
                          std::vector<std::pair<int, int>>* pairs) {
  double D = 0;
  // nearest[j]: the map-1 feature nearest to feature j of map 2 (one-to-one pairing), and its d.
  std::vector<std::pair<double, int>> nearest(features2.size(), {config.inlier_m, -1});
  for (std::size_t i = 0; i < features1.size(); ++i) {
    const Feature moved = transformed(features1[i], T);
    const auto cell = map2.grid().cellOf(moved.position.x(), moved.position.y());
    if (!cell || map2.stateAt(cell->x(), cell->y()) != CellState::Known) {
      D += config.d_max_m;
      continue;
    }
    double best = config.d_max_m;
    int best_j = -1;
    for (std::size_t j = 0; j < features2.size(); ++j) {
      if (features2[j].type != moved.type) continue;
      const double d = featureDistance(moved, features2[j]);
      if (d < best) best = d, best_j = int(j);
    }
    D += best;
    if (best_j >= 0 && best < nearest[best_j].first) nearest[best_j] = {best, int(i)};
  }
  if (pairs) {
    pairs->clear();
    for (std::size_t j = 0; j < nearest.size(); ++j)
      if (nearest[j].second >= 0) pairs->emplace_back(nearest[j].second, int(j));
    std::sort(pairs->begin(), pairs->end());
  }
  return D;
}

FeatureMatch matchFeatures(const std::vector<Feature>& features1, const std::vector<Feature>& features2,
                           const ElevationMap& map2, const PoseVector& nu0, const FeatureMatchConfig& config) {
  checkConfig(config);
  const Eigen::Isometry3d T0 = poseFromVector(nu0);
  FeatureMatch best;
  best.nu = nu0;
  best.D0 = best.D = featureDistanceSum(features1, features2, map2, T0, config, &best.pairs);

  // Map 1's strongest features (ties by index) are the search's levels.
  std::vector<int> order(features1.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](int a, int b) { return features1[a].strength > features1[b].strength; });
  if (int(order.size()) > config.search_features) order.resize(config.search_features);

  // Predict: each level's candidates, nearest under T_0 first.
  std::vector<std::vector<int>> candidates(order.size());
  for (std::size_t l = 0; l < order.size(); ++l) {
    const Feature& a = features1[order[l]];
    const Eigen::Vector3d guess = T0 * a.position;
    std::vector<std::pair<double, int>> c;
    for (std::size_t j = 0; j < features2.size(); ++j) {
      const double shift = (features2[j].position - guess).head<2>().norm();
      if (shift <= config.max_shift_m && similar(a, features2[j], config)) c.emplace_back(shift, int(j));
    }
    std::stable_sort(c.begin(), c.end());
    for (const auto& [shift, j] : c) candidates[l].push_back(j);
  }

  // Rigid consistency of two pairs (i1, j1), (i2, j2): distances and line angles kept.
  const auto consistent = [&](int i1, int j1, int i2, int j2) {
    const Feature &a1 = features1[i1], &a2 = features1[i2], &b1 = features2[j1], &b2 = features2[j2];
    const double d1 = (a1.position - a2.position).norm(), d2 = (b1.position - b2.position).norm();
    double tol = config.tolerance_m;
    // A line's centre is where its set's cells are: it moves along the line with what each view
    // saw of it, by up to half the difference of the two lengths.
    if (a1.type == FeatureType::Line) tol += 0.5 * std::abs(a1.length_m - b1.length_m);
    if (a2.type == FeatureType::Line) tol += 0.5 * std::abs(a2.length_m - b2.length_m);
    if (std::abs(d1 - d2) > tol || d1 < config.min_spread_m) return false;
    if (a1.type == FeatureType::Line && a2.type == FeatureType::Line) {
      const double c1 = std::abs(a1.direction.dot(a2.direction)), c2 = std::abs(b1.direction.dot(b2.direction));
      const double half = 0.5 * std::min({a1.length_m, a2.length_m, b1.length_m, b2.length_m});
      if (std::abs(std::acos(std::min(c1, 1.0)) - std::acos(std::min(c2, 1.0))) > config.tolerance_m / std::max(half, 1e-9))
        return false;
    }
    return true;
  };

  // The prior bounds the true pose, but a hypothesis is a fit to a few noisy feature pairs and
  // differs from the truth by its own error: held to the prior exactly, a true pairing whose truth
  // lies at the bound (the paper's 30° case with a 30° prior) is rejected whenever its fit errs
  // outwards, about half the time. So the refitted hypothesis may turn past the prior by three σ
  // of its rotation, σ_θ = σ_p / √(Σ ρ_k²), from its inliers' residuals (σ_p² = Σ d_k² / (3n − 6),
  // d the distance of eq. 3 at the fit) and their spread ρ_k about their centroid
  // (docs/matching.md).
  const double max_rotation = config.max_rotation_deg * kPi / 180;
  const auto rotationSigma = [&](const Eigen::Isometry3d& T, const std::vector<std::pair<int, int>>& pairs) {
    const int n = int(pairs.size());
    if (3 * n <= 6) return 0.0;
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    for (const auto& [i, j] : pairs) centroid += T * features1[i].position;
    centroid /= n;
    double sum_d2 = 0, spread = 0;
    for (const auto& [i, j] : pairs) {
      const double d = featureDistance(transformed(features1[i], T), features2[j]);
      sum_d2 += d * d;
      spread += (T * features1[i].position - centroid).squaredNorm();
    }
    return spread > 0 ? std::sqrt(sum_d2 / (3 * n - 6) / spread) : 0.0;
  };
  const auto turnedFromT0 = [&](const Eigen::Isometry3d& T) {
    return std::acos(std::clamp(((T0.linear().transpose() * T.linear()).trace() - 1) / 2, -1.0, 1.0));
  };

  // Two transforms are one hypothesis when no feature of map 1 lands inlier_m apart under them.
  const auto sameHypothesis = [&](const Eigen::Isometry3d& A, const Eigen::Isometry3d& B) {
    for (const Feature& f : features1)
      if ((A * f.position - B * f.position).norm() >= config.inlier_m) return false;
    return true;
  };
  // Keeps `ranked` the keep_ranked distinct pairings of lowest D below T_0's, best first.
  const auto rank = [&](const Eigen::Isometry3d& T, double D, int inliers) {
    std::vector<RankedPairing>& ranked = best.ranked;
    if (!(D < best.D0) || config.keep_ranked <= 0) return;
    if (int(ranked.size()) == config.keep_ranked && !(D < ranked.back().D)) return;
    for (std::size_t k = 0; k < ranked.size(); ++k) {
      if (!sameHypothesis(T, poseFromVector(ranked[k].nu))) continue;
      if (!(D < ranked[k].D)) return;  // a better form of this hypothesis is kept
      ranked.erase(ranked.begin() + long(k));
      break;
    }
    RankedPairing entry{vectorFromPose(T), D, inliers};
    const auto at = std::upper_bound(ranked.begin(), ranked.end(), D,
                                     [](double d, const RankedPairing& e) { return d < e.D; });
    ranked.insert(at, entry);
    if (int(ranked.size()) > config.keep_ranked) ranked.pop_back();
  };

  std::vector<std::pair<int, int>> pairing;
  std::vector<char> used(features2.size(), 0);
  // Verify a full hypothesis: fit, refit on its inliers, score by D.
  const auto verify = [&] {
    ++best.hypotheses;
    const auto fit = fitPairing(features1, features2, pairing, T0, false);
    if (!fit) return;
    Eigen::Isometry3d T = *fit;
    std::vector<std::pair<int, int>> inliers;
    double D = 0;
    for (int k = 0;; ++k) {
      D = featureDistanceSum(features1, features2, map2, T, config, &inliers);
      if (k == config.refits || inliers.size() < std::size_t(config.pairs_per_hypothesis)) break;
      const auto refit = fitPairing(features1, features2, inliers, T, true);
      if (!refit) break;
      const double D_refit = featureDistanceSum(features1, features2, map2, *refit, config);
      if (!(D_refit < D)) break;
      T = *refit;
    }
    const double sigma = rotationSigma(T, inliers);
    if (turnedFromT0(T) > max_rotation + 3 * sigma) return;  // turned beyond the prior
    rank(T, D, int(inliers.size()));
    if (D < best.D) {
      best.found = true;
      best.D = D;
      best.nu = vectorFromPose(T);
      best.pairs = inliers;
      best.rotation_sigma_deg = sigma * 180 / kPi;
    }
  };
  // Depth-first over pairings: level l pairs map 1's feature order[l] with a candidate or skips it.
  const auto search = [&](const auto& self, std::size_t level) -> void {
    if (best.nodes >= config.max_nodes) {
      best.exhausted = true;
      return;
    }
    ++best.nodes;
    if (int(pairing.size()) == config.pairs_per_hypothesis) {
      verify();
      return;
    }
    // Not enough levels left to complete the pairing.
    if (order.size() - level < std::size_t(config.pairs_per_hypothesis) - pairing.size()) return;
    const int i = order[level];
    for (const int j : candidates[level]) {
      if (used[j]) continue;
      bool ok = true;
      for (const auto& [i2, j2] : pairing) ok = ok && consistent(i, j, i2, j2);
      if (!ok) continue;
      used[j] = 1;
      pairing.emplace_back(i, j);
      self(self, level + 1);
      pairing.pop_back();
      used[j] = 0;
      if (best.exhausted) return;
    }
    self(self, level + 1);  // feature order[level] unpaired
  };
  search(search, 0);
  return best;
}

}  // namespace ambler::perception
