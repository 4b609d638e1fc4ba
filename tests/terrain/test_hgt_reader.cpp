// Tests for terrain/hgt_reader.cpp on synthetic SRTM tiles written here:
// byte order, corner samples, georeferencing from the name, voids, and the
// Rejects* cases (size, name, missing file).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <fstream>
#include <string>
#include <vector>

#include "horizon/terrain/dem_reader.hpp"
#include "test_support.hpp"

namespace horizon::terrain {
namespace {

using testing::TempDir;

// Sample (c, r) of the synthetic tile: distinct, negative values included.
std::int16_t sample(int c, int r) {
  return static_cast<std::int16_t>((c * 7 + r * 13) % 9000 - 500);
}

void write_hgt(const std::string& path, int n, std::vector<std::pair<int, int>> voids = {}) {
  std::vector<unsigned char> bytes(static_cast<std::size_t>(n) * n * 2);
  for (int r = 0; r < n; ++r)
    for (int c = 0; c < n; ++c) {
      std::int16_t v = sample(c, r);
      for (const auto& [vc, vr] : voids)
        if (vc == c && vr == r) v = -32768;
      const auto u = static_cast<std::uint16_t>(v);
      const std::size_t i = (static_cast<std::size_t>(r) * n + c) * 2;
      bytes[i] = static_cast<unsigned char>(u >> 8);  // big-endian
      bytes[i + 1] = static_cast<unsigned char>(u & 0xFF);
    }
  std::ofstream(path, std::ios::binary)
      .write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

TEST(HgtReader, Reads3ArcSecondTile) {
  TempDir dir;
  const std::string path = dir.file("N27E086.hgt");
  write_hgt(path, 1201, {{600, 600}});
  auto dem = read_hgt(path);
  ASSERT_TRUE(dem.ok()) << dem.error().message;
  EXPECT_EQ(dem->width(), 1201);
  EXPECT_EQ(dem->height(), 1201);
  // Corners (hand-computed from sample()).
  EXPECT_EQ(dem->elevation.at(0, 0), -500.0f);
  EXPECT_EQ(dem->elevation.at(1200, 0), static_cast<float>(1200 * 7 % 9000 - 500));   // 7900
  EXPECT_EQ(dem->elevation.at(0, 1200), static_cast<float>(1200 * 13 % 9000 - 500));  // 6100
  EXPECT_EQ(dem->elevation.at(1200, 1200), static_cast<float>(24000 % 9000 - 500));   // 5500
  EXPECT_EQ(dem->elevation.at(1200, 0), 7900.0f);
  EXPECT_EQ(dem->elevation.at(1, 2), static_cast<float>(7 + 26 - 500));
  // The void.
  EXPECT_TRUE(std::isnan(dem->elevation.at(600, 600)));
  EXPECT_EQ(elevation_stats(dem->elevation).nodata_cells, 1u);
  ASSERT_TRUE(dem->nodata.has_value());
  EXPECT_EQ(*dem->nodata, -32768.0);
  // Samples on whole degrees: cell (0, 0) is centred on 86 E, 28 N.
  const GeoTransform& t = dem->georef.transform;
  EXPECT_EQ(dem->georef.epsg, 4326);
  EXPECT_DOUBLE_EQ(t.pixel_width, 1.0 / 1200);
  EXPECT_DOUBLE_EQ(t.pixel_height, -1.0 / 1200);
  EXPECT_DOUBLE_EQ(t.origin_x, 86.0 - 0.5 / 1200);
  EXPECT_DOUBLE_EQ(t.origin_y, 28.0 + 0.5 / 1200);
  EXPECT_NEAR(t.x_at(0), 86.0, 1e-12);
  EXPECT_NEAR(t.y_at(0), 28.0, 1e-12);
  EXPECT_NEAR(t.x_at(1200), 87.0, 1e-12);
  EXPECT_NEAR(t.y_at(1200), 27.0, 1e-12);
  EXPECT_EQ(dem->format, "SRTM HGT 3 arc-second (1201x1201)");
}

TEST(HgtReader, SouthWestTileNameIsCaseInsensitive) {
  TempDir dir;
  const std::string path = dir.file("s01w072.HGT");
  write_hgt(path, 1201);
  auto dem = read_hgt(path);
  ASSERT_TRUE(dem.ok()) << dem.error().message;
  // S01W072 covers 1 S .. 0, 72 W .. 71 W: the north-west sample is at (-72, 0).
  EXPECT_NEAR(dem->georef.transform.x_at(0), -72.0, 1e-12);
  EXPECT_NEAR(dem->georef.transform.y_at(0), 0.0, 1e-12);
  EXPECT_NEAR(dem->georef.transform.y_at(1200), -1.0, 1e-12);
}

TEST(HgtReader, Reads1ArcSecondTileViaReadDem) {
  TempDir dir;
  const std::string path = dir.file("N46W122.hgt");
  write_hgt(path, 3601);
  auto dem = read_dem(path);
  ASSERT_TRUE(dem.ok()) << dem.error().message;
  EXPECT_EQ(dem->width(), 3601);
  EXPECT_DOUBLE_EQ(dem->georef.transform.pixel_width, 1.0 / 3600);
  EXPECT_NEAR(dem->georef.transform.x_at(3600), -121.0, 1e-12);
  EXPECT_EQ(dem->elevation.at(3600, 3600), static_cast<float>((3600 * 20) % 9000 - 500));
  EXPECT_EQ(dem->format, "SRTM HGT 1 arc-second (3601x3601)");
}

TEST(HgtReader, RejectsWrongSize) {
  TempDir dir;
  const std::string path = dir.file("N27E086.hgt");
  std::ofstream(path, std::ios::binary) << std::string(1000, '\0');
  auto dem = read_hgt(path);
  ASSERT_FALSE(dem.ok());
  EXPECT_EQ(dem.error().code, ErrorCode::kDataError);
  EXPECT_NE(dem.error().message.find("1000 bytes"), std::string::npos) << dem.error().message;
  EXPECT_NE(dem.error().message.find("N27E086.hgt"), std::string::npos);
}

TEST(HgtReader, RejectsBadNames) {
  TempDir dir;
  for (const char* name :
       {"tile.hgt", "X27E086.hgt", "N27Q086.hgt", "N2E086.hgt", "N95E086.hgt", "N27E186.hgt", "N27E0861.hgt"}) {
    const std::string path = dir.file(name);
    write_hgt(path, 1201);
    auto dem = read_hgt(path);
    ASSERT_FALSE(dem.ok()) << name;
    EXPECT_EQ(dem.error().code, ErrorCode::kDataError) << name;
    EXPECT_NE(dem.error().message.find("N27E086.hgt"), std::string::npos) << dem.error().message;
  }
}

TEST(HgtReader, RejectsMissingFile) {
  TempDir dir;
  auto dem = read_hgt(dir.file("N00E000.hgt"));
  ASSERT_FALSE(dem.ok());
  EXPECT_EQ(dem.error().code, ErrorCode::kNotFound);
}

}  // namespace
}  // namespace horizon::terrain
