// Tests for terrain/terrain_rgb_reader.cpp: decoding of a small synthetic
// terrain-RGB PNG written here, web Mercator georeferencing from z/x/y (the
// path or ReadOptions::tile), and the Rejects* cases.
#include <gtest/gtest.h>

#include <OpenImageIO/imageio.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "horizon/terrain/dem_reader.hpp"
#include "test_support.hpp"

namespace horizon::terrain {
namespace {

using testing::TempDir;

// 4x2 RGB tile. Codes hand-computed from h = -10000 + (R*65536 + G*256 + B) * 0.1:
//   (1,134,160) -> 0 m, (2,26,32) -> 3776 m, (0,0,0) -> -10000 m,
//   (1,182,217) -> 1234.5 m, (1,134,107) -> -5.3 m, (255,255,255) -> 1667721.5 m.
const std::vector<std::array<std::uint8_t, 3>> kPixels = {{1, 134, 160}, {2, 26, 32},   {0, 0, 0},       {1, 182, 217},
                                                          {1, 134, 107}, {1, 134, 160}, {255, 255, 255}, {2, 26, 32}};
const std::vector<double> kHeights = {0.0, 3776.0, -10000.0, 1234.5, -5.3, 0.0, 1667721.5, 3776.0};

bool write_png(const std::string& path, int channels, std::uint8_t alpha_of_last = 255) {
  std::filesystem::create_directories(std::filesystem::path(path).parent_path());
  std::vector<std::uint8_t> data;
  for (std::size_t i = 0; i < kPixels.size(); ++i) {
    data.insert(data.end(), kPixels[i].begin(), kPixels[i].end());
    if (channels == 4) data.push_back(i + 1 == kPixels.size() ? alpha_of_last : 255);
  }
  auto out = OIIO::ImageOutput::create(path);
  if (!out) return false;
  OIIO::ImageSpec spec(4, 2, channels, OIIO::TypeDesc::UINT8);
  return out->open(path, spec) && out->write_image(OIIO::TypeDesc::UINT8, data.data()) && out->close();
}

// Tile z10/x906/y404 (Mt Fuji). T = 2*pi*6378137 / 2^10 = 39135.75848201024 m;
// x0 = -pi*R + 906 T, y0 = pi*R - 404 T.
constexpr double kTile = 39135.75848201024;
constexpr double kX0 = 15419488.841912035;
constexpr double kY0 = 4226661.916057106;

TEST(TerrainRgbReader, DecodesHeightsAndGeoreferenceFromPath) {
  TempDir dir;
  const std::string path = dir.file("tiles/10/906/404.png");
  ASSERT_TRUE(write_png(path, 3));
  auto dem = read_terrain_rgb(path, {});
  ASSERT_TRUE(dem.ok()) << dem.error().message;
  ASSERT_EQ(dem->width(), 4);
  ASSERT_EQ(dem->height(), 2);
  for (int i = 0; i < 8; ++i)
    EXPECT_NEAR(dem->elevation.data()[i], kHeights[i], 1e-3 * std::max(1.0, std::abs(kHeights[i]) / 1000)) << i;
  EXPECT_EQ(dem->georef.epsg, 3857);
  EXPECT_NEAR(dem->georef.transform.origin_x, kX0, 1e-6);
  EXPECT_NEAR(dem->georef.transform.origin_y, kY0, 1e-6);
  EXPECT_NEAR(dem->georef.transform.pixel_width, kTile / 4, 1e-9);
  EXPECT_NEAR(dem->georef.transform.pixel_height, -kTile / 2, 1e-9);
  EXPECT_FALSE(dem->nodata.has_value());
  EXPECT_EQ(dem->format, "Mapbox terrain-RGB png z10/x906/y404 (4x2)");
}

TEST(TerrainRgbReader, RetinaSuffixAndReadDemDispatch) {
  TempDir dir;
  const std::string path = dir.file("10/906/404@2x.png");
  ASSERT_TRUE(write_png(path, 3));
  auto dem = read_dem(path);
  ASSERT_TRUE(dem.ok()) << dem.error().message;
  EXPECT_NEAR(dem->georef.transform.origin_x, kX0, 1e-6);
  EXPECT_NEAR(dem->elevation.at(1, 0), 3776.0, 1e-3);
}

TEST(TerrainRgbReader, TileOptionOverridesPath) {
  TempDir dir;
  const std::string path = dir.file("fuji.png");
  ASSERT_TRUE(write_png(path, 3));
  ReadOptions options;
  options.tile = TileId{0, 0, 0};
  auto dem = read_terrain_rgb(path, options);
  ASSERT_TRUE(dem.ok()) << dem.error().message;
  // z0 is the whole world: x from -pi R, 2 pi R / 4 per pixel.
  EXPECT_NEAR(dem->georef.transform.origin_x, -20037508.342789244, 1e-6);
  EXPECT_NEAR(dem->georef.transform.origin_y, 20037508.342789244, 1e-6);
  EXPECT_NEAR(dem->georef.transform.pixel_width, 40075016.68557849 / 4, 1e-6);
}

TEST(TerrainRgbReader, TransparentPixelIsNodata) {
  TempDir dir;
  const std::string path = dir.file("10/906/404.png");
  ASSERT_TRUE(write_png(path, 4, 0));
  auto dem = read_terrain_rgb(path, {});
  ASSERT_TRUE(dem.ok()) << dem.error().message;
  EXPECT_TRUE(std::isnan(dem->elevation.at(3, 1)));
  EXPECT_NEAR(dem->elevation.at(0, 1), -5.3, 1e-3);
}

// The shared fuji_512.tif was decoded from the same tile's 512-px PNG; its
// GDAL georeferencing must equal the z/x/y formula.
TEST(TerrainRgbReader, FormulaMatchesSharedFujiTile) {
  const std::string shared = testing::shared_dem_dir();
  if (shared.empty()) GTEST_SKIP() << "shared DEM directory not present";
  auto fuji = read_dem(shared + "/fuji_512.tif");
  ASSERT_TRUE(fuji.ok()) << fuji.error().message;
  TempDir dir;
  const std::string path = dir.file("10/906/404.png");
  ASSERT_TRUE(write_png(path, 3));
  auto tile = read_terrain_rgb(path, {});
  ASSERT_TRUE(tile.ok());
  EXPECT_NEAR(fuji->georef.transform.origin_x, tile->georef.transform.origin_x, 1e-4);
  EXPECT_NEAR(fuji->georef.transform.origin_y, tile->georef.transform.origin_y, 1e-4);
  EXPECT_NEAR(fuji->georef.transform.pixel_width, kTile / 512, 1e-6);
  EXPECT_EQ(fuji->georef.epsg, 3857);
}

TEST(TerrainRgbReader, RejectsMissingTileId) {
  TempDir dir;
  const std::string path = dir.file("fuji.png");
  ASSERT_TRUE(write_png(path, 3));
  auto dem = read_terrain_rgb(path, {});
  ASSERT_FALSE(dem.ok());
  EXPECT_EQ(dem.error().code, ErrorCode::kInvalidArgument);
  EXPECT_EQ(dem.error().field, "tile");
  // Says what a user can do (the CLI has no flag for the position), in no internal name.
  EXPECT_NE(dem.error().message.find("z/x/y.png"), std::string::npos) << dem.error().message;
  EXPECT_EQ(dem.error().message.find("::"), std::string::npos) << dem.error().message;
  EXPECT_EQ(dem.error().message.find("--tile"), std::string::npos) << dem.error().message;
}

TEST(TerrainRgbReader, RejectsImpossibleTile) {
  TempDir dir;
  const std::string path = dir.file("3/8/0.png");  // x must be < 2^3
  ASSERT_TRUE(write_png(path, 3));
  auto dem = read_terrain_rgb(path, {});
  ASSERT_FALSE(dem.ok());
  EXPECT_EQ(dem.error().code, ErrorCode::kInvalidArgument);
  EXPECT_NE(dem.error().message.find("3/8/0"), std::string::npos) << dem.error().message;
}

TEST(TerrainRgbReader, RejectsGreyImage) {
  TempDir dir;
  const std::string path = dir.file("1/0/0.png");
  std::filesystem::create_directories(dir.file("1/0"));
  auto out = OIIO::ImageOutput::create(path);
  ASSERT_TRUE(out);
  const std::uint8_t grey[4] = {1, 2, 3, 4};
  ASSERT_TRUE(out->open(path, OIIO::ImageSpec(2, 2, 1, OIIO::TypeDesc::UINT8)));
  ASSERT_TRUE(out->write_image(OIIO::TypeDesc::UINT8, grey));
  ASSERT_TRUE(out->close());
  auto dem = read_terrain_rgb(path, {});
  ASSERT_FALSE(dem.ok());
  EXPECT_EQ(dem.error().code, ErrorCode::kDataError);
  EXPECT_NE(dem.error().message.find("3 or 4 channels"), std::string::npos);
}

TEST(TerrainRgbReader, RejectsMissingFile) {
  TempDir dir;
  auto dem = read_terrain_rgb(dir.file("1/0/0.png"), {});
  ASSERT_FALSE(dem.ok());
  EXPECT_EQ(dem.error().code, ErrorCode::kNotFound);
}

}  // namespace
}  // namespace horizon::terrain
