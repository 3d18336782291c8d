#pragma once
// An elevation map: a gravity-aligned grid (perception::MapGrid, north-up) with named layers —
// elevation, σ_z, state, and the shadow ceiling. Unknown elevation is NaN *and* a state (unseen
// or range shadow).
#include <Eigen/Core>
#include <cstdint>
#include <optional>

#include "perception/map_grid.hpp"

namespace ambler::perception {

enum class CellState : std::uint8_t {
  Unseen = 0,  // no data: outside the field of view, beyond range, no return, not asked for, or
               // in the undecidable part of the gap at an occluding edge (docs/locus.md)
  Known = 1,   // elevation and σ_z are set
  Shadow = 2,  // the cell's line meets the image at an occluding edge: hidden behind terrain,
               // below the shadow ceiling where there is one
};

using MapRaster = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
using StateRaster = Eigen::Matrix<std::uint8_t, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

class ElevationMap {
 public:
  ElevationMap() = default;
  // Every cell unseen, elevation and σ NaN.
  explicit ElevationMap(const MapGrid& grid);

  const MapGrid& grid() const { return grid_; }
  MapRaster& elevation() { return z_; }
  const MapRaster& elevation() const { return z_; }
  MapRaster& sigma() { return sigma_; }
  const MapRaster& sigma() const { return sigma_; }
  StateRaster& state() { return state_; }
  const StateRaster& state() const { return state_; }
  // Per shadow cell, the height its terrain is known to lie below: where the lowest sampled ray
  // that passes over the cell crosses its vertical line (docs/locus.md). NaN elsewhere, and in a
  // shadow cell that no sampled ray passes over.
  MapRaster& shadowCeiling() { return ceiling_; }
  const MapRaster& shadowCeiling() const { return ceiling_; }

  CellState stateAt(int r, int c) const { return CellState(state_(r, c)); }
  void setKnown(int r, int c, float z, float sigma);
  void setUnknown(int r, int c, CellState why);  // Unseen or Shadow (without a ceiling)
  void setShadow(int r, int c, float ceiling);

  // The elevation / σ of the cell containing (x, y); nullopt outside the grid or not known.
  std::optional<double> elevationAt(double x, double y) const;
  std::optional<double> sigmaAt(double x, double y) const;
  CellState stateAt(double x, double y) const;

  long count(CellState s) const;

 private:
  MapGrid grid_;
  MapRaster z_, sigma_, ceiling_;
  StateRaster state_;
};

}  // namespace ambler::perception
