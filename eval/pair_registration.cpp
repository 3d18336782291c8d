#include "eval/pair_registration.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

#include "eval/run_state.hpp"

namespace ambler::eval {

PairRegistration::PairRegistration(const perception::ScanMap& view_i, const Eigen::Isometry3d& T_WS_i,
                                   const perception::ScanMap& view_j, const Eigen::Isometry3d& T_WS_j,
                                   perception::RegistrationConfig config, const std::vector<MatchMethod>& methods)
    : i_(view_i), j_(view_j), T_WS_i_(T_WS_i), T_IJ_(T_WS_i.inverse() * T_WS_j), config_(std::move(config)) {
  // The mapper map I was made with: the pixels of image I that map I's lines share.
  if (std::find(methods.begin(), methods.end(), MatchMethod::IconicWeighted) != methods.end())
    source_i_.emplace(i_.image, i_.edges ? &*i_.edges : nullptr, config_.locus);
}

PairResult PairRegistration::run(MatchMethod method, const Eigen::Isometry3d& T_0) const {
  PairResult out;
  out.believed_WS = T_WS_i_ * T_0;
  const auto paper = paperMethod(method);
  if (!paper) throw std::invalid_argument(std::string(matchMethodName(method)) + ": a registration peer, not built yet");
  // Image J as the rover has it: unwrapped, its edges, at the believed pose.
  perception::RangeImage image = j_.image;
  image.T_WS = out.believed_WS;
  const perception::MapGrid grid_j = perception::believedGrid(i_.map.grid(), T_WS_i_, out.believed_WS);
  Stopwatch t;
  out.reg = perception::registerViews(i_.map, image, j_.edges ? &*j_.edges : nullptr, grid_j, *paper, config_,
                                      source_i_ ? &*source_i_ : nullptr);
  out.seconds = t.seconds();
  out.T_est = T_WS_i_.inverse() * perception::poseFromVector(out.reg.nu).inverse() * out.believed_WS;
  out.error = perception::poseError(T_IJ_, out.T_est);
  out.start = perception::poseError(T_IJ_, T_0);
  return out;
}

}  // namespace ambler::eval
