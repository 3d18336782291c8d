#include "eval/run/pair_registration.hpp"

#include <algorithm>
#include <cctype>
#include <set>
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

void checkCustomMethods(const CustomMethods& methods, const std::string& where) {
  std::set<std::string> seen;
  for (const CustomMethod& m : methods) {
    const std::string name = "custom method " + yamlQuoted(m.name);
    if (m.name.empty()) throw std::invalid_argument(where + ": a custom method has an empty name");
    if (!std::all_of(m.name.begin(), m.name.end(), [](char c) {
          return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '+' || c == '.';
        }))
      throw std::invalid_argument(where + ": " + name + ": a name of letters, digits, '_', '-', '+' and '.' (it "
                                  "names files and CSV cells)");
    if (matchMethodFromName(m.name))
      throw std::invalid_argument(where + ": " + name + " is a built-in method's name; choose another");
    if (!seen.insert(m.name).second) throw std::invalid_argument(where + ": " + name + " is given twice");
    if (!m.fn) throw std::invalid_argument(where + ": " + name + " has no function");
  }
}

PairResult PairRegistration::run(const CustomMethod& method, const Eigen::Isometry3d& T_0) const {
  PairResult out;
  out.believed_WS = T_WS_i_ * T_0;
  out.start = perception::poseError(T_IJ_, T_0);
  base::Stopwatch t;
  CustomEstimate e = method.fn(*this, T_0);
  out.seconds = t.seconds();
  if (!e.T.matrix().allFinite())
    throw std::invalid_argument("custom method " + method.name + ": its estimate is not finite");
  if (e.covariance_pose && !e.covariance_pose->allFinite())
    throw std::invalid_argument("custom method " + method.name + ": its covariance is not finite");
  if (e.registered && e.registered->believed_WS.matrix() == out.believed_WS.matrix()) {
    // A built-in registration of this pair from this start: its result and its own verdict.
    out.reg = std::move(e.registered->reg);
    out.covariance_pose = e.registered->covariance_pose;
  } else {
    // sensor J at T_WS,I·T in the world: the correction (believed → estimated) and ν its inverse.
    out.reg.iterations = e.iterations;
    out.reg.corrected_WS = T_WS_i_ * e.T;
    out.reg.correction = out.reg.corrected_WS * out.believed_WS.inverse();
    out.reg.nu = perception::vectorFromPose(out.reg.correction.inverse());
    out.covariance_pose = e.covariance_pose;
    perception::RangeImage image = j_.image;
    image.T_WS = out.believed_WS;
    const perception::LocusMapper mapper(image, j_.sensor, j_.edges ? &*j_.edges : nullptr, config_.locus);
    std::optional<perception::Matrix6d> P;  // ν's covariance, for the verdict's positive-definite test
    if (e.covariance_pose) P = perception::nuCovariance(out.reg.nu, *e.covariance_pose, out.believed_WS);
    out.reg.assessment = perception::assessRegistration(reference_.map, mapper, out.reg.nu, out.believed_WS,
                                                        P ? &*P : nullptr, nullptr,
                                                        perception::acceptanceFor(config_, T_0));
  }
  out.T_est = e.T;
  out.error = perception::poseError(T_IJ_, out.T_est);
  return out;
}

}  // namespace ambler::eval
