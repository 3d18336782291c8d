// GeoTIFF map rasters (eval/geo/geotiff.hpp): the geotransform against the grid's own cell centres,
// the bytes GDAL and OpenCV read back against the raster written, the CRS, and refusals.
#include "eval/geo/geotiff.hpp"

#include <cpl_conv.h>
#include <gdal.h>
#include <gtest/gtest.h>
#include <ogr_srs_api.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <numbers>

#include "eval/scenario/io.hpp"
#include "perception/map_grid.hpp"
#include "test_support.hpp"

namespace ambler::eval {
namespace {

using perception::MapGrid;
using perception::Raster;

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

// A raster whose every value differs, with NaN (unknown cells) sprinkled in.
Raster<float> sample(int rows, int cols) {
  Raster<float> r(rows, cols);
  for (int i = 0; i < rows; ++i)
    for (int j = 0; j < cols; ++j) r(i, j) = (i * 7 + j) % 11 == 0 ? kNaN : float(0.001 * i - 0.37 * j + 1e-7 * i * j);
  return r;
}

// The world point a GDAL geotransform gives pixel position (column u, row v) (corner convention).
Eigen::Vector2d apply(const std::array<double, 6>& t, double u, double v) {
  return {t[0] + u * t[1] + v * t[2], t[3] + u * t[4] + v * t[5]};
}

struct Opened {
  GDALDatasetH ds;
  explicit Opened(const std::filesystem::path& p) {
    GDALAllRegister();
    ds = GDALOpen(p.c_str(), GA_ReadOnly);
  }
  ~Opened() {
    if (ds) GDALClose(ds);
  }
};

TEST(GeoTiff, WorldGridTransformIsTheCornerAndTheCell) {
  const MapGrid g = MapGrid::covering(-5, 5, -3, 8, 0.1);
  const auto t = geoTransform(g, {});
  EXPECT_DOUBLE_EQ(t[0], -5.0);
  EXPECT_DOUBLE_EQ(t[3], 8.0);
  EXPECT_DOUBLE_EQ(t[1], 0.1);
  EXPECT_DOUBLE_EQ(t[5], -0.1);
  EXPECT_EQ(t[2], 0.0);
  EXPECT_EQ(t[4], 0.0);
  // A DEM frame only shifts it by the world origin's easting and northing.
  const auto e = geoTransform(g, {"", 1.5e6, -2.25e5});
  EXPECT_DOUBLE_EQ(e[0], 1.5e6 - 5.0);
  EXPECT_DOUBLE_EQ(e[3], -2.25e5 + 8.0);
}

TEST(GeoTiff, PixelCentresAreTheGridsCellCentresInAnyMapFrame) {
  // A map frame turned by 30° and moved: the geotransform must put pixel (c + ½, r + ½) at the cell
  // centre the grid itself reports in the world.
  const MapGrid g = MapGrid::covering(-1.2, 2.3, 0.4, 3.1, 0.05,
                                      perception::mapFrame({3.0, -2.0, 0.7}, 30.0 * std::numbers::pi / 180.0));
  const GeoFrame frame{"", 1000.0, 2000.0};
  const auto t = geoTransform(g, frame);
  for (int r : {0, 7, g.rows - 1})
    for (int c : {0, 13, g.cols - 1}) {
      const Eigen::Vector3d w = g.worldPoint(r, c, 0.0);
      const Eigen::Vector2d p = apply(t, c + 0.5, r + 0.5);
      EXPECT_NEAR(p.x(), w.x() + 1000.0, 1e-9) << r << "," << c;
      EXPECT_NEAR(p.y(), w.y() + 2000.0, 1e-9) << r << "," << c;
    }
}

TEST(GeoTiff, GdalReadsBackTransformNodataCrsAndEveryBit) {
  test::TempDir tmp;
  const MapGrid g = MapGrid::covering(-2, 3, -1, 1.5, 0.1);
  const Raster<float> r = sample(g.rows, g.cols);
  const auto path = tmp.path() / "m.tiff";
  writeGeoTiff(path, r, g, {});
  Opened f(path);
  ASSERT_NE(f.ds, nullptr);
  EXPECT_EQ(GDALGetRasterXSize(f.ds), g.cols);
  EXPECT_EQ(GDALGetRasterYSize(f.ds), g.rows);
  EXPECT_EQ(GDALGetRasterCount(f.ds), 1);
  double t[6];
  ASSERT_EQ(GDALGetGeoTransform(f.ds, t), CE_None);
  const auto want = geoTransform(g, {});
  for (int i = 0; i < 6; ++i) EXPECT_EQ(t[i], want[i]) << i;
  GDALRasterBandH band = GDALGetRasterBand(f.ds, 1);
  EXPECT_EQ(GDALGetRasterDataType(band), GDT_Float32);
  int has_nodata = 0;
  EXPECT_TRUE(std::isnan(GDALGetRasterNoDataValue(band, &has_nodata)));
  EXPECT_TRUE(has_nodata);
  Raster<float> back(g.rows, g.cols);
  ASSERT_EQ(GDALRasterIO(band, GF_Read, 0, 0, g.cols, g.rows, back.data(), g.cols, g.rows, GDT_Float32, 0, 0), CE_None);
  EXPECT_EQ(std::memcmp(back.data(), r.data(), sizeof(float) * r.size()), 0);
  // No CRS given: the local engineering frame in metres.
  OGRSpatialReferenceH srs = OSRNewSpatialReference(GDALGetProjectionRef(f.ds));
  ASSERT_NE(srs, nullptr);
  EXPECT_TRUE(OSRIsLocal(srs));
  EXPECT_DOUBLE_EQ(OSRGetLinearUnits(srs, nullptr), 1.0);
  OSRDestroySpatialReference(srs);
  // OpenCV (eval::readTiff, what scripts and tests use) reads the same bits.
  const Raster<float> cv_back = readTiff(path);
  ASSERT_EQ(cv_back.size(), r.size());
  EXPECT_EQ(std::memcmp(cv_back.data(), r.data(), sizeof(float) * r.size()), 0);
}

TEST(GeoTiff, AProjectedCrsIsKept) {
  test::TempDir tmp;
  OGRSpatialReferenceH utm = OSRNewSpatialReference(nullptr);
  ASSERT_EQ(OSRImportFromEPSG(utm, 32633), OGRERR_NONE);
  char* wkt = nullptr;
  OSRExportToWkt(utm, &wkt);
  const GeoFrame frame{wkt, 500000.0, 4649776.0};
  CPLFree(wkt);
  const MapGrid g = MapGrid::covering(0, 1, 0, 1, 0.25);
  writeGeoTiff(tmp.path() / "u.tiff", sample(g.rows, g.cols), g, frame);
  Opened f(tmp.path() / "u.tiff");
  ASSERT_NE(f.ds, nullptr);
  OGRSpatialReferenceH got = OSRNewSpatialReference(GDALGetProjectionRef(f.ds));
  ASSERT_NE(got, nullptr);
  EXPECT_TRUE(OSRIsSame(got, utm));
  double t[6];
  ASSERT_EQ(GDALGetGeoTransform(f.ds, t), CE_None);
  EXPECT_DOUBLE_EQ(t[0], 500000.0);
  EXPECT_DOUBLE_EQ(t[3], 4649777.0);
  OSRDestroySpatialReference(got);
  OSRDestroySpatialReference(utm);
}

TEST(GeoTiff, SameRasterSameBytes) {
  test::TempDir tmp;
  const MapGrid g = MapGrid::covering(-2, 3, -1, 1.5, 0.1);
  writeGeoTiff(tmp.path() / "a.tiff", sample(g.rows, g.cols), g, {});
  writeGeoTiff(tmp.path() / "b.tiff", sample(g.rows, g.cols), g, {});
  const std::string a = test::slurp(tmp.path() / "a.tiff");
  EXPECT_GT(a.size(), 100u);
  EXPECT_EQ(a, test::slurp(tmp.path() / "b.tiff"));
}

TEST(GeoTiff, RefusesARasterNotOnItsGridAndAnUnwritablePath) {
  test::TempDir tmp;
  const MapGrid g = MapGrid::covering(0, 1, 0, 1, 0.25);
  try {
    writeGeoTiff(tmp.path() / "x.tiff", sample(3, 4), g, {});
    FAIL() << "no refusal";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()), (tmp.path() / "x.tiff").string() + ": the raster is 3 x 4 but its grid is 4 x 4");
  }
  EXPECT_FALSE(std::filesystem::exists(tmp.path() / "x.tiff"));
  const auto blocked = tmp.path() / "file" / "m.tiff";
  { std::ofstream(tmp.path() / "file") << "x"; }
  EXPECT_THROW(writeGeoTiff(blocked, sample(g.rows, g.cols), g, {}), std::runtime_error);
}

}  // namespace
}  // namespace ambler::eval
