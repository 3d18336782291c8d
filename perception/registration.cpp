#include "perception/registration.hpp"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace ambler::perception {

bool twoStage(RegistrationMethod method) {
  return method == RegistrationMethod::FeaturesIconic || method == RegistrationMethod::FeaturesIconicRobust ||
         method == RegistrationMethod::FeaturesLm || method == RegistrationMethod::FeaturesIconicWeighted;
}

bool readsWeightedMaps(RegistrationMethod method) {
  return method == RegistrationMethod::IconicWeighted || method == RegistrationMethod::FeaturesIconicWeighted;
}

AcceptanceConfig acceptanceFor(const RegistrationConfig& config, const Eigen::Isometry3d& T_0) {
  AcceptanceConfig a = config.acceptance;
  if (config.odometry) a.prior = config.odometry->at(T_0.translation().norm());
  return a;
}

Matrix6d sensorPoseJacobian(const PoseVector& nu, const Eigen::Isometry3d& believed_WS_j) {
  const Eigen::Isometry3d B = believed_WS_j;
  const Eigen::Isometry3d base = B.inverse() * poseFromVector(nu);
  const auto e = [&](const PoseVector& d) { return vectorFromPose(base * poseFromVector(nu + d).inverse() * B); };
  Matrix6d A;
  constexpr double h = 1e-6;
  for (int k = 0; k < 6; ++k) {
    const PoseVector d = PoseVector::Unit(k) * h;
    A.col(k) = (e(d) - e(-d)) / (2 * h);
  }
  return A;
}

Matrix6d sensorPoseCovariance(const PoseVector& nu, const Matrix6d& P, const Eigen::Isometry3d& believed_WS_j) {
  const Matrix6d A = sensorPoseJacobian(nu, believed_WS_j);
  return A * P * A.transpose();
}

Matrix6d nuCovariance(const PoseVector& nu, const Matrix6d& C, const Eigen::Isometry3d& believed_WS_j) {
  const Eigen::FullPivLU<Matrix6d> lu(sensorPoseJacobian(nu, believed_WS_j));
  if (!lu.isInvertible()) throw std::invalid_argument("nuCovariance: the pose's Jacobian in nu is singular");
  const Matrix6d A_inv = lu.inverse();
  return A_inv * C * A_inv.transpose();
}

MapGrid believedGrid(const MapGrid& grid_i, const Eigen::Isometry3d& T_WS_i, const Eigen::Isometry3d& believed_WS_j) {
  const Eigen::Isometry3d T = believed_WS_j * T_WS_i.inverse() * grid_i.T_WM;
  const Eigen::Vector3d x = T.linear().col(0);
  MapGrid g = grid_i;
  g.T_WM = mapFrame(T.translation(), std::atan2(x.y(), x.x()));
  return g;
}

Verification verifyHypotheses(const ElevationMap& map_i, const LocusMapper& image_j,
                              const std::vector<RegistrationHypothesis>& starts, double D0, const Refiner& refine,
                              const RegistrationConfig& config) {
  Verification v;
  std::vector<RegistrationHypothesis>& hs = v.hypotheses;
  const double c = config.acceptance.inlier_sigmas;
  std::vector<std::vector<double>> residuals;
  std::size_t best = 0;
  if (!starts.empty()) {
    IconicOptions coarse = config.iconic;
    coarse.strides = {config.screen_stride};
    for (RegistrationHypothesis h : starts) {
      const IconicResult r = refine(h.nu0, coarse);
      h.stage = "screen", h.nu = r.nu, h.iterations = r.iterations;
      residuals.push_back(normalizedResiduals(map_i, image_j, h.nu, config.screen_stride, &r.hints));
      hs.push_back(h);
    }
    const std::vector<double> costs = commonOverlapCosts(residuals, c, nullptr);
    for (std::size_t k = 0; k < costs.size(); ++k) {
      hs[k].cost = costs[k];
      if (costs[k] < costs[best]) best = k;
    }
  }
  // The two refined in full: the best pairing (from where its screen ended) and T_0.
  std::vector<IconicResult> results;
  const std::size_t first = hs.size();
  if (!starts.empty()) {
    results.push_back(refine(hs[best].nu, config.iconic));
    hs.push_back({hs[best].start, "refine", hs[best].nu, results.back().nu, hs[best].D_m, 0, results.back().iterations});
  }
  results.push_back(refine(PoseVector::Zero(), config.iconic));
  hs.push_back({"T_0", "refine", PoseVector::Zero(), results.back().nu, D0, 0, results.back().iterations});
  residuals.clear();
  for (const IconicResult& r : results)
    residuals.push_back(r.residuals_u.size() == std::size_t(map_i.grid().cells()) ? r.residuals_u
                                                                                   : normalizedResiduals(map_i, image_j, r.nu));
  const std::vector<double> costs = commonOverlapCosts(residuals, c, &v.common_lines);
  std::size_t kept = 0;
  for (std::size_t k = 0; k < results.size(); ++k) {
    hs[first + k].cost = costs[k];
    if (costs[k] < costs[kept]) kept = k;
  }
  v.chosen = int(first + kept);
  v.result = std::move(results[kept]);
  return v;
}

namespace {

LocusConfig withFootprint(LocusConfig locus) {
  locus.footprint_sigma = true;
  return locus;
}

}  // namespace

ReferenceView referenceView(const ScanMap& scan, const MapGrid& grid, const RegistrationConfig& config,
                            bool with_weighted) {
  if (!grid.inWorldFrame()) throw std::invalid_argument("referenceView: map I's grid is not in the world frame");
  const Raster<std::uint8_t>* edges = scan.edges ? &*scan.edges : nullptr;
  ReferenceView view;
  view.T_WS = scan.image.T_WS;
  view.map = LocusMapper(scan.image, scan.sensor, edges, config.locus, grid.T_WM).map(grid);
  if (with_weighted) {
    const LocusConfig weighted = withFootprint(config.locus);
    view.weighted = LocusMapper(scan.image, scan.sensor, edges, weighted, grid.T_WM).map(grid);
    view.source.emplace(scan.image, scan.sensor, edges, weighted);
  }
  return view;
}

ReferenceView referenceView(ElevationMap composite, const Eigen::Isometry3d& T_WS) {
  if (!composite.grid().inWorldFrame())
    throw std::invalid_argument("referenceView: the composite is not in the world frame");
  ReferenceView view;
  view.weighted = composite;
  view.map = std::move(composite);
  view.T_WS = T_WS;
  return view;
}

RegistrationResult registerViews(const ReferenceView& view_i, const ScanMap& scan_j,
                                 const Eigen::Isometry3d& believed_WS_j, RegistrationMethod method,
                                 const RegistrationConfig& config) {
  const bool weighted = readsWeightedMaps(method);
  if (weighted && !view_i.weighted)
    throw std::invalid_argument("registerViews: the weighted method needs view I's weighted map (referenceView)");
  if (!view_i.map.grid().inWorldFrame()) throw std::invalid_argument("registerViews: map I is not in the world frame");
  // Map I as this method's iconic stage reads it; the feature stage reads the plain maps.
  const ElevationMap& map_i = weighted ? *view_i.weighted : view_i.map;
  const ElevationMap& feature_map_i = view_i.map;
  const LocusMapper* map_i_source = view_i.source ? &*view_i.source : nullptr;
  // Image J as the rover has it: unwrapped, its edges, at the believed pose.
  RangeImage image_j = scan_j.image;
  image_j.T_WS = believed_WS_j;
  const Raster<std::uint8_t>* edges_j = scan_j.edges ? &*scan_j.edges : nullptr;
  const MapGrid grid_j = believedGrid(view_i.map.grid(), view_i.T_WS, believed_WS_j);
  RegistrationResult out;
  const LocusMapper mapper(image_j, scan_j.sensor, edges_j, weighted ? withFootprint(config.locus) : config.locus);
  PoseVector nu0 = PoseVector::Zero();  // the rover trusts its belief
  if (method == RegistrationMethod::Features || twoStage(method)) {
    // Map J as the rover has it: in the believed world, on grid_j (in its own frame M_J).
    const LocusMapper mapper_j(image_j, scan_j.sensor, edges_j, config.locus, grid_j.T_WM);
    out.map_j = mapper_j.map(grid_j);
    out.features_i = extractFeatures(feature_map_i, config.features);
    out.features_j = extractFeatures(*out.map_j, config.features);
    FeatureMatchConfig match = config.match;
    const MapGrid& g = map_i.grid();  // in the world: its M is the world
    const Eigen::Vector2d sensor = image_j.T_WS.translation().head<2>();
    double far = 0;
    for (const double x : {g.x_min, g.x_min + g.cols * g.cell})
      for (const double y : {g.y_max, g.y_max - g.rows * g.cell}) far = std::max(far, (Eigen::Vector2d(x, y) - sensor).norm());
    match.max_rotation_deg = config.prior_rotation_deg;
    match.max_shift_m = config.prior_translation_m + 2 * std::sin(config.prior_rotation_deg * M_PI / 360) * far;
    // T_0 from map I's frame (the world) to M_J: T_WM_J⁻¹ (the rover trusts its belief).
    out.feature_match = matchFeatures(out.features_i, out.features_j, *out.map_j,
                                      vectorFromPose(grid_j.T_WM.inverse()), match);
    nu0 = vectorFromPose(grid_j.T_WM * poseFromVector(out.feature_match->nu));
  }
  const Eigen::Isometry3d& believed = image_j.T_WS;
  if (method == RegistrationMethod::Features) {
    out.nu = nu0;
    out.correction = poseFromVector(out.nu).inverse();
    out.corrected_WS = out.correction * believed;
    out.assessment = assessRegistration(map_i, mapper, out.nu, believed, nullptr, nullptr, config.acceptance);
    return out;
  }
  out.ran_iconic = true;
  const Refiner refine = [&](const PoseVector& start, const IconicOptions& options) {
    switch (method) {
      case RegistrationMethod::Iconic:
      case RegistrationMethod::FeaturesIconic:
        return iconicPaperDescent(map_i, mapper, start, options);
      case RegistrationMethod::IconicRobust:
      case RegistrationMethod::FeaturesIconicRobust:
        return iconicGradientDescent(map_i, mapper, start, options);
      case RegistrationMethod::IconicWeighted:
      case RegistrationMethod::FeaturesIconicWeighted: {
        IconicOptions weighted = options;
        weighted.map1_source = map_i_source;
        return iconicWeighted(map_i, mapper, start, weighted);
      }
      default:
        return iconicLevenbergMarquardt(map_i, mapper, start, options);
    }
  };
  const FeatureMatch* fm = out.feature_match ? &*out.feature_match : nullptr;
  if (!twoStage(method) || !fm->found) {
    out.iconic = refine(nu0, config.iconic);
  } else {
    const auto inBelieved = [&](const PoseVector& nu_f) { return vectorFromPose(grid_j.T_WM * poseFromVector(nu_f)); };
    std::vector<RegistrationHypothesis> starts;
    for (std::size_t k = 0; k < fm->ranked.size(); ++k)
      starts.push_back({k == 0 ? "T_F" : "pairing " + std::to_string(k + 1), "screen", inBelieved(fm->ranked[k].nu), {},
                        fm->ranked[k].D, 0, 0});
    Verification v = verifyHypotheses(map_i, mapper, starts, fm->D0, refine, config);
    out.hypotheses = std::move(v.hypotheses);
    out.chosen = v.chosen;
    out.common_lines = v.common_lines;
    out.iconic = std::move(v.result);
  }
  out.nu = out.iconic.nu;
  out.correction = poseFromVector(out.nu).inverse();
  out.corrected_WS = out.correction * believed;
  out.iterations = out.iconic.iterations;
  const Degeneracy d{out.iconic.degenerate, out.iconic.free_directions};
  out.assessment =
      assessRegistration(map_i, mapper, out.nu, believed, &out.iconic.covariance, &d, config.acceptance, &out.iconic.residuals_u,
                         out.iconic.step_mahalanobis2);
  return out;
}

}  // namespace ambler::perception
