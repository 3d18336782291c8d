#include "perception/elevation_map.hpp"

#include <limits>

namespace ambler::perception {

namespace {
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
}

ElevationMap::ElevationMap(const MapGrid& grid)
    : grid_(grid),
      z_(Raster<float>::Constant(grid.rows, grid.cols, kNaN)),
      sigma_(Raster<float>::Constant(grid.rows, grid.cols, kNaN)),
      ceiling_(Raster<float>::Constant(grid.rows, grid.cols, kNaN)),
      state_(Raster<std::uint8_t>::Constant(grid.rows, grid.cols, std::uint8_t(CellState::Unseen))) {}

void ElevationMap::setKnown(int r, int c, float z, float sigma) {
  z_(r, c) = z;
  sigma_(r, c) = sigma;
  ceiling_(r, c) = kNaN;
  state_(r, c) = std::uint8_t(CellState::Known);
}

void ElevationMap::setUnknown(int r, int c, CellState why) {
  z_(r, c) = kNaN;
  sigma_(r, c) = kNaN;
  ceiling_(r, c) = kNaN;
  state_(r, c) = std::uint8_t(why);
}

void ElevationMap::setShadow(int r, int c, float ceiling) {
  setUnknown(r, c, CellState::Shadow);
  ceiling_(r, c) = ceiling;
}

std::optional<double> ElevationMap::elevationAt(double x, double y) const {
  const auto cell = grid_.cellOf(x, y);
  if (!cell || stateAt((*cell)(0), (*cell)(1)) != CellState::Known) return std::nullopt;
  return z_((*cell)(0), (*cell)(1));
}

std::optional<double> ElevationMap::sigmaAt(double x, double y) const {
  const auto cell = grid_.cellOf(x, y);
  if (!cell || stateAt((*cell)(0), (*cell)(1)) != CellState::Known) return std::nullopt;
  return sigma_((*cell)(0), (*cell)(1));
}

CellState ElevationMap::stateAt(double x, double y) const {
  const auto cell = grid_.cellOf(x, y);
  return cell ? stateAt((*cell)(0), (*cell)(1)) : CellState::Unseen;
}

long ElevationMap::count(CellState s) const {
  long n = 0;
  for (long i = 0; i < state_.size(); ++i) n += state_.data()[i] == std::uint8_t(s);
  return n;
}

}  // namespace ambler::perception
