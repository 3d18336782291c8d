#include "perception/registration.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace ambler::perception {

MapGrid believedGrid(const MapGrid& grid_i, const Eigen::Isometry3d& T_WS_i, const Eigen::Isometry3d& believed_WS_j) {
  const Eigen::Isometry3d T = believed_WS_j * T_WS_i.inverse() * grid_i.T_WM;
  const Eigen::Vector3d x = T.linear().col(0);
  MapGrid g = grid_i;
  g.T_WM = mapFrame(T.translation(), std::atan2(x.y(), x.x()));
  return g;
}

RegistrationResult registerViews(const ElevationMap& map_i, const RangeImage& image_j,
                                 const Raster<std::uint8_t>* edges_j, const MapGrid& grid_j,
                                 RegistrationMethod method, const RegistrationConfig& config,
                                 const LocusMapper* map_i_source) {
  if (!map_i.grid().inWorldFrame()) throw std::invalid_argument("registerViews: map I is not in the world frame");
  RegistrationResult out;
  const LocusMapper mapper(image_j, edges_j, config.locus);
  PoseVector nu0 = PoseVector::Zero();  // the rover trusts its belief
  if (method == RegistrationMethod::Features || method == RegistrationMethod::FeaturesIconic ||
      method == RegistrationMethod::FeaturesLm) {
    // Map J as the rover has it: in the believed world, on grid_j (in its own frame M_J).
    const LocusMapper mapper_j(image_j, edges_j, config.locus, grid_j.T_WM);
    out.map_j = mapper_j.map(grid_j);
    out.features_i = extractFeatures(map_i, config.features);
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
  out.nu = nu0;
  if (method == RegistrationMethod::Features) return out;
  out.ran_iconic = true;
  switch (method) {
    case RegistrationMethod::Iconic:
    case RegistrationMethod::FeaturesIconic:
      out.iconic = iconicGradientDescent(map_i, mapper, nu0, config.iconic);
      break;
    case RegistrationMethod::IconicLm:
    case RegistrationMethod::FeaturesLm:
      out.iconic = iconicLevenbergMarquardt(map_i, mapper, nu0, config.iconic);
      break;
    case RegistrationMethod::IconicWeighted: {
      IconicOptions options = config.iconic;
      options.map1_source = map_i_source;
      out.iconic = iconicWeighted(map_i, mapper, nu0, options);
      break;
    }
    case RegistrationMethod::Features:
      break;
  }
  out.nu = out.iconic.nu;
  out.iterations = out.iconic.iterations;
  return out;
}

}  // namespace ambler::perception
