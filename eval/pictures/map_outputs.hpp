#pragma once
// The map files of a run directory (docs/scenario.md, "The run directory"): the layers as rasters a GIS or a
// script reads back bit for bit, and pictures of them for people.
#include <filesystem>
#include <string>

#include "eval/geo/geotiff.hpp"
#include "perception/elevation_map.hpp"
#include "sim/ground_truth.hpp"

namespace ambler::eval {

// Writes into `dir` (which must exist):
//   <stem>_elevation.tiff, <stem>_sigma.tiff   float32, NaN where unknown
//   <stem>_shadow_ceiling.tiff                 float32: the height a shadow cell lies below, NaN elsewhere
//   <stem>_state.png                           uint8, pixel value = perception::CellState
//   <stem>_meta.json                           {"x_min_m", "y_max_m", "cell_m", "rows", "cols",
//                                               "frame": {"origin_m", "yaw_deg"}}
//   <stem>_elevation.png, <stem>_sigma.png, <stem>_state_view.png, and, when `truth` is given
//   (on the map's grid), <stem>_error.png.
// Every raster is north-up (row 0 is the cell row of largest y of the map frame), and every .tiff is
// a GeoTIFF placed by its geotransform in `geo` (eval/geo/geotiff.hpp). Throws std::runtime_error naming
// the file that cannot be written, std::invalid_argument when `truth` is not on the map's grid.
void writeMapFiles(const std::filesystem::path& dir, const std::string& stem,
                   const perception::ElevationMap& map, const perception::ElevationMap* truth,
                   const std::string& title, const GeoFrame& geo = {});

// The Cartesian baseline: <stem>_cartesian_elevation.tiff and, when `truth` is given,
// <stem>_cartesian_error.png. Throws like writeMapFiles.
void writeCartesianFiles(const std::filesystem::path& dir, const std::string& stem,
                         const perception::ElevationMap& map, const perception::ElevationMap* truth,
                         const std::string& title, const GeoFrame& geo = {});

}  // namespace ambler::eval
