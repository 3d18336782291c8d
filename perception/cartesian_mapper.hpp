#pragma once
// The Cartesian baseline the paper compares against (Sections 3 and 6): eq. 1 applied to every
// pixel, the points binned into the map grid (averaged where several share a cell), and gaps
// filled by interpolation. A fair competitor: the better of nearest and linear gap filling is
// reported. docs/cartesian_baseline.md explains the choices and why the map thins with range.
#include <Eigen/Core>
#include <cstdint>

#include "perception/raster.hpp"
#include "perception/elevation_map.hpp"
#include "perception/range_image.hpp"

namespace ambler::perception {

enum class GapFill {
  None,     // only cells that received points are known
  Nearest,  // an empty cell takes the value of the nearest binned cell within max_gap_m
  Linear,   // barycentric interpolation on a Delaunay triangulation of the binned centroids
};

struct CartesianConfig {
  GapFill gap_fill = GapFill::Linear;
  // Gaps wider than this stay unknown: no interpolation across holes such as range shadows.
  // Nearest: the largest centre-to-centre distance to the binned cell that gives the value (so it
  // also reaches this far past the edge of the data). Linear: triangles whose longest edge exceeds
  // max_gap_m + one cell diagonal are not used; it never extrapolates.
  double max_gap_m = 0.5;
};

// What eq. 1 puts into each cell before any gap is filled (world frame, metres). Where a cell has
// no point, count is 0 and the other layers are NaN.
struct CartesianBins {
  Raster<std::int32_t> count;                    // points in the cell
  Raster<double> mean_x, mean_y, mean_z;   // centroid of the cell's points
  Raster<double> sem_z;                    // standard error of mean_z; NaN below two points
};

// Bins every valid (finite) pixel of `image` into `grid` by the cell containing its world (x, y),
// exactly as MapGrid::cellOf. Deterministic. Throws std::invalid_argument on an empty grid or a
// cell size that is not > 0.
CartesianBins binPoints(const RangeImage& image, const MapGrid& grid);

// The baseline elevation map: binned cells are Known with the mean z and σ = sem_z; filled cells
// are Known with σ = NaN (no error model); the rest stay Unseen. Points just off the grid take part
// in filling its border cells. Deterministic. Throws std::invalid_argument as binPoints, or if
// config.max_gap_m is negative or not finite.
ElevationMap cartesianMap(const RangeImage& image, const MapGrid& grid,
                          const CartesianConfig& config = {});

}  // namespace ambler::perception
