#pragma once
// The one raster type of the project: a row-major Eigen matrix. Map layers, ground truth,
// visibility, edge masks and range images are all Raster<T>. For maps the row order is north-up
// (MapGrid: row 0 is the largest y of the map frame); a range image's row 0 is its top scanline.
// Only the terrain's heightfield keeps MuJoCo's order (row 0 = smallest y), and only sim/world.cpp
// hands it on, to MuJoCo (docs/conventions.md, "Rasters").
#include <Eigen/Core>

namespace ambler::perception {

template <class T>
using Raster = Eigen::Matrix<T, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

}  // namespace ambler::perception
