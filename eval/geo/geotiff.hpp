#pragma once
// GeoTIFF map rasters (docs/conventions.md, "GeoTIFF"): what QGIS and GDAL need to place a map.
#include <array>
#include <filesystem>
#include <string>

#include "perception/map_grid.hpp"
#include "perception/raster.hpp"

namespace ambler::eval {

// Where a map raster lies: the coordinate system its x and y are in, and where the world origin is
// in it. A run on a procedural terrain has no Earth frame: crs_wkt is empty and the rasters carry
// a local engineering frame in metres (the world frame). A run on a DEM (terrain.kind: dem) takes
// the DEM's projected CRS, and the world origin is the centre of the DEM window, at
// (origin_x_m, origin_y_m) in that CRS; world z is the DEM's height minus its vertical offset.
struct GeoFrame {
  std::string crs_wkt;
  double origin_x_m = 0.0, origin_y_m = 0.0;
};

// The WKT of the local frame written when GeoFrame::crs_wkt is empty.
std::string localFrameWkt();

// The GDAL geotransform of `grid` in `frame`: pixel (column c, row r) has its corner at
// X = t[0] + c·t[1] + r·t[2], Y = t[3] + c·t[4] + r·t[5]. A grid whose map frame is turned by a yaw
// about z gets the rotation terms; a world-frame grid has t[2] = t[4] = 0 and t[5] = −cell.
std::array<double, 6> geoTransform(const perception::MapGrid& grid, const GeoFrame& frame);

// A raster on `grid` as a single-channel float32 GeoTIFF (DEFLATE, floating-point predictor), with
// the grid's geotransform in `frame`, the frame's CRS, and NaN as its nodata value. The pixel values
// are the raster's, unchanged, so readTiff reads them back. Same raster, same bytes. Written
// atomically; throws std::runtime_error naming the file on failure.
void writeGeoTiff(const std::filesystem::path& path, const perception::Raster<float>& raster,
                  const perception::MapGrid& grid, const GeoFrame& frame);

}  // namespace ambler::eval
