#include "eval/run/pair_registration.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

#include "eval/peers/open3d_peers.hpp"
#include "eval/run/run_state.hpp"

namespace ambler::eval {

PairRegistration::PairRegistration(const perception::ScanMap& view_i, const Eigen::Isometry3d& T_WS_i,
                                   const perception::ScanMap& view_j, const Eigen::Isometry3d& T_WS_j,
                                   perception::RegistrationConfig config, const std::vector<MatchMethod>& methods)
    : i_(view_i),
      j_(view_j),
      T_WS_i_(T_WS_i),
      T_IJ_(T_WS_i.inverse() * T_WS_j),
      config_(std::move(config)),
      reference_(perception::referenceView(
          i_, i_.map.grid(), config_,
          std::any_of(methods.begin(), methods.end(), [](MatchMethod m) {
            const auto paper = paperMethod(m);
            return paper && perception::readsWeightedMaps(*paper);
          }))) {
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
    const perception::LocusMapper mapper(image, j_.sensor, j_.edges ? &*j_.edges : nullptr, config_.locus);
    out.reg.assessment = perception::assessRegistration(reference_.map, mapper, out.reg.nu, out.believed_WS, nullptr, nullptr,
                                                        perception::acceptanceFor(config_, T_0));
    return out;
  }
  base::Stopwatch t;
  perception::RegistrationConfig config = config_;
  config.acceptance = perception::acceptanceFor(config, T_0);  // this pair's prior
  out.reg = perception::registerViews(reference_, j_, out.believed_WS, *paper, config);
  out.seconds = t.seconds();
  out.T_est = relativeEstimate(out.reg, out.believed_WS);
  out.error = perception::poseError(T_IJ_, out.T_est);
  return out;
}

}  // namespace ambler::eval
