#include "perception/placement.hpp"

#include <array>
#include <cmath>
#include <limits>

namespace ambler::perception {

Eigen::Isometry3d PlacementLink::relative(const PoseVector& delta) const {
  return T_WS_i.inverse() * poseFromVector(nu + delta).inverse() * believed_WS_j;
}

const char* placementHowName(PlacementHow h) {
  switch (h) {
    case PlacementHow::Reference: return "reference";
    case PlacementHow::Matched: return "matched";
    case PlacementHow::LeftOut: return "left_out";
    case PlacementHow::True: return "true";
  }
  return "left_out";
}

Eigen::Isometry3d ChainStep::motion(const PoseVector& delta) const {
  const Eigen::Isometry3d moved = reverse ? link->relative(delta).inverse() : link->relative(delta);
  const Eigen::Isometry3d at = reverse ? link->relative().inverse() : link->relative();
  return from_WS * moved * at.inverse() * from_WS.inverse();
}

std::vector<ViewPlacement> placeViews(int views, int reference, const Eigen::Isometry3d& reference_WS,
                                      const std::vector<PlacementLink>& links) {
  std::vector<ViewPlacement> p(std::size_t(std::max(views, 0)));
  if (reference < 0 || reference >= views) return p;
  p[std::size_t(reference)] = {PlacementHow::Reference, reference_WS, {}};
  const auto placed = [&](int k) { return p[std::size_t(k)].how != PlacementHow::LeftOut; };
  for (bool grew = true; grew;) {
    grew = false;
    for (const PlacementLink& l : links) {
      if (!l.accepted || l.i < 0 || l.j < 0 || l.i >= views || l.j >= views || placed(l.i) == placed(l.j)) continue;
      const bool forward = placed(l.i);
      const ViewPlacement& from = p[std::size_t(forward ? l.i : l.j)];
      ViewPlacement to;
      to.how = PlacementHow::Matched;
      to.T_WS = from.T_WS * (forward ? l.relative() : l.relative().inverse());
      to.chain = from.chain;
      to.chain.push_back({&l, !forward, from.T_WS});
      p[std::size_t(forward ? l.j : l.i)] = std::move(to);
      grew = true;
    }
  }
  return p;
}

Raster<float> placementSigma(const ElevationMap& map, const std::vector<ChainStep>& chain) {
  const MapGrid& g = map.grid();
  Raster<float> out = Raster<float>::Constant(g.rows, g.cols, std::numeric_limits<float>::quiet_NaN());
  // Each step's derivatives ∂G/∂δ_k at 0 (central differences, as 4×4 affine matrices).
  struct Step {
    std::array<Eigen::Matrix4d, 6> dG;
    Matrix6d P;
  };
  std::vector<Step> steps;
  constexpr double h = 1e-6;
  for (const ChainStep& c : chain) {
    if (!c.link || !c.link->covariance) continue;
    Step s;
    s.P = *c.link->covariance;
    for (int k = 0; k < 6; ++k) {
      const PoseVector e = PoseVector::Unit(k) * h;
      s.dG[std::size_t(k)] = (c.motion(e).matrix() - c.motion(-e).matrix()) / (2 * h);
    }
    steps.push_back(s);
  }
  const std::vector<Eigen::Vector3d> normals = referenceNormals(map);
  for (int r = 0; r < g.rows; ++r)
    for (int c = 0; c < g.cols; ++c) {
      if (map.stateAt(r, c) != CellState::Known) continue;
      Eigen::Vector3d n = normals[std::size_t(r) * g.cols + c];
      if (!n.allFinite()) n = Eigen::Vector3d::UnitZ();  // no neighbours to take a slope from: level
      const Eigen::Vector2d xy = g.center(r, c);
      const Eigen::Vector4d p(xy.x(), xy.y(), map.elevation()(r, c), 1.0);
      double var = 0;
      for (const Step& s : steps) {
        Eigen::Matrix<double, 1, 6> J;
        for (int k = 0; k < 6; ++k) J(k) = n.dot((s.dG[std::size_t(k)] * p).head<3>()) / n.z();
        var += double(J * s.P * J.transpose());
      }
      out(r, c) = float(std::sqrt(std::max(0.0, var)));
    }
  return out;
}

}  // namespace ambler::perception
