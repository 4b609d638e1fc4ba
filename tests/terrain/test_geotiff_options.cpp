// GeoTIFF creation options (terrain/geotiff_options.hpp): parsing GDAL's
// spellings, refusing what does not apply, and files written with each
// option read back by our reader, by libtiff's tags and by gdalinfo.
#include <gtest/gtest.h>
#include <tiffio.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "horizon/terrain/dem_reader.hpp"
#include "horizon/terrain/geotiff_writer.hpp"
#include "test_support.hpp"

namespace horizon::terrain {
namespace {

using testing::TempDir;

Result<GeoTiffOptions> parse(TiffFormat format, std::vector<std::string> items) {
  return parse_creation_options(format, items);
}

std::string error_of(TiffFormat format, std::vector<std::string> items) {
  auto o = parse(format, std::move(items));
  if (o.ok()) return "(accepted)";
  EXPECT_EQ(o.error().field, "creation_options");
  return o.error().message;
}

Grid<float> ramp() {
  Grid<float> g(300, 270);
  for (int r = 0; r < g.height(); ++r)
    for (int c = 0; c < g.width(); ++c) g.at(c, r) = 0.25f * c - 1.5f * r + 1000.0f;
  g.at(10, 20) = std::numeric_limits<float>::quiet_NaN();
  return g;
}

Georeference utm() {
  return {GeoTransform{712000.5, 10.0, 9561000.25, -10.0}, 32717};
}

struct Tags {
  std::uint16_t compression = 0, predictor = 1;
  bool tiled = false;
  std::uint32_t tile_width = 0, tile_height = 0, rows_per_strip = 0;
  bool bigtiff = false;
};

Tags tags_of(const std::string& path) {
  Tags t;
  TIFF* tif = TIFFOpen(path.c_str(), "r");
  if (!tif) return t;
  TIFFGetField(tif, TIFFTAG_COMPRESSION, &t.compression);
  TIFFGetField(tif, TIFFTAG_PREDICTOR, &t.predictor);
  t.tiled = TIFFIsTiled(tif);
  TIFFGetField(tif, TIFFTAG_TILEWIDTH, &t.tile_width);
  TIFFGetField(tif, TIFFTAG_TILELENGTH, &t.tile_height);
  TIFFGetField(tif, TIFFTAG_ROWSPERSTRIP, &t.rows_per_strip);
  t.bigtiff = TIFFIsBigTIFF(tif);
  TIFFClose(tif);
  return t;
}

void expect_same_values(const std::string& path, const Grid<float>& want) {
  auto back = read_dem(path);
  ASSERT_TRUE(back.ok()) << back.error().message;
  ASSERT_EQ(back->width(), want.width());
  for (int r = 0; r < want.height(); ++r)
    for (int c = 0; c < want.width(); ++c) {
      const float a = want.at(c, r), b = back->elevation.at(c, r);
      ASSERT_TRUE(a == b || (std::isnan(a) && std::isnan(b))) << path << " at " << c << "," << r;
    }
}

TEST(CreationOptions, DefaultsAreTheWritersOwn) {
  auto o = parse(TiffFormat::kGTiff, {});
  ASSERT_TRUE(o.ok());
  EXPECT_TRUE(o->is_default());
  auto cog = parse(TiffFormat::kCog, {});
  ASSERT_TRUE(cog.ok());
  EXPECT_EQ(cog->block_width, 512);
  EXPECT_TRUE(cog->overviews);
  EXPECT_FALSE(cog->is_default());
}

TEST(CreationOptions, GdalSpellingsInAnyCase) {
  auto o = parse(TiffFormat::kGTiff,
                 {"compress=zstd", "ZSTD_LEVEL=15", "Predictor=2", "TILED=NO", "BLOCKYSIZE=32", "BIGTIFF=YES"});
  ASSERT_TRUE(o.ok()) << o.error().message;
  EXPECT_EQ(o->compression, TiffCompression::kZstd);
  EXPECT_EQ(o->level, 15);
  EXPECT_EQ(o->predictor, TiffPredictor::kHorizontal);
  EXPECT_FALSE(o->tiled);
  EXPECT_EQ(o->block_height, 32);
  EXPECT_EQ(o->bigtiff, BigTiff::kYes);
  auto cog = parse(TiffFormat::kCog, {"COMPRESS=LZW", "BLOCKSIZE=256", "OVERVIEW_RESAMPLING=NEAREST"});
  ASSERT_TRUE(cog.ok()) << cog.error().message;
  EXPECT_EQ(cog->block_width, 256);
  EXPECT_EQ(cog->block_height, 256);
  EXPECT_EQ(cog->resampling, OverviewResampling::kNearest);
  EXPECT_EQ(parse_tiff_format("cog"), TiffFormat::kCog);
  EXPECT_EQ(parse_tiff_format("GTiff"), TiffFormat::kGTiff);
  EXPECT_FALSE(parse_tiff_format("PNG").has_value());
}

TEST(CreationOptions, RefusalsQuoteTheItem) {
  EXPECT_NE(error_of(TiffFormat::kGTiff, {"COMPRESS=JPEG"}).find("COMPRESS=JPEG: not a lossless codec"),
            std::string::npos);
  EXPECT_NE(error_of(TiffFormat::kGTiff, {"COMPRES=LZW"}).find("unknown creation option"), std::string::npos);
  EXPECT_NE(error_of(TiffFormat::kGTiff, {"BLOCKSIZE=512"}).find("an option of the COG format"), std::string::npos);
  EXPECT_NE(error_of(TiffFormat::kCog, {"TILED=NO"}).find("an option of the GTiff format"), std::string::npos);
  EXPECT_NE(error_of(TiffFormat::kGTiff, {"ZLEVEL=13"}).find("from 1 to 12"), std::string::npos);
  EXPECT_NE(
      error_of(TiffFormat::kGTiff, {"COMPRESS=LZW", "ZLEVEL=5"}).find("ZLEVEL=5: applies to COMPRESS=DEFLATE, not LZW"),
      std::string::npos);
  EXPECT_NE(error_of(TiffFormat::kCog, {"COMPRESS=LZW", "LEVEL=5"}).find("LZW has no level"), std::string::npos);
  EXPECT_NE(error_of(TiffFormat::kCog, {"COMPRESS=ZSTD", "LEVEL=23"}).find("from 1 to 22"), std::string::npos);
  EXPECT_NE(error_of(TiffFormat::kGTiff, {"BLOCKXSIZE=100"}).find("multiples of 16"), std::string::npos);
  EXPECT_NE(error_of(TiffFormat::kGTiff, {"TILED=maybe"}).find("expected YES or NO"), std::string::npos);
  EXPECT_NE(error_of(TiffFormat::kGTiff, {"COMPRESS"}).find("expected NAME=VALUE"), std::string::npos);
  EXPECT_NE(error_of(TiffFormat::kGTiff, {"COMPRESS=LZW", "compress=ZSTD"}).find("more than once"), std::string::npos);
  EXPECT_NE(error_of(TiffFormat::kCog, {"OVERVIEW_RESAMPLING=CUBIC"}).find("NEAREST, MODE or AVERAGE"),
            std::string::npos);
}

TEST(CreationOptions, EveryCodecRoundTrips) {
  TempDir dir;
  const Grid<float> grid = ramp();
  struct Case {
    const char* compress;
    std::uint16_t tag;
    const char* gdal;
  };
  for (const Case& k : {Case{"DEFLATE", COMPRESSION_ADOBE_DEFLATE, "DEFLATE"}, Case{"LZW", COMPRESSION_LZW, "LZW"},
                        Case{"ZSTD", COMPRESSION_ZSTD, "ZSTD"}, Case{"LZMA", COMPRESSION_LZMA, "LZMA"},
                        Case{"PACKBITS", COMPRESSION_PACKBITS, "PACKBITS"}, Case{"NONE", COMPRESSION_NONE, ""}}) {
    auto o = parse(TiffFormat::kGTiff, {std::string("COMPRESS=") + k.compress});
    ASSERT_TRUE(o.ok()) << o.error().message;
    const std::string path = dir.file(std::string(k.compress) + ".tif");
    ASSERT_TRUE(write_geotiff(path, grid, utm(), -9999.0, *o).ok()) << k.compress;
    expect_same_values(path, grid);
    const Tags t = tags_of(path);
    EXPECT_EQ(t.compression, k.tag) << k.compress;
    // The default predictor: floating point where a codec compresses, none for NONE and PACKBITS.
    const bool codes_only = std::string(k.compress) == "NONE" || std::string(k.compress) == "PACKBITS";
    EXPECT_EQ(t.predictor, codes_only ? PREDICTOR_NONE : PREDICTOR_FLOATINGPOINT) << k.compress;
    if (testing::run_command("gdalinfo --version").exit_code != 0 || !*k.gdal) continue;
    const auto run = testing::run_command("gdalinfo -json '" + path + "'");
    ASSERT_EQ(run.exit_code, 0) << run.output;
    const auto info = nlohmann::json::parse(run.output.substr(run.output.find('{')));
    EXPECT_EQ(info.at("metadata").at("IMAGE_STRUCTURE").at("COMPRESSION").get<std::string>(), k.gdal);
  }
}

TEST(CreationOptions, StripsTilesPredictorsAndBigTiff) {
  TempDir dir;
  const Grid<float> grid = ramp();
  const auto write = [&](const std::string& name, std::vector<std::string> items) {
    auto o = parse(TiffFormat::kGTiff, std::move(items));
    EXPECT_TRUE(o.ok()) << o.error().message;
    const std::string path = dir.file(name);
    EXPECT_TRUE(write_geotiff(path, grid, utm(), std::nullopt, *o).ok()) << name;
    expect_same_values(path, grid);
    return tags_of(path);
  };
  const Tags strips = write("strips.tif", {"TILED=NO", "BLOCKYSIZE=7"});
  EXPECT_FALSE(strips.tiled);
  EXPECT_EQ(strips.rows_per_strip, 7u);
  const Tags tiles = write("tiles.tif", {"BLOCKXSIZE=64", "BLOCKYSIZE=32", "PREDICTOR=NO", "ZLEVEL=9"});
  EXPECT_TRUE(tiles.tiled);
  EXPECT_EQ(tiles.tile_width, 64u);
  EXPECT_EQ(tiles.tile_height, 32u);
  EXPECT_EQ(tiles.predictor, PREDICTOR_NONE);
  const Tags horizontal = write("horizontal.tif", {"PREDICTOR=2", "COMPRESS=LZW"});
  EXPECT_EQ(horizontal.predictor, PREDICTOR_HORIZONTAL);
  EXPECT_TRUE(write("big.tif", {"BIGTIFF=YES"}).bigtiff);
  EXPECT_FALSE(write("small.tif", {"BIGTIFF=IF_NEEDED"}).bigtiff);
}

TEST(CreationOptions, AnIntegerRasterRefusesTheFloatingPointPredictor) {
  TempDir dir;
  auto o = parse(TiffFormat::kGTiff, {"PREDICTOR=3"});
  ASSERT_TRUE(o.ok());
  const Status s = write_geotiff(dir.file("m.tif"), Grid<std::uint8_t>(20, 20, 1), utm(), 255.0, *o);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().field, "creation_options");
  EXPECT_NE(s.error().message.find("UInt8"), std::string::npos) << s.error().message;
  auto none = parse(TiffFormat::kGTiff, {"COMPRESS=NONE", "PREDICTOR=2"});
  ASSERT_TRUE(none.ok());
  EXPECT_FALSE(write_geotiff(dir.file("n.tif"), Grid<std::uint8_t>(20, 20, 1), utm(), 255.0, *none).ok());
  EXPECT_TRUE(std::filesystem::is_empty(dir.path())) << "nothing written on a refusal";
}

// The default predictor by sample type: none for UInt8 codes (a difference
// of two codes means nothing, and their runs compress smaller as they are),
// horizontal for UInt32 counts; PREDICTOR=2 still applies to codes.
TEST(CreationOptions, CodesTakeNoPredictorByDefault) {
  TempDir dir;
  Grid<std::uint8_t> codes(300, 200, 0);
  for (int r = 0; r < codes.height(); ++r)
    for (int c = 0; c < codes.width(); ++c) codes.at(c, r) = (c / 37 + r / 23) % 3 == 0 ? 255 : (c + r) / 50 % 2;
  const GeoTiffOptions defaults;
  ASSERT_TRUE(write_geotiff(dir.file("codes.tif"), codes, utm(), 255.0, defaults).ok());
  EXPECT_EQ(tags_of(dir.file("codes.tif")).predictor, PREDICTOR_NONE);
  auto horizontal = parse(TiffFormat::kGTiff, {"PREDICTOR=2"});
  ASSERT_TRUE(horizontal.ok());
  ASSERT_TRUE(write_geotiff(dir.file("predicted.tif"), codes, utm(), 255.0, *horizontal).ok());
  EXPECT_EQ(tags_of(dir.file("predicted.tif")).predictor, PREDICTOR_HORIZONTAL);
  EXPECT_LT(std::filesystem::file_size(dir.file("codes.tif")), std::filesystem::file_size(dir.file("predicted.tif")));
  for (const char* name : {"codes.tif", "predicted.tif"}) {  // the same codes either way
    TIFF* tif = TIFFOpen(dir.file(name).c_str(), "r");
    ASSERT_NE(tif, nullptr);
    std::vector<std::uint8_t> tile(TIFFTileSize(tif));
    for (std::uint32_t y = 0; y < 200; y += 256)
      for (std::uint32_t x = 0; x < 300; x += 256) {
        ASSERT_GT(TIFFReadTile(tif, tile.data(), x, y, 0, 0), 0);
        for (std::uint32_t r = 0; r < 256 && y + r < 200; ++r)
          for (std::uint32_t c = 0; c < 256 && x + c < 300; ++c)
            ASSERT_EQ(tile[r * 256 + c], codes.at(static_cast<int>(x + c), static_cast<int>(y + r))) << name;
      }
    TIFFClose(tif);
  }
  Grid<std::uint32_t> counts(40, 30, 7);
  ASSERT_TRUE(write_geotiff(dir.file("counts.tif"), counts, utm(), std::nullopt, defaults).ok());
  EXPECT_EQ(tags_of(dir.file("counts.tif")).predictor, PREDICTOR_HORIZONTAL);
}

TEST(CreationOptions, IntegerRastersInStripsRoundTrip) {
  TempDir dir;
  Grid<std::uint32_t> counts(301, 33);
  for (int r = 0; r < counts.height(); ++r)
    for (int c = 0; c < counts.width(); ++c) counts.at(c, r) = static_cast<std::uint32_t>(c * 70001 + r);
  auto o = parse(TiffFormat::kGTiff, {"TILED=NO", "COMPRESS=ZSTD"});
  ASSERT_TRUE(o.ok());
  const std::string path = dir.file("counts.tif");
  ASSERT_TRUE(write_geotiff(path, counts, utm(), std::nullopt, *o).ok());
  TIFF* tif = TIFFOpen(path.c_str(), "r");
  ASSERT_NE(tif, nullptr);
  std::vector<std::uint32_t> line(301);
  for (std::uint32_t r = 0; r < 33; ++r) {
    ASSERT_EQ(TIFFReadScanline(tif, line.data(), r, 0), 1);
    for (int c = 0; c < 301; ++c) ASSERT_EQ(line[c], counts.at(c, static_cast<int>(r)));
  }
  TIFFClose(tif);
}

}  // namespace
}  // namespace horizon::terrain
