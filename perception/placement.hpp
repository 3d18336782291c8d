#pragma once
// Where the rover puts each view in its composite (docs/composite.md, "Placements"): the
// reference view where it is, every other view chained from it through the registrations it
// accepted, and views no accepted registration reaches left out; the σ each link's calibrated
// covariance adds to the cells of every view placed through it. Onboard code.
#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <vector>

#include "perception/elevation_map.hpp"
#include "perception/iconic.hpp"
#include "perception/raster.hpp"
#include "perception/rigid_transform.hpp"

namespace ambler::perception {

// One registration of view J against view I, as the rover has it.
struct PlacementLink {
  int i = 0, j = 0;
  Eigen::Isometry3d T_WS_i = Eigen::Isometry3d::Identity();         // view I where map I was registered from
  Eigen::Isometry3d believed_WS_j = Eigen::Isometry3d::Identity();  // view J believed, in that frame
  PoseVector nu = PoseVector::Zero();  // the correction: sensor J at exp(ν)⁻¹·believed_WS_j
  std::optional<Matrix6d> covariance;  // of ν (rx ry rz tx ty tz), when calibrated; else none is propagated
  bool accepted = true;                // the rover's verdict; a rejected link places nothing

  // Sensor J in sensor I's frame by this link with ν + δ.
  Eigen::Isometry3d relative(const PoseVector& delta = PoseVector::Zero()) const;
};

// reference: where the caller put it; matched: chained through accepted links; left_out: no
// accepted link reaches it; true: at its true pose (eval's `poses: true`, no placement made).
enum class PlacementHow : std::uint8_t { Reference, Matched, LeftOut, True };
const char* placementHowName(PlacementHow h);

// A link of a view's chain, and whether it was used from J to I (view I placed from view J).
struct ChainStep {
  const PlacementLink* link = nullptr;
  bool reverse = false;
  Eigen::Isometry3d from_WS = Eigen::Isometry3d::Identity();  // where the view it placed from is

  // The motion of everything placed through this step when its link's ν errs by δ: a view placed
  // at P through it is at G(δ)·P (G(0) the identity).
  Eigen::Isometry3d motion(const PoseVector& delta) const;
};

struct ViewPlacement {
  PlacementHow how = PlacementHow::LeftOut;
  Eigen::Isometry3d T_WS = Eigen::Isometry3d::Identity();
  std::vector<ChainStep> chain;  // from the reference out
};

// The reference view at reference_WS; then, in the links' order, repeatedly, each accepted link
// with one view placed and the other not places the other (forward, J = P_I·T_IJ, or reverse,
// I = P_J·T_IJ⁻¹), until nothing more is placed. The rest are left out. `links` must outlive the
// result (chains point into it).
std::vector<ViewPlacement> placeViews(int views, int reference, const Eigen::Isometry3d& reference_WS,
                                      const std::vector<PlacementLink>& links);

// The σ a placement's uncertainty adds to each Known cell of `map` (NaN elsewhere): each step of
// the chain with a covariance P moves the map's points by its motion G(δ), to first order
// p + Σ_k ∂(G·p)/∂δ_k·δ_k, and the surface (upward normal n from the map's own slopes) vertically by
// nᵀ·∂(G·p)/∂δ·δ / n_z; the steps are independent, their variances add. p is the cell's centre at its
// elevation, in the map's frame (the composite's). With one forward step from the reference at its
// registered pose this is registrationSigma.
Raster<float> placementSigma(const ElevationMap& map, const std::vector<ChainStep>& chain);

}  // namespace ambler::perception
