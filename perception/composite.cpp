#include "perception/composite.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace ambler::perception {

namespace {

bool sameGrid(const MapGrid& a, const MapGrid& b) {
  return a.rows == b.rows && a.cols == b.cols && a.cell == b.cell && a.x_min == b.x_min && a.y_max == b.y_max &&
         a.T_WM.isApprox(b.T_WM, 0.0);
}

}  // namespace

namespace {

// mergeInto's cell rule; `shared` null: nothing shared.
void mergeCells(ElevationMap& composite, Raster<float>* composite_shared, const ElevationMap& map,
                const Raster<float>* map_shared) {
  if (!sameGrid(composite.grid(), map.grid())) throw std::invalid_argument("mergeInto: the maps' grids differ");
  const MapGrid& g = map.grid();
  if (composite_shared && (composite_shared->rows() != g.rows || composite_shared->cols() != g.cols ||
                           map_shared->rows() != g.rows || map_shared->cols() != g.cols))
    throw std::invalid_argument("mergeInto: the shared σ rasters are not the maps' size");
  const auto sharedAt = [](const Raster<float>* s, int r, int c) {
    const double v = s ? (*s)(r, c) : 0.0;
    return std::isnan(v) ? 0.0 : v;
  };
  for (int r = 0; r < g.rows; ++r)
    for (int c = 0; c < g.cols; ++c) {
      const CellState a = composite.stateAt(r, c), b = map.stateAt(r, c);
      if (b == CellState::Known) {
        const double z2 = map.elevation()(r, c), s2 = map.sigma()(r, c);
        const double sh2 = std::min(sharedAt(map_shared, r, c), s2);
        if (a != CellState::Known) {
          composite.setKnown(r, c, float(z2), float(s2));
          if (composite_shared) (*composite_shared)(r, c) = float(sh2);
          continue;
        }
        const double z1 = composite.elevation()(r, c), s1 = composite.sigma()(r, c);
        const double sh1 = std::min(sharedAt(composite_shared, r, c), s1);
        const double v1 = s1 * s1, v2 = s2 * s2;
        if (v1 + v2 > 0) {
          const double w1 = v2 / (v1 + v2), w2 = v1 / (v1 + v2);
          const double shared = w1 * sh1 + w2 * sh2;
          const double own = w1 * w1 * (v1 - sh1 * sh1) + w2 * w2 * (v2 - sh2 * sh2);
          composite.setKnown(r, c, float(w1 * z1 + w2 * z2), float(std::sqrt(own + shared * shared)));
          if (composite_shared) (*composite_shared)(r, c) = float(shared);
        } else {
          composite.setKnown(r, c, float(0.5 * (z1 + z2)), 0.f);
        }
      } else if (b == CellState::Shadow && a != CellState::Known) {
        const float cb = map.shadowCeiling()(r, c);
        if (a == CellState::Shadow) {
          const float ca = composite.shadowCeiling()(r, c);
          composite.setShadow(r, c, std::isnan(ca) ? cb : std::isnan(cb) ? ca : std::min(ca, cb));
        } else {
          composite.setShadow(r, c, cb);
        }
      }
    }
}

}  // namespace

void mergeInto(ElevationMap& composite, const ElevationMap& map) { mergeCells(composite, nullptr, map, nullptr); }

void mergeInto(ElevationMap& composite, Raster<float>& composite_shared, const ElevationMap& map,
               const Raster<float>& map_shared) {
  mergeCells(composite, &composite_shared, map, &map_shared);
}

Raster<float> registrationSigma(const ElevationMap& map, const PoseVector& nu, const Matrix6d& P) {
  const MapGrid& g = map.grid();
  Raster<float> out = Raster<float>::Constant(g.rows, g.cols, std::numeric_limits<float>::quiet_NaN());
  const Eigen::Isometry3d T = poseFromVector(nu);
  const Eigen::Matrix3d R = T.linear();
  Eigen::Matrix3d dRt_R[3];
  for (int k = 0; k < 3; ++k) dRt_R[k] = rotationDerivative(nu.head<3>(), k).transpose() * R;
  const std::vector<Eigen::Vector3d> normals = referenceNormals(map);
  for (int r = 0; r < g.rows; ++r)
    for (int c = 0; c < g.cols; ++c) {
      if (map.stateAt(r, c) != CellState::Known) continue;
      Eigen::Vector3d n = normals[std::size_t(r) * g.cols + c];
      if (!n.allFinite()) n = Eigen::Vector3d::UnitZ();  // no neighbours to take a slope from: level
      const Eigen::Vector2d xy = g.center(r, c);
      const Eigen::Vector3d p(xy.x(), xy.y(), map.elevation()(r, c));
      Eigen::Matrix<double, 1, 6> J;
      for (int k = 0; k < 3; ++k) J(k) = n.dot(dRt_R[k] * p);
      J.tail<3>() = -(R * n).transpose();  // nᵀ·(−Rᵀ) = −(R·n)ᵀ
      J /= n.z();
      out(r, c) = float(std::sqrt(std::max(0.0, double(J * P * J.transpose()))));
    }
  return out;
}

void addSigma(ElevationMap& map, const Raster<float>& extra) {
  const MapGrid& g = map.grid();
  if (extra.rows() != g.rows || extra.cols() != g.cols) throw std::invalid_argument("addSigma: sizes differ");
  for (int r = 0; r < g.rows; ++r)
    for (int c = 0; c < g.cols; ++c) {
      const float e = extra(r, c);
      if (map.stateAt(r, c) != CellState::Known || std::isnan(e)) continue;
      const float s = map.sigma()(r, c);
      map.sigma()(r, c) = std::sqrt(s * s + e * e);
    }
}

void addShared(Raster<float>& shared, const ElevationMap& map, const Raster<float>& extra) {
  const MapGrid& g = map.grid();
  if (extra.rows() != g.rows || extra.cols() != g.cols || shared.rows() != g.rows || shared.cols() != g.cols)
    throw std::invalid_argument("addShared: sizes differ");
  for (int r = 0; r < g.rows; ++r)
    for (int c = 0; c < g.cols; ++c) {
      const float e = extra(r, c);
      if (map.stateAt(r, c) != CellState::Known || std::isnan(e)) continue;
      const float s = std::isnan(shared(r, c)) ? 0.0f : shared(r, c);
      shared(r, c) = std::min(map.sigma()(r, c), std::sqrt(s * s + e * e));
    }
}

namespace {

// The part of each Known cell's σ every view of it shares (docs/composite.md, "What the views
// share"): σ_rough = √(σ² − σ_noise²), `map` mapped with the terrain's part of σ and `noise` the
// same scan without it; 0 where either is not Known.
Raster<float> sharedSigma(const ElevationMap& map, const ElevationMap& noise) {
  const MapGrid& g = map.grid();
  Raster<float> shared = Raster<float>::Zero(g.rows, g.cols);
  for (int r = 0; r < g.rows; ++r)
    for (int c = 0; c < g.cols; ++c)
      if (map.stateAt(r, c) == CellState::Known && noise.stateAt(r, c) == CellState::Known) {
        const float s = map.sigma()(r, c), n = noise.sigma()(r, c);
        shared(r, c) = std::sqrt(std::max(0.f, s * s - n * n));
      }
  return shared;
}

}  // namespace

ElevationMap mapForComposite(const ScanMap& scan, const Eigen::Isometry3d& T_WS, const MapGrid& grid,
                             const LocusConfig& config, Raster<float>& shared) {
  LocusConfig locus = config;
  locus.footprint_sigma = true;  // the footprint's error is shared by every view (docs/composite.md)
  // σ without the terrain's part (docs/locus.md, σ_rough): what is left is the part every view
  // of a cell shares (docs/composite.md).
  LocusConfig noise_only = locus;
  noise_only.roughness = false;
  ElevationMap map = mapAtPose(scan, T_WS, grid, locus);
  shared = sharedSigma(map, mapAtPose(scan, T_WS, grid, noise_only));
  return map;
}

ElevationMap buildComposite(const std::vector<const ScanMap*>& views, const std::vector<ViewPlacement>& placements,
                            const MapGrid& grid, const LocusConfig& config) {
  if (views.size() != placements.size())
    throw std::invalid_argument("buildComposite: " + std::to_string(views.size()) + " views but " +
                                std::to_string(placements.size()) + " placements");
  ElevationMap composite(grid);
  Raster<float> composite_shared = Raster<float>::Zero(grid.rows, grid.cols);
  for (std::size_t k = 0; k < views.size(); ++k) {
    const ViewPlacement& placement = placements[k];
    if (placement.how == PlacementHow::LeftOut) continue;
    if (!views[k])
      throw std::invalid_argument("buildComposite: view " + std::to_string(k) + " is placed but has no scan");
    // The scan as the rover mapped it (unwrapped, its edges), at the composite's pose for it.
    Raster<float> shared;
    ElevationMap map = mapForComposite(*views[k], placement.T_WS, grid, config, shared);
    // Each link's pose covariance, first order and independent: variances add.
    addSigma(map, placementSigma(map, placement.chain));
    mergeInto(composite, composite_shared, map, shared);
  }
  return composite;
}

}  // namespace ambler::perception
