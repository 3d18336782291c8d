#pragma once
// What eval/geo/geotiff.cpp and eval/geo/dem.cpp share of GDAL (the only two files that call it): driver
// registration, quiet errors, and the one writer of float32 GeoTIFFs. Internal: GDAL is linked
// privately into ambler_eval, so no public header may include GDAL's.
#include <cpl_error.h>

#include <array>
#include <filesystem>
#include <optional>
#include <string>

namespace ambler::eval::gdal {

// GDALAllRegister, once per process.
void registerDrivers();

// GDAL's messages are collected, never printed, while one of these lives: a refusal is one line
// (docs/errors.md).
struct Quiet {
  Quiet() {
    CPLPushErrorHandler(CPLQuietErrorHandler);
    CPLErrorReset();
  }
  ~Quiet() { CPLPopErrorHandler(); }
  Quiet(const Quiet&) = delete;
  Quiet& operator=(const Quiet&) = delete;
};

// " (GDAL: <its last message>)", or "" when it said nothing.
std::string lastError();

// A single-band float32 GeoTIFF (DEFLATE at `deflate_level` with the floating-point predictor) of
// rows × cols values, row 0 the northernmost, with `transform` as GDAL's geotransform, `crs_wkt`
// (empty: no CRS) and `nodata` if any. Made in GDAL's memory file system, then written atomically.
// Same input, same bytes. Throws std::runtime_error "<path>: <cause>".
void writeFloat32(const std::filesystem::path& path, const float* north_up, int rows, int cols,
                  const std::array<double, 6>& transform, const std::string& crs_wkt, std::optional<double> nodata,
                  int deflate_level = 6);

}  // namespace ambler::eval::gdal
