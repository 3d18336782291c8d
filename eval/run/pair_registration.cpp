#include "eval/run/pair_registration.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

#include "eval/peers/open3d_peers.hpp"
#include "eval/run/run_state.hpp"

namespace ambler::eval {

namespace {

// The methods whose iconic stage is the weighted LM: they read the weighted map I.
bool weightedMethod(MatchMethod m) { return m == MatchMethod::IconicWeighted || m == MatchMethod::FeaturesIconicWeighted; }

}  // namespace

PairRegistration::PairRegistration(const perception::ScanMap& view_i, const Eigen::Isometry3d& T_WS_i,
                                   const perception::ScanMap& view_j, const Eigen::Isometry3d& T_WS_j,
                                   perception::RegistrationConfig config, const std::vector<MatchMethod>& methods)
    : i_(view_i), j_(view_j), T_WS_i_(T_WS_i), T_IJ_(T_WS_i.inverse() * T_WS_j), config_(std::move(config)) {
  // Map I as registration maps it for the paper's methods (config.locus: the samples at edges
  // trusted, as for map J), on the grid of the run's map I.
  // Every method's result is assessed on it, the peers' too.
  map_i_ = perception::LocusMapper(i_.image, i_.edges ? &*i_.edges : nullptr, config_.locus, i_.map.grid().T_WM)
               .map(i_.map.grid());
  // The weighted method's σ_z has the footprint's term: the two views smooth the terrain over
  // footprints of different size and shape, so between their maps that error is noise. Its map I,
  // and the mapper map I was made with (the pixels of image I that map I's lines share).
  if (std::any_of(methods.begin(), methods.end(), weightedMethod)) {
    weighted_config_ = config_;
    weighted_config_.locus.footprint_sigma = true;
    weighted_config_.feature_locus = config_.locus;  // feature matching reads the plain maps
    const perception::Raster<std::uint8_t>* edges = i_.edges ? &*i_.edges : nullptr;
    weighted_map_i_ = perception::LocusMapper(i_.image, edges, weighted_config_.locus, i_.map.grid().T_WM)
                          .map(i_.map.grid());
    source_i_.emplace(i_.image, edges, weighted_config_.locus);
  }
  if (std::any_of(methods.begin(), methods.end(), [](MatchMethod m) { return !paperMethod(m); }))
    returns_i_ = peers::returns(i_.image);
}

namespace {

peers::PeerMethod peerMethod(MatchMethod m) {
  switch (m) {
    case MatchMethod::Gicp: return peers::PeerMethod::Gicp;
    case MatchMethod::Fgr: return peers::PeerMethod::Fgr;
    default: return peers::PeerMethod::IcpPointToPlane;
  }
}

}  // namespace

Eigen::Isometry3d PairRegistration::relativeEstimate(const perception::RegistrationResult& reg,
                                                     const Eigen::Isometry3d& believed_WS) const {
  // T_WS,I⁻¹·corrected_WS, multiplied as (T_WS,I⁻¹·correction)·believed: the same pose, rounded
  // as the run's outputs are (a product of isometries rounds differently in another order).
  return T_WS_i_.inverse() * reg.correction * believed_WS;
}

PairResult PairRegistration::run(MatchMethod method, const Eigen::Isometry3d& T_0) const {
  PairResult out;
  out.believed_WS = T_WS_i_ * T_0;
  const auto paper = paperMethod(method);
  out.start = perception::poseError(T_IJ_, T_0);
  if (!paper) {
    // A peer: scan J's returns in its believed world onto scan I's in the world. Its T maps the
    // believed world to the world, so sensor J is at T·believed, and ν (world → believed) is T⁻¹.
    perception::RangeImage image = j_.image;
    image.T_WS = out.believed_WS;
    const std::vector<Eigen::Vector3d> returns_j = peers::returns(image);
    base::Stopwatch t;
    const peers::PeerResult r = peers::registerPeer(returns_i_, T_WS_i_.translation(), returns_j,
                                                    out.believed_WS.translation(), peerMethod(method));
    out.seconds = t.seconds();
    out.reg.nu = perception::vectorFromPose(r.T.inverse());
    out.reg.iterations = r.iterations;
    out.reg.correction = r.T;
    out.reg.corrected_WS = r.T * out.believed_WS;
    out.T_est = relativeEstimate(out.reg, out.believed_WS);
    out.error = perception::poseError(T_IJ_, out.T_est);
    // The rover's verdict on the peer's estimate, by the same tests as the paper's methods'.
    const perception::LocusMapper mapper(image, j_.edges ? &*j_.edges : nullptr, config_.locus);
    out.reg.assessment = perception::assessRegistration(map_i_, mapper, out.reg.nu, out.believed_WS, nullptr, nullptr,
                                                        perception::acceptanceFor(config_, T_0));
    return out;
  }
  // Image J as the rover has it: unwrapped, its edges, at the believed pose.
  perception::RangeImage image = j_.image;
  image.T_WS = out.believed_WS;
  const perception::MapGrid grid_j = perception::believedGrid(map_i_.grid(), T_WS_i_, out.believed_WS);
  base::Stopwatch t;
  const bool weighted = weightedMethod(method);
  perception::RegistrationConfig config = weighted ? weighted_config_ : config_;
  config.acceptance = perception::acceptanceFor(config, T_0);  // this pair's prior
  out.reg = perception::registerViews(weighted ? *weighted_map_i_ : map_i_, image, j_.edges ? &*j_.edges : nullptr,
                                      grid_j, *paper, config, source_i_ ? &*source_i_ : nullptr,
                                      weighted ? &map_i_ : nullptr);
  out.seconds = t.seconds();
  out.T_est = relativeEstimate(out.reg, out.believed_WS);
  out.error = perception::poseError(T_IJ_, out.T_est);
  return out;
}

}  // namespace ambler::eval
