// Tests for terrain/geotiff_reader.cpp: the bundled real DEMs, pixel types and
// layouts, georeferencing variants, and a Rejects* case for every bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <ostream>
#include <string>

#include "horizon/terrain/dem_reader.hpp"
#include "test_support.hpp"
#include "tiff_fixtures.hpp"

namespace horizon::terrain {
namespace {

using testing::bundled_dem;
using testing::RawTiff;
using testing::TempDir;

constexpr double kSrtmStep = 1.0 / 1200.0;

// --- The bundled real DEMs (numbers from gdalinfo, see data/dem/README.md) ---

TEST(GeoTiffReader, ReadsRainierInt16GeographicWithVoids) {
  auto dem = read_geotiff(bundled_dem("rainier_summit_srtm3_400x400.tif"), {});
  ASSERT_TRUE(dem.ok()) << dem.error().message;
  EXPECT_EQ(dem->width(), 400);
  EXPECT_EQ(dem->height(), 400);
  EXPECT_EQ(dem->georef.epsg, 4326);
  EXPECT_NEAR(dem->georef.transform.origin_x, -121.927083333333329, 1e-9);
  EXPECT_NEAR(dem->georef.transform.origin_y, 47.000416666666666, 1e-9);
  EXPECT_NEAR(dem->georef.transform.pixel_width, kSrtmStep, 1e-12);
  EXPECT_NEAR(dem->georef.transform.pixel_height, -kSrtmStep, 1e-12);
  ASSERT_TRUE(dem->nodata.has_value());
  EXPECT_EQ(*dem->nodata, -32768.0);
  EXPECT_EQ(dem->format, "GeoTIFF Int16 (deflate, tiled 256x256)");
  const ElevationStats s = elevation_stats(dem->elevation);
  EXPECT_EQ(s.nodata_cells, 3700u);
  EXPECT_EQ(s.min, 377.0);
  EXPECT_EQ(s.max, 4371.0);
  EXPECT_EQ(dem->elevation.at(0, 0), 666.0f);
  EXPECT_EQ(dem->elevation.at(399, 399), 493.0f);
  // The summit cell, about 46.8529 N, 121.7604 W.
  EXPECT_EQ(dem->elevation.at(199, 177), 4371.0f);
  EXPECT_NEAR(dem->georef.transform.x_at(199), -121.7604, 0.001);
  EXPECT_NEAR(dem->georef.transform.y_at(177), 46.8529, 0.001);
}

TEST(GeoTiffReader, ReadsEverestVoidsAsNaN) {
  auto dem = read_geotiff(bundled_dem("everest_summit_voids_srtm3_300x300.tif"), {});
  ASSERT_TRUE(dem.ok()) << dem.error().message;
  const ElevationStats s = elevation_stats(dem->elevation);
  EXPECT_EQ(s.nodata_cells, 27586u);
  EXPECT_EQ(s.valid_cells, 300u * 300u - 27586u);
  EXPECT_EQ(s.max, 8642.0);
  EXPECT_EQ(dem->elevation.at(209, 12), 8642.0f);
  EXPECT_TRUE(std::isnan(dem->elevation.at(209, 14)));  // the (unfilled) summit void
  EXPECT_NEAR(dem->georef.transform.origin_x, 86.750416666666666, 1e-9);
}

TEST(GeoTiffReader, ReadsProjectedFloat32) {
  auto dem = read_geotiff(bundled_dem("olinda_coast_utm25s_111x111.tif"), {});
  ASSERT_TRUE(dem.ok()) << dem.error().message;
  EXPECT_EQ(dem->georef.epsg, 31985);
  EXPECT_NEAR(dem->georef.transform.origin_x, 288776.250000803149305, 1e-6);
  EXPECT_NEAR(dem->georef.transform.origin_y, 9120760.750028736889362, 1e-6);
  EXPECT_NEAR(dem->georef.transform.pixel_width, 89.994067349451157, 1e-9);
  EXPECT_EQ(dem->format, "GeoTIFF Float32 (deflate, tiled 256x256)");
  const ElevationStats s = elevation_stats(dem->elevation);
  EXPECT_EQ(s.nodata_cells, 0u);
  EXPECT_EQ(s.min, -1.0);
  EXPECT_EQ(s.max, 88.0);
  EXPECT_EQ(dem->elevation.at(0, 0), 38.0f);
}

TEST(GeoTiffReader, ReadsFloat32WithNaNNodata) {
  auto dem = read_geotiff(bundled_dem("ecuador_andes_utm17s_10m_383x415.tif"), {});
  ASSERT_TRUE(dem.ok()) << dem.error().message;
  EXPECT_EQ(dem->georef.epsg, 32717);
  EXPECT_EQ(dem->georef.transform.pixel_width, 10.0);
  ASSERT_TRUE(dem->nodata.has_value());
  EXPECT_TRUE(std::isnan(*dem->nodata));
  const ElevationStats s = elevation_stats(dem->elevation);
  EXPECT_EQ(s.nodata_cells, 619u);
  EXPECT_NEAR(s.min, 1711.2039794921875, 1e-9);
  EXPECT_NEAR(s.max, 3164.1650390625, 1e-9);
  EXPECT_FLOAT_EQ(dem->elevation.at(0, 0), 2227.60009765625f);
}

TEST(GeoTiffReader, ReadsZionWithoutVoids) {
  auto dem = read_geotiff(bundled_dem("zion_canyon_srtm3_465x457.tif"), {});
  ASSERT_TRUE(dem.ok()) << dem.error().message;
  EXPECT_EQ(dem->width(), 465);
  EXPECT_EQ(dem->height(), 457);
  const ElevationStats s = elevation_stats(dem->elevation);
  EXPECT_EQ(s.nodata_cells, 0u);
  EXPECT_EQ(s.min, 1024.0);
  EXPECT_EQ(s.max, 2892.0);
  EXPECT_EQ(dem->source, bundled_dem("zion_canyon_srtm3_465x457.tif"));
}

// --- Georeferencing variants --------------------------------------------

TEST(GeoTiffReader, PixelIsPointShiftsOriginByHalfACell) {
  TempDir dir;
  RawTiff t = testing::utm_raw_tiff(4, 3);
  t.geokeys = {{1024, 1}, {1025, 2}, {3072, 32633}};  // RasterPixelIsPoint
  ASSERT_TRUE(testing::write_raw_tiff(dir.file("point.tif"), t));
  auto dem = read_geotiff(dir.file("point.tif"), {});
  ASSERT_TRUE(dem.ok()) << dem.error().message;
  // The tiepoint names the centre of cell (0, 0); the corner is 5 m west and north.
  EXPECT_DOUBLE_EQ(dem->georef.transform.origin_x, 499995.0);
  EXPECT_DOUBLE_EQ(dem->georef.transform.origin_y, 5000005.0);
  EXPECT_DOUBLE_EQ(dem->georef.transform.x_at(0), 500000.0);
  EXPECT_EQ(dem->elevation.at(3, 2), 203.0f);
  EXPECT_EQ(dem->format, "GeoTIFF Float32 (uncompressed, striped)");
}

TEST(GeoTiffReader, TiepointAwayFromCellZero) {
  TempDir dir;
  RawTiff t = testing::utm_raw_tiff(4, 3);
  t.tiepoints = {2, 1, 0, 500020.0, 4999990.0, 0};  // cell corner (2, 1)
  ASSERT_TRUE(testing::write_raw_tiff(dir.file("tie.tif"), t));
  auto dem = read_geotiff(dir.file("tie.tif"), {});
  ASSERT_TRUE(dem.ok()) << dem.error().message;
  EXPECT_DOUBLE_EQ(dem->georef.transform.origin_x, 500000.0);
  EXPECT_DOUBLE_EQ(dem->georef.transform.origin_y, 5000000.0);
}

TEST(GeoTiffReader, ReadsNorthUpModelTransformation) {
  TempDir dir;
  RawTiff t = testing::utm_raw_tiff(4, 3);
  t.pixel_scale.clear();
  t.tiepoints.clear();
  t.matrix = {30, 0, 0, 400000, 0, -20, 0, 6000000, 0, 0, 0, 0, 0, 0, 0, 1};
  ASSERT_TRUE(testing::write_raw_tiff(dir.file("matrix.tif"), t));
  auto dem = read_geotiff(dir.file("matrix.tif"), {});
  ASSERT_TRUE(dem.ok()) << dem.error().message;
  EXPECT_EQ(dem->georef.transform, (GeoTransform{400000, 30, 6000000, -20}));
}

TEST(GeoTiffReader, ReadsGdalNodataOnInt16) {
  TempDir dir;
  RawTiff t = testing::utm_raw_tiff(3, 2);
  t.int16 = true;
  t.values[4] = -9999;
  t.nodata = "-9999";
  ASSERT_TRUE(testing::write_raw_tiff(dir.file("nd.tif"), t));
  auto dem = read_geotiff(dir.file("nd.tif"), {});
  ASSERT_TRUE(dem.ok()) << dem.error().message;
  EXPECT_EQ(*dem->nodata, -9999.0);
  EXPECT_TRUE(std::isnan(dem->elevation.at(1, 1)));
  EXPECT_EQ(dem->elevation.at(2, 1), 102.0f);
  EXPECT_EQ(elevation_stats(dem->elevation).nodata_cells, 1u);
}

// A row of 21 samples is two vector steps of eight Int16 (or five of four
// Float32) and a scalar tail: voids in each part, the extremes of Int16 (the
// sign extension), and the nodata code's neighbours, which stay values.
TEST(GeoTiffReader, ConvertsEverySampleOfARowAndOnlyTheNodataCodeToNaN) {
  for (const bool int16 : {true, false}) {
    SCOPED_TRACE(int16 ? "Int16" : "Float32");
    TempDir dir;
    RawTiff t = testing::utm_raw_tiff(21, 3);
    t.int16 = int16;
    const double code = int16 ? -32767 : -9999.5;
    t.nodata = int16 ? "-32767" : "-9999.5";
    t.values[0] = code;                            // first lane of the first step
    t.values[9] = code;                            // second step
    t.values[20] = code;                           // the tail
    t.values[21 + 3] = int16 ? -32768 : -9999.25;  // the code's neighbours
    t.values[21 + 4] = int16 ? -32766 : -9999.75;
    t.values[21 + 15] = int16 ? 32767 : 3.0e38;
    t.values[21 + 16] = int16 ? -1 : -0.0;
    t.values[42 + 7] = int16 ? -12345 : -12345.125;
    ASSERT_TRUE(testing::write_raw_tiff(dir.file("row.tif"), t));
    auto dem = read_geotiff(dir.file("row.tif"), {});
    ASSERT_TRUE(dem.ok()) << dem.error().message;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 21; ++c) {
        const double v = t.values[static_cast<std::size_t>(21 * r + c)];
        if (v == code)
          EXPECT_TRUE(std::isnan(dem->elevation.at(c, r))) << c << "," << r;
        else
          EXPECT_EQ(dem->elevation.at(c, r), static_cast<float>(v)) << c << "," << r;
      }
    EXPECT_EQ(elevation_stats(dem->elevation).nodata_cells, 3u);
  }
}

TEST(GeoTiffReader, AllowMissingCrsKeepsTransformOfUnsupportedCrs) {
  TempDir dir;
  RawTiff t = testing::utm_raw_tiff(4, 3);
  t.geokeys = {{1024, 1}, {1025, 1}, {3072, 4978}};  // WGS 84 geocentric (X, Y, Z)
  ASSERT_TRUE(testing::write_raw_tiff(dir.file("geocentric.tif"), t));
  ReadOptions options;
  options.allow_missing_crs = true;
  auto dem = read_geotiff(dir.file("geocentric.tif"), options);
  ASSERT_TRUE(dem.ok()) << dem.error().message;
  EXPECT_EQ(dem->georef.epsg, 0);
  EXPECT_TRUE(dem->georef.crs.empty());
  EXPECT_DOUBLE_EQ(dem->georef.transform.origin_x, 500000.0);
}

// --- Pixel types and layouts (OIIO-written, not georeferenced) ------------

struct TypeCase {
  OIIO::TypeDesc type;
  const char* name;
  const char* compression;
  bool tiled;
  bool bigtiff;
};

void PrintTo(const TypeCase& tc, std::ostream* os) {
  *os << tc.name << ", " << tc.compression << (tc.tiled ? ", tiled" : ", striped") << (tc.bigtiff ? ", BigTIFF" : "");
}

class GeoTiffPixelTypes : public ::testing::TestWithParam<TypeCase> {};

TEST_P(GeoTiffPixelTypes, ReadsValuesUnnormalised) {
  const TypeCase& tc = GetParam();
  TempDir dir;
  const std::string path = dir.file("t.tif");
  ASSERT_TRUE(testing::write_oiio_image(path, 37, 21, 1, tc.type, tc.compression, tc.tiled, tc.bigtiff));
  ReadOptions options;
  options.allow_missing_crs = true;
  auto dem = read_geotiff(path, options);
  ASSERT_TRUE(dem.ok()) << dem.error().message;
  EXPECT_EQ(dem->width(), 37);
  EXPECT_EQ(dem->height(), 21);
  EXPECT_EQ(dem->georef.epsg, 0);
  EXPECT_NE(dem->format.find(tc.name), std::string::npos) << dem->format;
  EXPECT_EQ(dem->format.rfind(tc.bigtiff ? "BigTIFF" : "GeoTIFF", 0), 0u) << dem->format;
  EXPECT_NE(dem->format.find(tc.tiled ? "tiled 16x16" : "striped"), std::string::npos) << dem->format;
  const bool small = tc.type == OIIO::TypeDesc::UINT8;
  for (int r : {0, 7, 20})
    for (int c : {0, 13, 36}) {
      const int v = 1000 + 10 * r + c;
      EXPECT_EQ(dem->elevation.at(c, r), static_cast<float>(small ? v % 200 : v)) << c << "," << r;
    }
}

INSTANTIATE_TEST_SUITE_P(Types, GeoTiffPixelTypes,
                         ::testing::Values(TypeCase{OIIO::TypeDesc::INT16, "Int16", "zip", false, false},
                                           TypeCase{OIIO::TypeDesc::UINT16, "UInt16", "lzw", true, false},
                                           TypeCase{OIIO::TypeDesc::INT32, "Int32", "none", false, false},
                                           TypeCase{OIIO::TypeDesc::FLOAT, "Float32", "zip", true, true},
                                           TypeCase{OIIO::TypeDesc::DOUBLE, "Float64", "none", true, false},
                                           TypeCase{OIIO::TypeDesc::UINT8, "UInt8", "zip", false, false}),
                         [](const ::testing::TestParamInfo<TypeCase>& test) {
                           const TypeCase& tc = test.param;
                           return std::string(tc.name) + "_" + tc.compression + (tc.tiled ? "_tiled" : "_striped") +
                                  (tc.bigtiff ? "_BigTIFF" : "");
                         });

TEST(GeoTiffReader, ChoosesBandOfMultiBandFile) {
  TempDir dir;
  const std::string path = dir.file("two.tif");
  ASSERT_TRUE(testing::write_oiio_image(path, 5, 4, 2, OIIO::TypeDesc::INT16));
  ReadOptions options;
  options.allow_missing_crs = true;
  options.band = 2;
  auto dem = read_geotiff(path, options);
  ASSERT_TRUE(dem.ok()) << dem.error().message;
  EXPECT_EQ(dem->elevation.at(4, 3), 2034.0f);
  EXPECT_NE(dem->format.find("band 2 of 2"), std::string::npos);
  options.band = 1;
  auto first = read_geotiff(path, options);
  ASSERT_TRUE(first.ok());
  EXPECT_EQ(first->elevation.at(4, 3), 1034.0f);
}

TEST(GeoTiffReader, ChoosesBandOfTiledFloat64File) {
  // Tiled Float64 goes through libtiff (OIIO 2.4.7 decodes it as zeros).
  TempDir dir;
  const std::string path = dir.file("three.tif");
  ASSERT_TRUE(testing::write_oiio_image(path, 40, 19, 3, OIIO::TypeDesc::DOUBLE, "zip", true));
  ReadOptions options;
  options.allow_missing_crs = true;
  options.band = 3;
  auto dem = read_geotiff(path, options);
  ASSERT_TRUE(dem.ok()) << dem.error().message;
  EXPECT_EQ(dem->elevation.at(0, 0), 3000.0f);
  EXPECT_EQ(dem->elevation.at(39, 18), 3000.0f + 180.0f + 39.0f);
  EXPECT_EQ(dem->elevation.at(17, 16), 3000.0f + 160.0f + 17.0f);
}

// gdal_translate re-encodes a bundled DEM in other layouts; every variant
// must read back the same values and georeferencing.
TEST(GeoTiffReader, GdalWrittenVariantsMatchOriginal) {
  if (testing::run_command("gdal_translate --version").exit_code != 0) GTEST_SKIP() << "gdal_translate not installed";
  const std::string src = bundled_dem("olinda_coast_utm25s_111x111.tif");
  auto original = read_geotiff(src, {});
  ASSERT_TRUE(original.ok());
  TempDir dir;
  const char* variants[] = {
      "-ot Float64 -co TILED=YES -co COMPRESS=DEFLATE -co BLOCKXSIZE=32 -co BLOCKYSIZE=16",
      "-ot Float64 -co COMPRESS=LZW",
      "-ot Float32 -co TILED=YES -co COMPRESS=DEFLATE -co PREDICTOR=3 -co BIGTIFF=YES",
      "-ot Int16 -co COMPRESS=PACKBITS -a_nodata -32768",
      "-ot Int32 -co TILED=YES -co COMPRESS=ZSTD",
  };
  int n = 0;
  for (const char* opts : variants) {
    const std::string out = dir.file("v" + std::to_string(n++) + ".tif");
    const auto run = testing::run_command(std::string("gdal_translate -q ") + opts + " '" + src + "' '" + out + "'");
    ASSERT_EQ(run.exit_code, 0) << run.output;
    auto dem = read_geotiff(out, {});
    ASSERT_TRUE(dem.ok()) << opts << ": " << dem.error().message;
    EXPECT_EQ(dem->georef.epsg, 31985) << opts;
    EXPECT_EQ(dem->georef.transform, original->georef.transform) << opts;
    for (int r = 0; r < 111; r += 5)
      for (int c = 0; c < 111; c += 7)
        ASSERT_EQ(dem->elevation.at(c, r), original->elevation.at(c, r)) << opts << " at " << c << "," << r;
  }
}

// --- Rejects ------------------------------------------------------------

TEST(GeoTiffReader, RejectsMissingFile) {
  TempDir dir;
  auto dem = read_geotiff(dir.file("nope.tif"), {});
  ASSERT_FALSE(dem.ok());
  EXPECT_EQ(dem.error().code, ErrorCode::kNotFound);
  EXPECT_NE(dem.error().message.find("nope.tif"), std::string::npos);
}

TEST(GeoTiffReader, RejectsTextFile) {
  TempDir dir;
  std::ofstream(dir.file("text.tif")) << "this is not a TIFF at all\n";
  auto dem = read_geotiff(dir.file("text.tif"), {});
  ASSERT_FALSE(dem.ok());
  EXPECT_EQ(dem.error().code, ErrorCode::kDataError);
  EXPECT_NE(dem.error().message.find("not a raster"), std::string::npos) << dem.error().message;
  EXPECT_NE(dem.error().message.find("text.tif"), std::string::npos);
}

// A copy cut short (a download that stopped) is said to be truncated, with
// the file's size and where the missing bytes were, whether the cut falls in
// the header's directory or in the tiles.
TEST(GeoTiffReader, SaysATruncatedFileIsTruncated) {
  TempDir dir;
  std::ifstream in(bundled_dem("rainier_summit_srtm3_400x400.tif"), std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  for (std::size_t size : {std::size_t{12}, std::size_t{100}, std::size_t{5000}, bytes.size() / 2, bytes.size() - 1}) {
    const std::string path = dir.file("cut_" + std::to_string(size) + ".tif");
    std::ofstream(path, std::ios::binary) << bytes.substr(0, size);
    auto dem = read_geotiff(path, {});
    ASSERT_FALSE(dem.ok()) << size;
    EXPECT_EQ(dem.error().code, ErrorCode::kDataError);
    EXPECT_NE(dem.error().message.find("the file is truncated: it has " + std::to_string(size) + " bytes"),
              std::string::npos)
        << dem.error().message;
  }
}

TEST(GeoTiffReader, RejectsDirectory) {
  TempDir dir;
  auto dem = read_geotiff(dir.path().string(), {});
  ASSERT_FALSE(dem.ok());
  EXPECT_EQ(dem.error().code, ErrorCode::kDataError);
}

TEST(GeoTiffReader, RejectsTruncatedFile) {
  TempDir dir;
  const std::string src = bundled_dem("zion_canyon_srtm3_465x457.tif");
  const std::string path = dir.file("cut.tif");
  std::filesystem::copy_file(src, path);
  std::filesystem::resize_file(path, std::filesystem::file_size(src) / 2);
  auto dem = read_geotiff(path, {});
  ASSERT_FALSE(dem.ok());
  EXPECT_EQ(dem.error().code, ErrorCode::kDataError) << dem.error().message;
}

TEST(GeoTiffReader, RejectsMultiBandWithoutBandChoice) {
  TempDir dir;
  const std::string path = dir.file("two.tif");
  ASSERT_TRUE(testing::write_oiio_image(path, 5, 4, 2, OIIO::TypeDesc::FLOAT));
  auto dem = read_geotiff(path, {});
  ASSERT_FALSE(dem.ok());
  EXPECT_EQ(dem.error().code, ErrorCode::kInvalidArgument);
  EXPECT_EQ(dem.error().field, "band");
  EXPECT_NE(dem.error().message.find("2 bands"), std::string::npos) << dem.error().message;
}

TEST(GeoTiffReader, RejectsBandBeyondCount) {
  TempDir dir;
  const std::string path = dir.file("two.tif");
  ASSERT_TRUE(testing::write_oiio_image(path, 5, 4, 2, OIIO::TypeDesc::FLOAT));
  ReadOptions options;
  options.band = 3;
  auto dem = read_geotiff(path, options);
  ASSERT_FALSE(dem.ok());
  EXPECT_NE(dem.error().message.find("band 3 requested, file has 2"), std::string::npos) << dem.error().message;
  options.band = -1;
  EXPECT_EQ(read_geotiff(path, options).error().code, ErrorCode::kInvalidArgument);
}

TEST(GeoTiffReader, RejectsUnsupportedPixelType) {
  TempDir dir;
  const std::string path = dir.file("int8.tif");
  ASSERT_TRUE(testing::write_oiio_image(path, 5, 4, 1, OIIO::TypeDesc::INT8));
  ReadOptions options;
  options.allow_missing_crs = true;
  auto dem = read_geotiff(path, options);
  ASSERT_FALSE(dem.ok());
  EXPECT_EQ(dem.error().code, ErrorCode::kUnsupported);
  EXPECT_NE(dem.error().message.find("pixel type"), std::string::npos) << dem.error().message;
}

TEST(GeoTiffReader, RejectsMissingGeoreference) {
  TempDir dir;
  const std::string path = dir.file("plain.tif");
  ASSERT_TRUE(testing::write_oiio_image(path, 5, 4, 1, OIIO::TypeDesc::FLOAT));
  auto dem = read_geotiff(path, {});
  ASSERT_FALSE(dem.ok());
  EXPECT_EQ(dem.error().code, ErrorCode::kDataError);
  EXPECT_NE(dem.error().message.find("no georeferencing"), std::string::npos) << dem.error().message;
  ReadOptions options;
  options.allow_missing_crs = true;
  auto plain = read_geotiff(path, options);
  ASSERT_TRUE(plain.ok()) << plain.error().message;
  EXPECT_EQ(plain->georef.epsg, 0);
  EXPECT_EQ(plain->georef.transform, GeoTransform{});
}

TEST(GeoTiffReader, RejectsTransformWithoutCrs) {
  TempDir dir;
  RawTiff t = testing::utm_raw_tiff(4, 3);
  t.geokeys.clear();
  ASSERT_TRUE(testing::write_raw_tiff(dir.file("nocrs.tif"), t));
  auto dem = read_geotiff(dir.file("nocrs.tif"), {});
  ASSERT_FALSE(dem.ok());
  EXPECT_NE(dem.error().message.find("no CRS"), std::string::npos) << dem.error().message;
}

TEST(GeoTiffReader, RejectsUnusableCrs) {
  // EPSG:4978 exists, but is geocentric (X, Y, Z): no map grid lies in it.
  TempDir dir;
  RawTiff t = testing::utm_raw_tiff(4, 3);
  t.geokeys = {{1024, 1}, {1025, 1}, {3072, 4978}};
  ASSERT_TRUE(testing::write_raw_tiff(dir.file("geocentric.tif"), t));
  auto dem = read_geotiff(dir.file("geocentric.tif"), {});
  ASSERT_FALSE(dem.ok());
  EXPECT_EQ(dem.error().code, ErrorCode::kUnsupported);
  EXPECT_NE(dem.error().message.find("EPSG:4978"), std::string::npos) << dem.error().message;
  EXPECT_NE(dem.error().message.find("geocentric"), std::string::npos) << dem.error().message;

  // Read anyway as a plain grid, the georeference says what was refused.
  ReadOptions options;
  options.allow_missing_crs = true;
  auto plain = read_geotiff(dir.file("geocentric.tif"), options);
  ASSERT_TRUE(plain.ok()) << plain.error().message;
  EXPECT_FALSE(plain->georef.has_crs());
  EXPECT_NE(plain->georef.crs_problem.find("geocentric"), std::string::npos) << plain->georef.crs_problem;
}

TEST(GeoTiffReader, ReadsAnyEpsgCrs) {
  // ETRS89 / LAEA Europe, and NAD83 / California zone 3 in US survey feet.
  TempDir dir;
  RawTiff t = testing::utm_raw_tiff(4, 3);
  for (int code : {3035, 2227}) {
    t.geokeys = {{1024, 1}, {1025, 1}, {3072, code}};
    const std::string path = dir.file(std::to_string(code) + ".tif");
    ASSERT_TRUE(testing::write_raw_tiff(path, t));
    auto dem = read_geotiff(path, {});
    ASSERT_TRUE(dem.ok()) << dem.error().message;
    EXPECT_EQ(dem->georef.epsg, code);
    EXPECT_TRUE(dem->georef.crs.empty());
    EXPECT_TRUE(dem->georef.crs_problem.empty());
  }
}

TEST(GeoTiffReader, VerticalCrsMakesACompoundCrs) {
  // British National Grid + ODN height (VerticalCSTypeGeoKey 4096).
  TempDir dir;
  RawTiff t = testing::utm_raw_tiff(4, 3);
  t.geokeys = {{1024, 1}, {1025, 1}, {3072, 27700}, {4096, 5701}};
  ASSERT_TRUE(testing::write_raw_tiff(dir.file("bng_odn.tif"), t));
  auto bng = read_geotiff(dir.file("bng_odn.tif"), {});
  ASSERT_TRUE(bng.ok()) << bng.error().message;
  EXPECT_EQ(bng->georef.epsg, 27700);
  EXPECT_EQ(bng->georef.crs, "EPSG:27700+5701");

  // Heights in feet, by a vertical CRS's unit or by VerticalUnitsGeoKey
  // (4099) alone: refused, since elevations are metres.
  using Keys = decltype(t.geokeys);
  for (const auto& [keys, says] : {std::pair{Keys{{1024, 1}, {1025, 1}, {3072, 2227}, {4096, 6360}}, "US survey foot"},
                                   std::pair{Keys{{1024, 1}, {1025, 1}, {3072, 27700}, {4099, 9002}}, "foot"}}) {
    t.geokeys = keys;
    ASSERT_TRUE(testing::write_raw_tiff(dir.file("feet.tif"), t));
    auto feet = read_geotiff(dir.file("feet.tif"), {});
    ASSERT_FALSE(feet.ok());
    EXPECT_EQ(feet.error().code, ErrorCode::kUnsupported);
    EXPECT_NE(feet.error().message.find(says), std::string::npos) << feet.error().message;
    EXPECT_NE(feet.error().message.find("metres"), std::string::npos) << feet.error().message;
  }
}

TEST(GeoTiffReader, RejectsUserDefinedCrsWithoutItsKeys) {
  // "User-defined" (32767) and nothing else: no projection to build.
  TempDir dir;
  RawTiff t = testing::utm_raw_tiff(4, 3);
  t.geokeys = {{1024, 1}, {1025, 1}, {3072, 32767}};
  ASSERT_TRUE(testing::write_raw_tiff(dir.file("user.tif"), t));
  auto dem = read_geotiff(dir.file("user.tif"), {});
  ASSERT_FALSE(dem.ok());
  EXPECT_EQ(dem.error().code, ErrorCode::kUnsupported);
  EXPECT_NE(dem.error().message.find("user-defined"), std::string::npos) << dem.error().message;
}

TEST(GeoTiffReader, RejectsRotatedTransform) {
  TempDir dir;
  RawTiff t = testing::utm_raw_tiff(4, 3);
  t.pixel_scale.clear();
  t.tiepoints.clear();
  // 30 degrees of rotation: x = 8.66 i + 5 j + x0, y = 5 i - 8.66 j + y0.
  t.matrix = {8.660254, 5.0, 0, 500000, 5.0, -8.660254, 0, 5000000, 0, 0, 0, 0, 0, 0, 0, 1};
  ASSERT_TRUE(testing::write_raw_tiff(dir.file("rot.tif"), t));
  auto dem = read_geotiff(dir.file("rot.tif"), {});
  ASSERT_FALSE(dem.ok());
  EXPECT_EQ(dem.error().code, ErrorCode::kUnsupported);
  EXPECT_NE(dem.error().message.find("rotated"), std::string::npos) << dem.error().message;
}

TEST(GeoTiffReader, RejectsGroundControlPoints) {
  TempDir dir;
  RawTiff t = testing::utm_raw_tiff(4, 3);
  t.pixel_scale.clear();
  t.tiepoints = {0, 0, 0, 500000, 5000000, 0, 3, 2, 0, 500040, 4999970, 0};
  ASSERT_TRUE(testing::write_raw_tiff(dir.file("gcp.tif"), t));
  auto dem = read_geotiff(dir.file("gcp.tif"), {});
  ASSERT_FALSE(dem.ok());
  EXPECT_NE(dem.error().message.find("ground control points"), std::string::npos) << dem.error().message;
}

TEST(GeoTiffReader, RejectsMirroredAndDegenerateTransforms) {
  TempDir dir;
  RawTiff mirrored = testing::utm_raw_tiff(4, 3);
  mirrored.pixel_scale.clear();
  mirrored.tiepoints.clear();
  mirrored.matrix = {-10, 0, 0, 500000, 0, -10, 0, 5000000, 0, 0, 0, 0, 0, 0, 0, 1};
  ASSERT_TRUE(testing::write_raw_tiff(dir.file("m.tif"), mirrored));
  auto m = read_geotiff(dir.file("m.tif"), {});
  ASSERT_FALSE(m.ok());
  EXPECT_EQ(m.error().code, ErrorCode::kUnsupported);

  RawTiff flat = testing::utm_raw_tiff(4, 3);
  flat.pixel_scale = {10.0, 0.0, 0.0};
  ASSERT_TRUE(testing::write_raw_tiff(dir.file("z.tif"), flat));
  auto z = read_geotiff(dir.file("z.tif"), {});
  ASSERT_FALSE(z.ok());
  EXPECT_EQ(z.error().code, ErrorCode::kDataError);
}

TEST(GeoTiffReader, RejectsNonNumericNodata) {
  TempDir dir;
  RawTiff t = testing::utm_raw_tiff(4, 3);
  t.nodata = "none";
  ASSERT_TRUE(testing::write_raw_tiff(dir.file("bad_nd.tif"), t));
  auto dem = read_geotiff(dir.file("bad_nd.tif"), {});
  ASSERT_FALSE(dem.ok());
  EXPECT_EQ(dem.error().code, ErrorCode::kDataError);
  EXPECT_NE(dem.error().message.find("GDAL_NODATA"), std::string::npos);
}

}  // namespace
}  // namespace horizon::terrain
