// Tests for terrain/dem_reader.cpp: read_dem picks the reader by content
// first (TIFF / BigTIFF / PNG magic), then by the .hgt extension, and names
// the file in every refusal.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "horizon/terrain/dem_reader.hpp"
#include "horizon/terrain/geotiff_writer.hpp"
#include "test_support.hpp"
#include "tiff_fixtures.hpp"

namespace horizon::terrain {
namespace {

using testing::TempDir;

TEST(ReadDem, ReadsEveryBundledDem) {
  struct Expect {
    const char* name;
    int width, height, epsg;
  };
  for (const Expect& e : {Expect{"zion_canyon_srtm3_465x457.tif", 465, 457, 4326},
                          Expect{"rainier_summit_srtm3_400x400.tif", 400, 400, 4326},
                          Expect{"everest_summit_voids_srtm3_300x300.tif", 300, 300, 4326},
                          Expect{"olinda_coast_utm25s_111x111.tif", 111, 111, 31985},
                          Expect{"ecuador_andes_utm17s_10m_383x415.tif", 383, 415, 32717}}) {
    auto dem = read_dem(testing::bundled_dem(e.name));
    ASSERT_TRUE(dem.ok()) << e.name << ": " << dem.error().message;
    EXPECT_EQ(dem->width(), e.width) << e.name;
    EXPECT_EQ(dem->height(), e.height) << e.name;
    EXPECT_EQ(dem->georef.epsg, e.epsg) << e.name;
    EXPECT_GT(elevation_stats(dem->elevation).valid_cells, 0u) << e.name;
  }
}

TEST(ReadDem, DispatchesTiffByContentNotName) {
  TempDir dir;
  const std::string path = dir.file("elevation.dat");
  std::filesystem::copy_file(testing::bundled_dem("olinda_coast_utm25s_111x111.tif"), path);
  auto dem = read_dem(path);
  ASSERT_TRUE(dem.ok()) << dem.error().message;
  EXPECT_EQ(dem->georef.epsg, 31985);
}

TEST(ReadDem, DispatchesBigTiff) {
  TempDir dir;
  const std::string path = dir.file("big.tif");
  ASSERT_TRUE(testing::write_oiio_image(path, 8, 8, 1, OIIO::TypeDesc::FLOAT, "zip", true, true));
  std::ifstream in(path, std::ios::binary);
  char magic[4] = {};
  in.read(magic, 4);
  ASSERT_EQ(magic[2], 43) << "fixture is not BigTIFF";
  ReadOptions options;
  options.allow_missing_crs = true;
  auto dem = read_dem(path, options);
  ASSERT_TRUE(dem.ok()) << dem.error().message;
  EXPECT_EQ(dem->format.rfind("BigTIFF Float32", 0), 0u) << dem->format;
}

TEST(ReadDem, RejectsMissingFile) {
  TempDir dir;
  const std::string path = dir.file("absent.tif");
  auto dem = read_dem(path);
  ASSERT_FALSE(dem.ok());
  EXPECT_EQ(dem.error().code, ErrorCode::kNotFound);
  EXPECT_EQ(dem.error().message, "dem '" + path + "': no such file");
  EXPECT_EQ(dem.error().field, path);
}

TEST(ReadDem, RejectsDirectory) {
  TempDir dir;
  auto dem = read_dem(dir.path().string());
  ASSERT_FALSE(dem.ok());
  EXPECT_EQ(dem.error().code, ErrorCode::kDataError);
  EXPECT_NE(dem.error().message.find("not a raster"), std::string::npos);
}

TEST(ReadDem, RejectsUnknownContent) {
  TempDir dir;
  for (const char* name : {"notes.tif", "empty.tif", "noext"}) {
    const std::string path = dir.file(name);
    std::ofstream out(path);
    if (std::string(name) != "empty.tif") out << "GIF89a is not what we read";
    out.close();
    auto dem = read_dem(path);
    ASSERT_FALSE(dem.ok()) << name;
    EXPECT_EQ(dem.error().code, ErrorCode::kDataError) << name;
    EXPECT_NE(dem.error().message.find("not a raster"), std::string::npos) << dem.error().message;
    EXPECT_NE(dem.error().message.find(name), std::string::npos);
  }
}

TEST(ReadDem, RejectsTiffMagicWithGarbageAfter) {
  TempDir dir;
  const std::string path = dir.file("fake.tif");
  std::ofstream(path, std::ios::binary) << std::string("II*\0", 4) << std::string(64, '\x7f');
  auto dem = read_dem(path);
  ASSERT_FALSE(dem.ok());
  EXPECT_EQ(dem.error().code, ErrorCode::kDataError) << dem.error().message;
}

TEST(ReadDem, RejectsBandForSingleBandFormats) {
  TempDir dir;
  ReadOptions options;
  options.band = 2;
  auto dem = read_dem(testing::bundled_dem("zion_canyon_srtm3_465x457.tif"), options);
  ASSERT_FALSE(dem.ok());
  EXPECT_NE(dem.error().message.find("band 2 requested, file has 1"), std::string::npos) << dem.error().message;
  options.band = -3;
  EXPECT_EQ(read_dem(testing::bundled_dem("zion_canyon_srtm3_465x457.tif"), options).error().code,
            ErrorCode::kInvalidArgument);
}

}  // namespace
}  // namespace horizon::terrain
