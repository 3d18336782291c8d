#pragma once
// Digital elevation models in (terrain.kind: dem; docs/terrains.md, "DEM terrains"): a GeoTIFF read
// with GDAL, cropped to the scenario's window and resampled onto the terrain's heightfield grid.
// GDAL lives here and in eval/geo/geotiff.cpp only; terrains/ gets the heights as a plain matrix.
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "eval/geo/geotiff.hpp"
#include "eval/scenario/scenario.hpp"
#include "terrains/heightfield.hpp"

namespace ambler::eval {

// A DEM refused: "<dem file>: <cause>" (one line).
class DemError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// A DEM window resampled onto a terrain grid.
struct DemSurface {
  terrains::HeightMatrix heights;  // terrains::terrainGrid(spec)'s samples (row 0 = smallest y): world z
  GeoFrame frame;                  // the DEM's CRS (WKT) and the world origin (the window centre) in it
  std::string crs_name;            // the CRS's name, for messages and metrics
  double vertical_offset_m = 0.0;  // world z = DEM height − this
  std::array<double, 2> pixel_m{};  // the DEM's pixel size (east, north), metres
  int dem_cols = 0, dem_rows = 0;  // the whole DEM's size in pixels
};

// Reads spec.dem (kind Dem) and resamples it onto terrains::terrainGrid(spec): the window of
// size_m centred on spec.dem_centre_m (absent: the DEM's centre), each sample the bilinear
// interpolation of the four nearest pixel centres (band 1, scale and offset applied), minus the
// vertical offset (absent: the DEM's interpolated height at the window centre, so z = 0 at the
// world origin). Refuses, with DemError "<file>: <cause>": a file GDAL cannot open as a GeoTIFF, no
// geotransform, a rotated or south-up geotransform, no CRS, a CRS that is not projected (geographic
// degrees), linear units other than the metre, heights in a unit other than metres, fewer than 2 × 2
// pixels, a window reaching beyond the DEM's outermost pixel centres, and any nodata (or NaN) pixel
// among those the window's samples interpolate from.
DemSurface readDem(const terrains::TerrainSpec& spec);

// The same for a scenario, refusals as ScenarioError "<scenario>: terrain.dem: <dem file>: <cause>"
// (terrain.window_m for a window beyond the DEM).
DemSurface readScenarioDem(const Scenario& sc);

// The terrain of a scenario of any kind but mjcf: a DEM's (read with readScenarioDem, which may
// refuse) with its components on top, or makeTerrain's. `dem`, when given, receives the DEM read
// (left empty for other kinds), for the run's georeferencing.
terrains::Terrain scenarioTerrain(const Scenario& sc, std::optional<DemSurface>* dem = nullptr);

// A single-band float32 GeoTIFF (DEFLATE, floating-point predictor): `north_up` holds rows × cols
// values, row 0 the northernmost; `geotransform` as GDAL's; `crs_wkt` empty writes no CRS; `nodata`
// the nodata value if any. Same input, same bytes. Written atomically; throws std::runtime_error
// naming the file on failure.
void writeDemGeoTiff(const std::filesystem::path& path, const std::vector<float>& north_up, int rows, int cols,
                     const std::array<double, 6>& geotransform, const std::string& crs_wkt,
                     std::optional<double> nodata);

// The sample DEM's model (docs/terrains.md, "The sample DEM"): a HiRISE-like 1 m DTM of a Mars
// crater plain in an equirectangular Mars 2000 projection.
struct SampleDemModel {
  int pixels = 256;                   // square, 1 m posting
  double posting_m = 1.0;
  double base_elevation_m = -2560.0;  // the plain's height at the centre (MOLA-like, Jezero's floor)
  double relief_m = 6.0;              // fBm peak-to-peak
  double hurst = 0.8;
  Eigen::Vector2d slope_deg{1.5, -1.0};  // regional tilt about x and y (docs/terrains.md, "Tilt")
  int craters = 12;
  double crater_min_m = 6.0, crater_max_m = 60.0, crater_sfd = 2.0;
  double footprint_radius_px = 200.0;   // pixels with |u−c| + |v−c| beyond this are nodata (a collar)
  double nodata = -3.4028226550889045e38;  // HiRISE DTMs' nodata value
  double centre_e_m = 4000.0, centre_n_m = 1093000.0;  // the DEM's centre in the CRS
};
// The sample DEM's CRS: equirectangular on the Mars 2000 sphere (R = 3 396 190 m), standard
// parallel 18.4° N, central meridian 77.5° E (as HiRISE DTMs of Jezero use), metres.
std::string marsEquirectangularWkt();
// Writes the sample DEM of `model` and `seed` (the fBm and craters of terrains/ with that seed).
void writeSampleDem(const std::filesystem::path& path, std::uint64_t seed = 1, const SampleDemModel& model = {});

}  // namespace ambler::eval
