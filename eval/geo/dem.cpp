#include "eval/geo/dem.hpp"

#include <cpl_conv.h>
#include <cpl_error.h>
#include <cpl_vsi.h>
#include <gdal.h>
#include <ogr_srs_api.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>

#include "base/text.hpp"
#include "eval/geo/gdal_internal.hpp"
#include "eval/scenario/message_text.hpp"
#include "terrains/terrain.hpp"

namespace ambler::eval {

namespace {

using base::plainText;

struct DatasetCloser {
  void operator()(void* ds) const { GDALClose(ds); }
};
using Dataset = std::unique_ptr<void, DatasetCloser>;

// "1.5" for 1.5, rounded to a millimetre so a message stays short.
std::string mm(double v) { return plainText(std::round(v * 1e3) / 1e3); }

}  // namespace

namespace {

// A DEM's georeference: the geotransform of north-up pixels in a projected CRS in metres, and the
// CRS's name. Throws DemError naming the file and the cause for anything else.
struct Georeference {
  std::array<double, 6> t{};
  std::string crs_name;
};

Georeference georeference(GDALDatasetH ds, const std::string& file) {
  const auto fail = [&](const std::string& cause) -> void { throw DemError(file + ": " + cause); };
  std::array<double, 6> t{};
  if (GDALGetGeoTransform(ds, t.data()) != CE_None || (t[0] == 0 && t[1] == 1 && t[2] == 0 && t[3] == 0 &&
                                                              t[4] == 0 && t[5] == 1))
    fail("no geotransform: the DEM is not georeferenced");
  if (t[2] != 0.0 || t[4] != 0.0)
    fail("rotated geotransform (terms 2 and 4: " + plainText(t[2]) + ", " + plainText(t[4]) +
         "); expected a north-up DEM");
  if (!(t[1] > 0.0 && t[5] < 0.0))
    fail("expected north-up pixels (geotransform terms 1 > 0 and 5 < 0), got " + plainText(t[1]) + " and " +
         plainText(t[5]));

  // The CRS: projected, in metres.
  OGRSpatialReferenceH srs = GDALGetSpatialRef(ds);
  if (!srs) fail("no coordinate reference system; expected a projected CRS in metres");
  const char* name_c = OSRGetName(srs);
  const std::string crs_name = name_c ? name_c : "unnamed";
  if (!OSRIsProjected(srs)) {
    fail(std::string(OSRIsGeographic(srs) ? "geographic CRS '" + escapedLine(crs_name) + "' (degrees)"
                                          : "CRS '" + escapedLine(crs_name) + "' is not projected") +
         "; expected a projected CRS in metres");
  }
  char* unit_c = nullptr;
  const double unit = OSRGetLinearUnits(srs, &unit_c);
  if (std::abs(unit - 1.0) > 1e-12)
    fail("linear unit '" + escapedLine(unit_c ? unit_c : "?") + "' (" + plainText(unit) +
         " m); expected a projected CRS in metres");
  return {t, crs_name};
}

// The window's pixels hold no nodata (nor NaN); throws DemError naming the file, the count and the
// first such pixel otherwise.
void checkNoData(GDALRasterBandH band, const std::vector<double>& block, int bw, int bh, int c0, int r0,
                 const std::string& file) {
  const auto fail = [&](const std::string& cause) -> void { throw DemError(file + ": " + cause); };
  int has_nodata = 0;
  const double nodata = GDALGetRasterNoDataValue(band, &has_nodata);
  long bad = 0;
  int first_c = -1, first_r = -1;
  for (int j = 0; j < bh; ++j)
    for (int i = 0; i < bw; ++i) {
      const double z = block[std::size_t(j) * bw + i];
      if (std::isnan(z) || (has_nodata && (z == nodata || (std::isnan(nodata) && std::isnan(z))))) {
        if (bad++ == 0) first_c = c0 + i, first_r = r0 + j;
      }
    }
  if (bad > 0)
    fail(std::to_string(bad) + " nodata pixel" + (bad == 1 ? "" : "s") +
         " under the window (the first at column " + std::to_string(first_c) + ", row " + std::to_string(first_r) +
         "); expected none: move or shrink the window");
}

}  // namespace

DemSurface readDem(const terrains::TerrainSpec& spec) {
  gdal::registerDrivers();
  const gdal::Quiet quiet;
  const std::string file = spec.dem;
  const auto fail = [&](const std::string& cause) -> void { throw DemError(file + ": " + cause); };

  const char* drivers[] = {"GTiff", nullptr};
  Dataset ds(GDALOpenEx(file.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY, drivers, nullptr, nullptr));
  if (!ds) fail("not a GeoTIFF GDAL can read" + gdal::lastError());
  const int W = GDALGetRasterXSize(ds.get()), H = GDALGetRasterYSize(ds.get());
  if (GDALGetRasterCount(ds.get()) < 1) fail("no raster band");
  if (W < 2 || H < 2)
    fail("expected at least 2 x 2 pixels, got " + std::to_string(W) + " x " + std::to_string(H));

  const Georeference geo = georeference(ds.get(), file);
  const std::array<double, 6>& t = geo.t;
  const std::string& crs_name = geo.crs_name;
  GDALRasterBandH band = GDALGetRasterBand(ds.get(), 1);  // band 1, whatever else the file holds
  const std::string z_unit = GDALGetRasterUnitType(band);
  if (!z_unit.empty() && z_unit != "m" && z_unit != "metre" && z_unit != "meter" && z_unit != "metres" &&
      z_unit != "meters")
    fail("heights in '" + escapedLine(z_unit) + "'; expected metres");

  // The window: the heightfield's samples, centred on the window centre.
  const terrains::Heightfield grid = terrains::terrainGrid(spec);
  const Eigen::Vector2d dem_centre(t[0] + 0.5 * W * t[1], t[3] + 0.5 * H * t[5]);
  const Eigen::Vector2d centre = spec.dem_centre_m.value_or(dem_centre);
  // Pixel-centre coordinates: pixel (column i, row j) has its centre at u = i, v = j.
  const auto u_of = [&](double e) { return (e - t[0]) / t[1] - 0.5; };
  const auto v_of = [&](double n) { return (n - t[3]) / t[5] - 0.5; };
  const double u0 = u_of(centre.x() + grid.xMin()), u1 = u_of(centre.x() + grid.xMax());
  const double v0 = v_of(centre.y() + grid.yMax()), v1 = v_of(centre.y() + grid.yMin());
  constexpr double kSlack = 1e-9;  // pixels: a window exactly on the outermost centres is inside
  if (!(u0 >= -kSlack && u1 <= W - 1 + kSlack && v0 >= -kSlack && v1 <= H - 1 + kSlack)) {
    throw DemError(file + ": the window of " + mm(grid.xMax() - grid.xMin()) + " x " + mm(grid.yMax() - grid.yMin()) +
                   " m centred at (" + mm(centre.x()) + ", " + mm(centre.y()) +
                   ") reaches beyond the DEM's outermost pixel centres (E " + mm(t[0] + 0.5 * t[1]) + " to " +
                   mm(t[0] + (W - 0.5) * t[1]) + ", N " + mm(t[3] + (H - 0.5) * t[5]) + " to " +
                   mm(t[3] + 0.5 * t[5]) + ")");
  }
  // The pixels the bilinear interpolation reads: columns c..c+1 for c = clamp(floor(u), 0, W−2).
  const auto lower = [](double x, int n) { return std::clamp(int(std::floor(x)), 0, n - 2); };
  const int c0 = lower(u0, W), c1 = lower(u1, W) + 1, r0 = lower(v0, H), r1 = lower(v1, H) + 1;
  const int bw = c1 - c0 + 1, bh = r1 - r0 + 1;
  std::vector<double> block(std::size_t(bw) * std::size_t(bh));
  if (GDALRasterIO(band, GF_Read, c0, r0, bw, bh, block.data(), bw, bh, GDT_Float64, 0, 0) != CE_None)
    fail("cannot read pixels" + gdal::lastError());
  checkNoData(band, block, bw, bh, c0, r0, file);
  int has_scale = 0, has_offset = 0;
  const double scale = GDALGetRasterScale(band, &has_scale), offset = GDALGetRasterOffset(band, &has_offset);
  for (double& z : block) z = z * (has_scale ? scale : 1.0) + (has_offset ? offset : 0.0);

  // Bilinear on the pixel centres.
  const auto height = [&](double e, double n) {
    const double u = u_of(e), v = v_of(n);
    const int c = lower(u, W), r = lower(v, H);
    const double fu = std::clamp(u - c, 0.0, 1.0), fv = std::clamp(v - r, 0.0, 1.0);
    const auto z = [&](int rr, int cc) { return block[std::size_t(rr - r0) * bw + std::size_t(cc - c0)]; };
    return (1 - fv) * ((1 - fu) * z(r, c) + fu * z(r, c + 1)) + fv * ((1 - fu) * z(r + 1, c) + fu * z(r + 1, c + 1));
  };
  DemSurface out;
  out.vertical_offset_m = spec.dem_vertical_offset_m.value_or(height(centre.x(), centre.y()));
  out.heights.resize(grid.rows(), grid.cols());
  for (int r = 0; r < grid.rows(); ++r)
    for (int c = 0; c < grid.cols(); ++c) {
      const Eigen::Vector2d p = grid.position(r, c);
      out.heights(r, c) = height(centre.x() + p.x(), centre.y() + p.y()) - out.vertical_offset_m;
    }
  const char* wkt = GDALGetProjectionRef(ds.get());
  out.frame.crs_wkt = wkt ? wkt : "";
  out.frame.origin_x_m = centre.x();
  out.frame.origin_y_m = centre.y();
  out.crs_name = crs_name;
  out.pixel_m = {t[1], -t[5]};
  out.dem_cols = W;
  out.dem_rows = H;
  return out;
}

DemSurface readScenarioDem(const Scenario& sc) {
  try {
    return readDem(sc.terrain);
  } catch (const DemError& e) {
    const std::string what = e.what();
    const bool window = what.find(": the window of ") != std::string::npos;
    throw ScenarioError((sc.file.empty() ? std::string("<string>") : sc.file.string()) +
                        (window ? ": terrain.window_m: " : ": terrain.dem: ") + what);
  }
}

terrains::Terrain scenarioTerrain(const Scenario& sc, std::optional<DemSurface>* dem) {
  if (sc.terrain.kind != terrains::TerrainKind::Dem) return terrains::makeTerrain(sc.terrain, sc.seed);
  DemSurface surface = readScenarioDem(sc);
  terrains::Terrain terrain = terrains::makeTerrain(sc.terrain, sc.seed, surface.heights);
  if (dem) *dem = std::move(surface);
  return terrain;
}

void writeDemGeoTiff(const std::filesystem::path& path, const std::vector<float>& north_up, int rows, int cols,
                     const std::array<double, 6>& geotransform, const std::string& crs_wkt,
                     std::optional<double> nodata) {
  if (rows < 1 || cols < 1 || north_up.size() != std::size_t(rows) * std::size_t(cols))
    throw std::runtime_error(path.string() + ": expected " + std::to_string(rows) + " x " + std::to_string(cols) +
                             " heights");
  gdal::writeFloat32(path, north_up.data(), rows, cols, geotransform, crs_wkt, nodata, 9);
}

std::string marsEquirectangularWkt() {
  return "PROJCS[\"Equirectangular Mars 2000 (Jezero)\","
         "GEOGCS[\"GCS_Mars_2000_Sphere\",DATUM[\"D_Mars_2000_Sphere\",SPHEROID[\"Mars_2000_Sphere_IAU_IAG\",3396190,0]],"
         "PRIMEM[\"Reference_Meridian\",0],UNIT[\"degree\",0.0174532925199433]],"
         "PROJECTION[\"Equirectangular\"],PARAMETER[\"standard_parallel_1\",18.4],PARAMETER[\"central_meridian\",77.5],"
         "PARAMETER[\"false_easting\",0],PARAMETER[\"false_northing\",0],UNIT[\"metre\",1]]";
}

void writeSampleDem(const std::filesystem::path& path, std::uint64_t seed, const SampleDemModel& m) {
  // The ground: the fBm, tilt and craters of terrains/ (docs/terrains.md) on the DEM's posting.
  terrains::TerrainSpec spec;
  spec.kind = terrains::TerrainKind::Fractal;
  spec.size_m = Eigen::Vector2d::Constant((m.pixels - 1) * m.posting_m);
  spec.cell_m = m.posting_m;
  spec.relief_m = m.relief_m;
  spec.hurst = m.hurst;
  spec.slope_deg = m.slope_deg;
  spec.craters = terrains::CraterSpec{m.craters, m.crater_min_m, m.crater_max_m, m.crater_sfd};
  const terrains::Terrain ground = terrains::makeTerrain(spec, seed);
  const terrains::Heightfield& g = ground.ground;
  std::vector<float> north_up(std::size_t(m.pixels) * std::size_t(m.pixels));
  const double mid = 0.5 * (m.pixels - 1);
  for (int j = 0; j < m.pixels; ++j)      // raster row j: heightfield row pixels − 1 − j (north up)
    for (int i = 0; i < m.pixels; ++i) {
      const bool inside = std::abs(i - mid) + std::abs(j - mid) <= m.footprint_radius_px;
      north_up[std::size_t(j) * m.pixels + i] =
          inside ? float(m.base_elevation_m + g.at(m.pixels - 1 - j, i)) : float(m.nodata);
    }
  const double half = 0.5 * m.pixels * m.posting_m;
  writeDemGeoTiff(path, north_up, m.pixels, m.pixels,
                  {m.centre_e_m - half, m.posting_m, 0.0, m.centre_n_m + half, 0.0, -m.posting_m},
                  marsEquirectangularWkt(), m.nodata);
}

}  // namespace ambler::eval
