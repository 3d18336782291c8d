#include "eval/geotiff.hpp"

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

namespace ambler::eval {

namespace {

void registerGdal() {
  static std::once_flag once;
  std::call_once(once, [] { GDALAllRegister(); });
}

[[noreturn]] void fail(const std::filesystem::path& path, const std::string& what) {
  throw std::runtime_error(path.string() + ": " + what);
}

}  // namespace

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
  registerGdal();
  if (raster.rows() == 0 || raster.cols() == 0) fail(path, "cannot write an empty raster");
  if (raster.rows() != grid.rows || raster.cols() != grid.cols)
    fail(path, "the raster is " + std::to_string(raster.rows()) + " x " + std::to_string(raster.cols()) +
                   " but its grid is " + std::to_string(grid.rows) + " x " + std::to_string(grid.cols));
  GDALDriverH driver = GDALGetDriverByName("GTiff");
  if (!driver) fail(path, "GDAL has no GTiff driver");
  // The file is made in GDAL's memory file system, then written atomically like every other output.
  static std::atomic<unsigned long> counter{0};
  const std::string mem = "/vsimem/ambler_geotiff_" + std::to_string(counter++) + ".tif";
  const char* options[] = {"COMPRESS=DEFLATE", "PREDICTOR=3", "INTERLEAVE=BAND", nullptr};
  GDALDatasetH ds = GDALCreate(driver, mem.c_str(), static_cast<int>(raster.cols()), static_cast<int>(raster.rows()),
                               1, GDT_Float32, const_cast<char**>(options));
  if (!ds) fail(path, std::string("GDAL cannot create the GeoTIFF: ") + CPLGetLastErrorMsg());
  std::array<double, 6> transform = geoTransform(grid, frame);
  bool ok = GDALSetGeoTransform(ds, transform.data()) == CE_None;
  const std::string wkt = frame.crs_wkt.empty() ? localFrameWkt() : frame.crs_wkt;
  ok = ok && GDALSetProjection(ds, wkt.c_str()) == CE_None;
  GDALRasterBandH band = GDALGetRasterBand(ds, 1);
  ok = ok && GDALSetRasterNoDataValue(band, std::numeric_limits<double>::quiet_NaN()) == CE_None;
  ok = ok && GDALRasterIO(band, GF_Write, 0, 0, static_cast<int>(raster.cols()), static_cast<int>(raster.rows()),
                          const_cast<float*>(raster.data()), static_cast<int>(raster.cols()),
                          static_cast<int>(raster.rows()), GDT_Float32, 0, 0) == CE_None;
  const std::string error = ok ? "" : CPLGetLastErrorMsg();
  GDALClose(ds);
  if (!ok) {
    VSIUnlink(mem.c_str());
    fail(path, "GDAL cannot write the GeoTIFF: " + error);
  }
  vsi_l_offset size = 0;
  GByte* bytes = VSIGetMemFileBuffer(mem.c_str(), &size, TRUE);
  if (!bytes) fail(path, "GDAL wrote no GeoTIFF");
  std::string data(reinterpret_cast<const char*>(bytes), static_cast<std::size_t>(size));
  CPLFree(bytes);
  base::writeFileAtomic(path, data);
}

}  // namespace ambler::eval
