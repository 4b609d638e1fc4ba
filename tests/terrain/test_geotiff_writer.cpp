// Tests for terrain/geotiff_writer.cpp: write -> read round trips, what
// gdalinfo sees, determinism, and the all-or-nothing (atomic) property.
#include <gtest/gtest.h>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>
#include <utility>

#include "horizon/terrain/dem_reader.hpp"
#include "horizon/terrain/geotiff_writer.hpp"
#include "test_support.hpp"

namespace horizon::terrain {
namespace {

using testing::TempDir;
namespace fs = std::filesystem;

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

// 300 x 270 crosses tile edges in both directions (256 x 256 tiles).
Grid<float> float_grid() {
  Grid<float> g(300, 270);
  for (int r = 0; r < g.height(); ++r)
    for (int c = 0; c < g.width(); ++c) g.at(c, r) = 0.25f * c - 1.5f * r + 1000.0f;
  g.at(0, 0) = kNaN;
  g.at(299, 269) = kNaN;
  g.at(257, 3) = kNaN;
  return g;
}

Georeference utm_georef() {
  return {GeoTransform{712000.5, 10.0, 9561000.25, -10.0}, 32717};
}

int leftover_temporaries(const fs::path& dir) {
  int n = 0;
  for (const auto& entry : fs::directory_iterator(dir))
    if (entry.path().filename().string().find(".tmp-") != std::string::npos) ++n;
  return n;
}

TEST(GeoTiffWriter, Float32RoundTripWithNodata) {
  TempDir dir;
  const std::string path = dir.file("out.tif");
  const Grid<float> grid = float_grid();
  ASSERT_TRUE(write_geotiff(path, grid, utm_georef(), -9999.0).ok());
  auto dem = read_dem(path);
  ASSERT_TRUE(dem.ok()) << dem.error().message;
  EXPECT_EQ(dem->width(), 300);
  EXPECT_EQ(dem->height(), 270);
  EXPECT_EQ(dem->georef.epsg, 32717);
  EXPECT_EQ(dem->georef.transform, utm_georef().transform);
  ASSERT_TRUE(dem->nodata.has_value());
  EXPECT_EQ(*dem->nodata, -9999.0);
  EXPECT_EQ(dem->format, "GeoTIFF Float32 (deflate, tiled 256x256)");
  for (int r = 0; r < grid.height(); ++r)
    for (int c = 0; c < grid.width(); ++c) {
      const float want = grid.at(c, r);
      const float got = dem->elevation.at(c, r);
      if (std::isnan(want))
        EXPECT_TRUE(std::isnan(got)) << c << "," << r;
      else
        ASSERT_EQ(got, want) << c << "," << r;
    }
  EXPECT_EQ(elevation_stats(dem->elevation).nodata_cells, 3u);
}

TEST(GeoTiffWriter, Float32WithoutNodataKeepsNaN) {
  TempDir dir;
  const std::string path = dir.file("nan.tif");
  ASSERT_TRUE(write_geotiff(path, float_grid(), utm_georef(), std::nullopt).ok());
  auto dem = read_dem(path);
  ASSERT_TRUE(dem.ok()) << dem.error().message;
  ASSERT_TRUE(dem->nodata.has_value());  // the tag says "nan"
  EXPECT_TRUE(std::isnan(*dem->nodata));
  EXPECT_TRUE(std::isnan(dem->elevation.at(257, 3)));
  EXPECT_EQ(dem->elevation.at(1, 0), 1000.25f);
}

TEST(GeoTiffWriter, UInt8RoundTripGeographic) {
  TempDir dir;
  const std::string path = dir.file("vis.tif");
  Grid<std::uint8_t> grid(260, 3);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 260; ++c) grid.at(c, r) = static_cast<std::uint8_t>((c + r) % 3 == 2 ? 255 : (c + r) % 3);
  const Georeference geo{GeoTransform{86.0, 1.0 / 1200, 28.0, -1.0 / 1200}, 4326};
  ASSERT_TRUE(write_geotiff(path, grid, geo, 255.0).ok());
  auto dem = read_dem(path);
  ASSERT_TRUE(dem.ok()) << dem.error().message;
  EXPECT_EQ(dem->georef.epsg, 4326);
  EXPECT_EQ(dem->georef.transform, geo.transform);
  EXPECT_EQ(*dem->nodata, 255.0);
  EXPECT_EQ(dem->format, "GeoTIFF UInt8 (deflate, tiled 256x256)");
  EXPECT_EQ(dem->elevation.at(0, 0), 0.0f);
  EXPECT_EQ(dem->elevation.at(1, 0), 1.0f);
  EXPECT_TRUE(std::isnan(dem->elevation.at(2, 0)));
  EXPECT_EQ(dem->elevation.at(259, 2), 0.0f);                     // (259 + 2) % 3 == 0
  EXPECT_TRUE(std::isnan(dem->elevation.at(258, 2)));             // (258 + 2) % 3 == 2 -> 255 -> nodata
  EXPECT_EQ(elevation_stats(dem->elevation).nodata_cells, 260u);  // one in three of 780 cells
}

TEST(GeoTiffWriter, UInt32RoundTripKeepsCountsBeyondUInt16) {
  TempDir dir;
  const std::string path = dir.file("count.tif");
  Grid<std::uint32_t> grid(300, 4);
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 300; ++c) grid.at(c, r) = static_cast<std::uint32_t>(c * 997 + r * 70001);
  grid.at(5, 1) = 4294967295u;  // nodata
  ASSERT_TRUE(write_geotiff(path, grid, utm_georef(), 4294967295.0).ok());
  auto dem = read_dem(path);
  ASSERT_TRUE(dem.ok()) << dem.error().message;
  EXPECT_EQ(dem->format, "GeoTIFF UInt32 (deflate, tiled 256x256)");
  EXPECT_EQ(dem->georef.transform, utm_georef().transform);
  EXPECT_EQ(dem->elevation.at(0, 0), 0.0f);
  EXPECT_EQ(dem->elevation.at(299, 3), 299.0f * 997 + 3 * 70001);  // 508 106: past 16 bits, exact in float
  EXPECT_EQ(dem->elevation.at(257, 2), 257.0f * 997 + 2 * 70001);
  EXPECT_TRUE(std::isnan(dem->elevation.at(5, 1)));
  EXPECT_EQ(elevation_stats(dem->elevation).nodata_cells, 1u);
  // A nodata the type cannot hold is refused, and nothing is written.
  const std::string bad = dir.file("bad.tif");
  auto s = write_geotiff(bad, grid, utm_georef(), -1.0);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("UInt32"), std::string::npos) << s.error().message;
  EXPECT_FALSE(std::filesystem::exists(bad));
}

TEST(GeoTiffWriter, SouthUpRoundTripUsesTransformationMatrix) {
  TempDir dir;
  const std::string path = dir.file("south_up.tif");
  const Georeference geo{GeoTransform{100.0, 2.0, 200.0, 3.0}, 32633};
  Grid<float> grid(3, 2, 5.0f);
  ASSERT_TRUE(write_geotiff(path, grid, geo, std::nullopt).ok());
  auto dem = read_dem(path);
  ASSERT_TRUE(dem.ok()) << dem.error().message;
  EXPECT_EQ(dem->georef.transform, geo.transform);
}

TEST(GeoTiffWriter, OutputIsDeterministic) {
  TempDir dir;
  ASSERT_TRUE(write_geotiff(dir.file("a.tif"), float_grid(), utm_georef(), -32768.0).ok());
  ASSERT_TRUE(write_geotiff(dir.file("b.tif"), float_grid(), utm_georef(), -32768.0).ok());
  const std::string a = testing::read_bytes(dir.file("a.tif"));
  EXPECT_GT(a.size(), 1000u);
  EXPECT_EQ(a, testing::read_bytes(dir.file("b.tif")));
}

TEST(GeoTiffWriter, GdalinfoSeesOriginPixelSizeEpsgAndNodata) {
  if (testing::run_command("gdalinfo --version").exit_code != 0) GTEST_SKIP() << "gdalinfo not installed";
  TempDir dir;
  const std::string path = dir.file("gdal.tif");
  ASSERT_TRUE(write_geotiff(path, float_grid(), utm_georef(), -32768.0).ok());
  const auto run = testing::run_command("gdalinfo -json '" + path + "'");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const auto info = nlohmann::json::parse(run.output.substr(run.output.find('{')));
  const auto& gt = info.at("geoTransform");
  EXPECT_DOUBLE_EQ(gt.at(0).get<double>(), 712000.5);
  EXPECT_DOUBLE_EQ(gt.at(1).get<double>(), 10.0);
  EXPECT_DOUBLE_EQ(gt.at(2).get<double>(), 0.0);
  EXPECT_DOUBLE_EQ(gt.at(3).get<double>(), 9561000.25);
  EXPECT_DOUBLE_EQ(gt.at(5).get<double>(), -10.0);
  EXPECT_EQ(info.at("size").at(0).get<int>(), 300);
  const std::string wkt = info.at("coordinateSystem").at("wkt").get<std::string>();
  EXPECT_NE(wkt.find("ID[\"EPSG\",32717]]"), std::string::npos) << wkt;
  const auto& band = info.at("bands").at(0);
  EXPECT_EQ(band.at("type").get<std::string>(), "Float32");
  EXPECT_DOUBLE_EQ(band.at("noDataValue").get<double>(), -32768.0);
  EXPECT_EQ(info.at("metadata").at("").at("AREA_OR_POINT").get<std::string>(), "Area");
  EXPECT_EQ(info.at("metadata").at("IMAGE_STRUCTURE").at("COMPRESSION").get<std::string>(), "DEFLATE");
}

// GDAL decodes the tiles (our own predictor and deflate) to the values written,
// in every tile, including the padded edge tiles.
TEST(GeoTiffWriter, GdalReadsThePixelsWritten) {
  if (testing::run_command("gdallocationinfo --version").exit_code != 0) GTEST_SKIP() << "GDAL not installed";
  TempDir dir;
  const std::string path = dir.file("pixels.tif");
  const Grid<float> grid = float_grid();
  ASSERT_TRUE(write_geotiff(path, grid, utm_georef(), -9999.0).ok());
  for (auto [c, r] : {std::pair{1, 0}, {255, 255}, {256, 0}, {299, 268}, {12, 269}, {257, 3}}) {
    const auto run =
        testing::run_command("gdallocationinfo -valonly '" + path + "' " + std::to_string(c) + " " + std::to_string(r));
    ASSERT_EQ(run.exit_code, 0) << run.output;
    const double want = std::isnan(grid.at(c, r)) ? -9999.0 : grid.at(c, r);
    EXPECT_EQ(std::stod(run.output), want) << c << "," << r;
  }
  Grid<std::uint8_t> mask(300, 270, 0);
  for (int r = 0; r < mask.height(); ++r)
    for (int c = 0; c < mask.width(); ++c) mask.at(c, r) = static_cast<std::uint8_t>((c * 7 + r * 3) % 256);
  const std::string mask_path = dir.file("mask.tif");
  ASSERT_TRUE(write_geotiff(mask_path, mask, utm_georef(), 255.0).ok());
  for (auto [c, r] : {std::pair{0, 0}, {200, 100}, {299, 269}, {260, 10}}) {
    const auto run = testing::run_command("gdallocationinfo -valonly '" + mask_path + "' " + std::to_string(c) + " " +
                                          std::to_string(r));
    ASSERT_EQ(run.exit_code, 0) << run.output;
    EXPECT_EQ(std::stoi(run.output), int(mask.at(c, r))) << c << "," << r;
  }
}

TEST(GeoTiffWriter, GdalinfoSeesGeographicUInt8) {
  if (testing::run_command("gdalinfo --version").exit_code != 0) GTEST_SKIP() << "gdalinfo not installed";
  TempDir dir;
  const std::string path = dir.file("geo.tif");
  const Georeference geo{GeoTransform{-122.0, 0.001, 47.0, -0.001}, 4326};
  ASSERT_TRUE(write_geotiff(path, Grid<std::uint8_t>(10, 8, 1), geo, 255.0).ok());
  const auto run = testing::run_command("gdalinfo -json '" + path + "'");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const auto info = nlohmann::json::parse(run.output.substr(run.output.find('{')));
  EXPECT_DOUBLE_EQ(info.at("geoTransform").at(0).get<double>(), -122.0);
  EXPECT_DOUBLE_EQ(info.at("geoTransform").at(3).get<double>(), 47.0);
  EXPECT_NE(info.at("coordinateSystem").at("wkt").get<std::string>().find("ID[\"EPSG\",4326]]"), std::string::npos);
  EXPECT_EQ(info.at("bands").at(0).at("type").get<std::string>(), "Byte");
  EXPECT_DOUBLE_EQ(info.at("bands").at(0).at("noDataValue").get<double>(), 255.0);
}

TEST(GeoTiffWriter, GdalinfoSeesTheColourTableAndThePixelsReadBack) {
  if (testing::run_command("gdalinfo --version").exit_code != 0) GTEST_SKIP() << "gdalinfo not installed";
  TempDir dir;
  const std::string path = dir.file("mask.tif");
  Grid<std::uint8_t> mask(300, 270, 0);
  for (int r = 0; r < 270; ++r)
    for (int c = 0; c < 300; ++c) mask.at(c, r) = static_cast<std::uint8_t>((c + r) % 3 == 0 ? 1 : c > 280 ? 255 : 0);
  ColourTable colours{};
  colours[0] = {213, 94, 0};
  colours[1] = {0, 114, 178};
  colours[255] = {222, 222, 222};
  ASSERT_TRUE(write_geotiff(path, mask, utm_georef(), 255.0, colours).ok());
  const auto run = testing::run_command("gdalinfo -json '" + path + "'");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const auto info = nlohmann::json::parse(run.output.substr(run.output.find('{')));
  const auto& band = info.at("bands").at(0);
  EXPECT_EQ(band.at("colorInterpretation").get<std::string>(), "Palette");
  const auto& entries = band.at("colorTable").at("entries");
  ASSERT_EQ(entries.size(), 256u);
  EXPECT_EQ(entries.at(0), nlohmann::json::parse("[213, 94, 0, 255]"));
  EXPECT_EQ(entries.at(1), nlohmann::json::parse("[0, 114, 178, 255]"));
  EXPECT_EQ(entries.at(255), nlohmann::json::parse("[222, 222, 222, 0]")) << "nodata: transparent";
  EXPECT_DOUBLE_EQ(band.at("noDataValue").get<double>(), 255.0);
  // The codes are unchanged: our reader and GDAL's read them back.
  auto back = read_dem(path);
  ASSERT_TRUE(back.ok()) << back.error().message;
  for (auto [c, r] : {std::pair{0, 0}, {1, 0}, {2, 1}, {290, 100}, {299, 269}}) {
    if (mask.at(c, r) == 255)
      EXPECT_TRUE(std::isnan(back->elevation.at(c, r))) << c << "," << r;
    else
      EXPECT_EQ(back->elevation.at(c, r), float(mask.at(c, r))) << c << "," << r;
  }
  const auto value = testing::run_command("gdallocationinfo -valonly '" + path + "' 3 0");
  EXPECT_EQ(std::stoi(value.output), 1);
}

TEST(GeoTiffWriter, ReplacesExistingFile) {
  TempDir dir;
  const std::string path = dir.file("out.tif");
  std::ofstream(path) << "old";
  ASSERT_TRUE(write_geotiff(path, Grid<float>(2, 2, 1.0f), utm_georef(), std::nullopt).ok());
  EXPECT_TRUE(read_dem(path).ok());
  EXPECT_EQ(leftover_temporaries(dir.path()), 0);
}

// The temporaries are "<path>.tmp-<pid>-<n>", n counting up in this
// process. Symlinks planted under those names (as in a shared /tmp) must
// never be written through: every other name taken, the writer skips them;
// every name taken, it refuses.
TEST(GeoTiffWriter, NeverWritesThroughANamePlantedForItsTemporary) {
  TempDir dir;
  const std::string path = dir.file("out.tif");
  const std::string victim = dir.file("victim.txt");
  std::ofstream(victim) << "precious";
  constexpr int kNames = 20000;  // beyond any count this test binary reaches
  const auto plant = [&](int step) {
    for (int n = 0; n < kNames; n += step)
      fs::create_symlink(victim, path + ".tmp-" + std::to_string(::getpid()) + "-" + std::to_string(n));
  };
  const auto unplant = [&] {
    for (int n = 0; n < kNames; ++n) fs::remove(path + ".tmp-" + std::to_string(::getpid()) + "-" + std::to_string(n));
  };
  plant(1);
  const Status refused = write_geotiff(path, float_grid(), utm_georef(), -9999.0);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().code, ErrorCode::kIoError);
  EXPECT_NE(refused.error().message.find("cannot create a temporary file"), std::string::npos)
      << refused.error().message;
  EXPECT_EQ(testing::read_bytes(victim), "precious");
  EXPECT_FALSE(fs::exists(path));
  unplant();
  plant(2);  // every even name
  ASSERT_TRUE(write_geotiff(path, float_grid(), utm_georef(), -9999.0).ok());
  EXPECT_EQ(testing::read_bytes(victim), "precious");
  EXPECT_TRUE(read_dem(path).ok());
  unplant();
}

TEST(GeoTiffWriter, RejectsPathInMissingDirectoryAndLeavesNothing) {
  TempDir dir;
  const std::string path = dir.file("missing/out.tif");
  const Status st = write_geotiff(path, float_grid(), utm_georef(), -9999.0);
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().code, ErrorCode::kIoError);
  EXPECT_NE(st.error().message.find(path), std::string::npos) << st.error().message;
  EXPECT_FALSE(fs::exists(dir.file("missing")));
  EXPECT_TRUE(fs::is_empty(dir.path()));
}

TEST(GeoTiffWriter, FailureAfterWritingLeavesTargetAndNoTemporary) {
  // The target is a directory: the data is fully written to the temporary,
  // then rename() fails. The directory must survive and the temporary go.
  TempDir dir;
  const std::string path = dir.file("taken.tif");
  fs::create_directory(path);
  std::ofstream(dir.file("taken.tif/keep.txt")) << "precious";
  const Status st = write_geotiff(path, float_grid(), utm_georef(), -9999.0);
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().code, ErrorCode::kIoError);
  EXPECT_NE(st.error().message.find(path), std::string::npos);
  EXPECT_EQ(testing::read_bytes(dir.file("taken.tif/keep.txt")), "precious");
  EXPECT_EQ(leftover_temporaries(dir.path()), 0);
}

TEST(GeoTiffWriter, FailureLeavesExistingFileUntouched) {
  TempDir dir;
  const std::string path = dir.file("out.tif");
  std::ofstream(path) << "precious";
  Georeference bad = utm_georef();
  bad.epsg = 5714;  // a valid EPSG code, but a vertical CRS (MSL height): no map
  const Status st = write_geotiff(path, float_grid(), bad, std::nullopt);
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().code, ErrorCode::kUnsupported);
  EXPECT_NE(st.error().message.find("EPSG:5714"), std::string::npos) << st.error().message;
  EXPECT_NE(st.error().message.find("vertical"), std::string::npos) << st.error().message;
  EXPECT_EQ(testing::read_bytes(path), "precious");
  EXPECT_EQ(leftover_temporaries(dir.path()), 0);
}

TEST(GeoTiffWriter, FailureInReadOnlyDirectoryLeavesExistingFileUntouched) {
  if (::geteuid() == 0) GTEST_SKIP() << "root ignores directory permissions";
  TempDir dir;
  const fs::path ro = dir.path() / "ro";
  fs::create_directory(ro);
  const std::string path = (ro / "out.tif").string();
  std::ofstream(path) << "precious";
  fs::permissions(ro, fs::perms::owner_read | fs::perms::owner_exec);
  const Status st = write_geotiff(path, float_grid(), utm_georef(), std::nullopt);
  fs::permissions(ro, fs::perms::owner_all);
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().code, ErrorCode::kIoError);
  EXPECT_EQ(testing::read_bytes(path), "precious");
  EXPECT_EQ(leftover_temporaries(ro), 0);
}

TEST(GeoTiffWriter, RejectsBadInput) {
  TempDir dir;
  const std::string path = dir.file("x.tif");
  EXPECT_EQ(write_geotiff(path, Grid<float>(), utm_georef(), std::nullopt).error().code, ErrorCode::kInvalidArgument);
  Georeference zero = utm_georef();
  zero.transform.pixel_width = 0.0;
  EXPECT_EQ(write_geotiff(path, Grid<float>(2, 2), zero, std::nullopt).error().code, ErrorCode::kInvalidArgument);
  Georeference inf = utm_georef();
  inf.transform.origin_x = std::numeric_limits<double>::infinity();
  EXPECT_EQ(write_geotiff(path, Grid<float>(2, 2), inf, std::nullopt).error().code, ErrorCode::kInvalidArgument);
  EXPECT_EQ(write_geotiff(path, Grid<std::uint8_t>(2, 2), utm_georef(), 256.0).error().code,
            ErrorCode::kInvalidArgument);
  EXPECT_EQ(write_geotiff(path, Grid<std::uint8_t>(2, 2), utm_georef(), 1.5).error().code, ErrorCode::kInvalidArgument);
  EXPECT_EQ(write_geotiff(path, Grid<float>(2, 2), utm_georef(), 1e39).error().code, ErrorCode::kInvalidArgument);
  EXPECT_FALSE(fs::exists(path));
}

}  // namespace
}  // namespace horizon::terrain
