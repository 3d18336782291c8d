#pragma once
// Composite maps (paper §4.3): maps of several views on one grid merged by the maximum-likelihood
// rule (eq. 9), and the σ a registration's uncertainty adds to a map (docs/composite.md).
// Onboard code: the poses are the rover's (matched) or whatever the caller gives.
#include <vector>

#include "perception/elevation_map.hpp"
#include "perception/iconic.hpp"
#include "perception/locus_mapper.hpp"
#include "perception/map_grid.hpp"
#include "perception/placement.hpp"
#include "perception/rigid_transform.hpp"
#include "perception/scan_to_map.hpp"

namespace ambler::perception {

// Merges `map` into `composite` (the same grid), cell by cell:
// - both Known: eq. 9, z = (σ₂²·z₁ + σ₁²·z₂)/(σ₁² + σ₂²), the ML estimate of two independent
//   Gaussian measurements, and its σ² = σ₁²·σ₂²/(σ₁² + σ₂²) (σ of 0, ground truth, wins outright;
//   two of 0 average);
// - one Known: that one (a measurement beats a shadow or nothing);
// - both Shadow: Shadow under the lower ceiling (each says the terrain lies below its own; NaN
//   ceilings say nothing);
// - Shadow and Unseen: the Shadow; both Unseen: Unseen.
// Throws std::invalid_argument if the grids differ.
void mergeInto(ElevationMap& composite, const ElevationMap& map);

// The same where part of each map's σ is shared by every view of a cell (an error they all make:
// docs/composite.md): `shared` gives that part's σ per cell (≤ σ; NaN: none), for the composite
// (updated) and for the map. z is eq. 9's as above; the σ is that of the same weighted mean
// w₁z₁ + w₂z₂ with the shared parts fully correlated and the rest independent:
//   σ_s = w₁σ_s1 + w₂σ_s2,   σ² = w₁²(σ₁² − σ_s1²) + w₂²(σ₂² − σ_s2²) + σ_s²,
// which is eq. 9's σ when nothing is shared. Throws std::invalid_argument if the sizes differ.
void mergeInto(ElevationMap& composite, Raster<float>& composite_shared, const ElevationMap& map,
               const Raster<float>& map_shared);

// The σ that an uncertain pose adds to each Known cell of `map` (NaN elsewhere). The map was
// built from a view whose sensor pose the rover corrected by ν (S = exp(ν)⁻¹·B, registerViews'
// convention, B the believed pose) and ν has covariance P (rx, ry, rz, tx, ty, tz). A point the
// view saw at q (believed frame) lands at p(ν) = Rᵀ·(q − t); to first order a perturbation δ of ν
// moves it by A(p)·δ, A = [∂Rᵀ/∂r_k·R·p (k = 0..2), −Rᵀ], and the surface (upward normal n, from
// the map's own slopes) moves vertically by nᵀ·A·δ/n_z, so σ² = nᵀ·A·P·Aᵀ·n/n_z² per cell. p is
// the cell's centre at its elevation, in the map frame (the world for the composite's maps).
Raster<float> registrationSigma(const ElevationMap& map, const PoseVector& nu, const Matrix6d& P);

// σ_z of every Known cell of `map` grown by `extra` in quadrature (√(σ² + extra²); NaN extra
// leaves a cell alone). Throws std::invalid_argument if the sizes differ.
void addSigma(ElevationMap& map, const Raster<float>& extra);

// The shared part of each Known cell's σ (`shared`, as mergeInto takes it; NaN: none) grown by
// `extra` in quadrature, √(shared² + extra²), and held at most the cell's σ in `map` (which should
// already include `extra`). NaN extra leaves a cell alone. Throws std::invalid_argument if the sizes
// differ.
void addShared(Raster<float>& shared, const ElevationMap& map, const Raster<float>& extra);

// A view's map as a composite merges it (docs/composite.md): the scan (its unwrapped image and
// edges) mapped on `grid` at T_WS (mapAtPose) with `config` and the footprint's term in σ on
// (LocusConfig::footprint_sigma), and in `shared` the part of each Known cell's σ every view of it
// shares, σ_rough (the σ the same scan has without roughness taken away in quadrature; 0 elsewhere).
ElevationMap mapForComposite(const ScanMap& scan, const Eigen::Isometry3d& T_WS, const MapGrid& grid,
                             const LocusConfig& config, Raster<float>& shared);

// The composite of several views on `grid` (docs/composite.md): each placed view's scan (its
// unwrapped image and edges) mapped by the locus algorithm straight onto the grid at its
// placement's pose (mapAtPose), with `config` and the footprint's term in σ on (it is shared by
// every view of a cell: LocusConfig::footprint_sigma); each cell's shared σ, σ_rough (the σ the
// same scan has without roughness taken away in quadrature); the σ its placement's chain adds
// (placementSigma, from the links the chain points into, which must still live); and the maps
// merged in view order by mergeInto with their shared parts. views[k] is view k's scan (null
// allowed for a view placed LeftOut); a view placed LeftOut contributes nothing. Throws
// std::invalid_argument when the two lists' sizes differ or a placed view has no scan.
ElevationMap buildComposite(const std::vector<const ScanMap*>& views, const std::vector<ViewPlacement>& placements,
                            const MapGrid& grid, const LocusConfig& config);

}  // namespace ambler::perception
