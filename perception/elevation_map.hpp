#pragma once
// An elevation map: a grid in a gravity-aligned map frame (perception::MapGrid: T_WM, north-up)
// with named layers — elevation, σ_z, state, and the shadow ceiling — all heights along the map
// frame's z. Unknown elevation is NaN *and* a state (unseen or range shadow). Ground truth is an
// ElevationMap too (sim::GroundTruth: known cells with σ_z = 0).
#include <Eigen/Core>
#include <cstdint>
#include <optional>

#include "perception/raster.hpp"
#include "perception/map_grid.hpp"

namespace ambler::perception {

enum class CellState : std::uint8_t {
  Unseen = 0,  // no data: outside the field of view, beyond range, no return, not asked for, or
               // in the undecidable part of the gap at an occluding edge (docs/locus.md)
  Known = 1,   // elevation and σ_z are set
  Shadow = 2,  // the cell's line meets the image at an occluding edge: hidden behind terrain,
               // below the shadow ceiling where there is one
};

class ElevationMap {
 public:
  ElevationMap() = default;
  // Every cell unseen, elevation and σ NaN.
  explicit ElevationMap(const MapGrid& grid);

  const MapGrid& grid() const { return grid_; }
  const Eigen::Isometry3d& T_WM() const { return grid_.T_WM; }
  Raster<float>& elevation() { return z_; }
  const Raster<float>& elevation() const { return z_; }
  Raster<float>& sigma() { return sigma_; }
  const Raster<float>& sigma() const { return sigma_; }
  Raster<std::uint8_t>& state() { return state_; }
  const Raster<std::uint8_t>& state() const { return state_; }
  // Per shadow cell, the height its terrain is known to lie below: where the lowest sampled ray
  // that passes over the cell crosses its vertical line (docs/locus.md). NaN elsewhere, and in a
  // shadow cell that no sampled ray passes over.
  Raster<float>& shadowCeiling() { return ceiling_; }
  const Raster<float>& shadowCeiling() const { return ceiling_; }

  CellState stateAt(int r, int c) const { return CellState(state_(r, c)); }
  void setKnown(int r, int c, float z, float sigma);
  void setUnknown(int r, int c, CellState why);  // Unseen or Shadow (without a ceiling)
  void setShadow(int r, int c, float ceiling);

  // The elevation / σ of the cell containing (x, y) of the map frame; nullopt outside the grid or
  // not known.
  std::optional<double> elevationAt(double x, double y) const;
  std::optional<double> sigmaAt(double x, double y) const;
  CellState stateAt(double x, double y) const;

  long count(CellState s) const;

 private:
  MapGrid grid_;
  Raster<float> z_, sigma_, ceiling_;
  Raster<std::uint8_t> state_;
};

}  // namespace ambler::perception
