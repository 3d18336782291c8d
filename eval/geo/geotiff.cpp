#include "eval/geo/geotiff.hpp"

#include <cpl_conv.h>
#include <cpl_vsi.h>
#include <gdal.h>

#include <atomic>
#include <cmath>
#include <limits>
#include <mutex>
#include <stdexcept>
#include <string>

#include "base/atomic_file.hpp"
#include "eval/geo/gdal_internal.hpp"
#include "eval/scenario/message_text.hpp"

namespace ambler::eval {

namespace gdal {

void registerDrivers() {
  static std::once_flag once;
  std::call_once(once, [] { GDALAllRegister(); });
}

std::string lastError() {
  const std::string m = CPLGetLastErrorMsg();
  return m.empty() ? std::string() : " (GDAL: " + escapedLine(m) + ")";
}

void writeFloat32(const std::filesystem::path& path, const float* north_up, int rows, int cols,
                  const std::array<double, 6>& transform, const std::string& crs_wkt, std::optional<double> nodata,
                  int deflate_level) {
  registerDrivers();
  const Quiet quiet;
  const auto fail = [&](const std::string& what) { throw std::runtime_error(path.string() + ": " + what); };
  if (rows < 1 || cols < 1) fail("cannot write an empty raster");
  GDALDriverH driver = GDALGetDriverByName("GTiff");
  if (!driver) fail("GDAL has no GTiff driver");
  static std::atomic<unsigned long> counter{0};
  const std::string mem = "/vsimem/ambler_geotiff_" + std::to_string(counter++) + ".tif";
  const std::string zlevel = "ZLEVEL=" + std::to_string(deflate_level);
  const char* options[] = {"COMPRESS=DEFLATE", "PREDICTOR=3", zlevel.c_str(), nullptr};
  GDALDatasetH ds = GDALCreate(driver, mem.c_str(), cols, rows, 1, GDT_Float32, const_cast<char**>(options));
  if (!ds) fail("GDAL cannot create the GeoTIFF" + lastError());
  std::array<double, 6> t = transform;
  bool ok = GDALSetGeoTransform(ds, t.data()) == CE_None;
  if (!crs_wkt.empty()) ok = ok && GDALSetProjection(ds, crs_wkt.c_str()) == CE_None;
  GDALRasterBandH band = GDALGetRasterBand(ds, 1);
  if (nodata) ok = ok && GDALSetRasterNoDataValue(band, *nodata) == CE_None;
  ok = ok && GDALRasterIO(band, GF_Write, 0, 0, cols, rows, const_cast<float*>(north_up), cols, rows, GDT_Float32, 0,
                          0) == CE_None;
  const std::string error = ok ? "" : lastError();
  GDALClose(ds);
  if (!ok) {
    VSIUnlink(mem.c_str());
    fail("GDAL cannot write the GeoTIFF" + error);
  }
  vsi_l_offset size = 0;
  GByte* bytes = VSIGetMemFileBuffer(mem.c_str(), &size, TRUE);
  if (!bytes) fail("GDAL wrote no GeoTIFF");
  const std::string data(reinterpret_cast<const char*>(bytes), static_cast<std::size_t>(size));
  CPLFree(bytes);
  base::writeFileAtomic(path, data);
}

}  // namespace gdal

std::string localFrameWkt() {
  return "LOCAL_CS[\"ambler world frame (x east, y north, metres)\",LOCAL_DATUM[\"ambler world origin\",0],"
         "UNIT[\"metre\",1],AXIS[\"x\",EAST],AXIS[\"y\",NORTH]]";
}

std::array<double, 6> geoTransform(const perception::MapGrid& grid, const GeoFrame& frame) {
  const Eigen::Matrix3d R = grid.T_WM.linear();
  const Eigen::Vector3d o = grid.T_WM.translation();
  const double c = R(0, 0), s = R(1, 0), h = grid.cell;
  return {frame.origin_x_m + o.x() + c * grid.x_min - s * grid.y_max, c * h, s * h,
          frame.origin_y_m + o.y() + s * grid.x_min + c * grid.y_max, s * h, -c * h};
}

void writeGeoTiff(const std::filesystem::path& path, const perception::Raster<float>& raster,
                  const perception::MapGrid& grid, const GeoFrame& frame) {
  if (raster.rows() != grid.rows || raster.cols() != grid.cols)
    throw std::runtime_error(path.string() + ": the raster is " + std::to_string(raster.rows()) + " x " +
                             std::to_string(raster.cols()) + " but its grid is " + std::to_string(grid.rows) + " x " +
                             std::to_string(grid.cols));
  gdal::writeFloat32(path, raster.data(), grid.rows, grid.cols, geoTransform(grid, frame),
                     frame.crs_wkt.empty() ? localFrameWkt() : frame.crs_wkt,
                     std::numeric_limits<double>::quiet_NaN());
}

}  // namespace ambler::eval
