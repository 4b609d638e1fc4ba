// Header-only reads and window reads: a window of a tiled or striped GeoTIFF
// decodes only the blocks under it, returns exactly the full read's cells
// with a shifted georeference, and counts what it decoded.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <utility>

#include "horizon/geodesy/observer.hpp"
#include "horizon/terrain/dem_reader.hpp"
#include "horizon/terrain/geotiff_writer.hpp"
#include "test_support.hpp"
#include "tiff_fixtures.hpp"

namespace horizon::terrain {
namespace {

using testing::TempDir;

// A 1100 x 900 projected DEM with voids, written as the engine writes rasters
// (deflate + predictor, 256 x 256 tiles): 5 x 4 = 20 tiles.
struct TiledFile {
  TempDir dir;
  std::string path;
  Dem dem;
  TiledFile() {
    dem = testing::make_dem(1100, 900, [](int c, int r) {
      if ((c * 7 + r * 13) % 97 == 0) return std::nan("");
      return 1000.0 + 300.0 * std::sin(c * 0.013) * std::cos(r * 0.017) + 0.25 * ((c * 31 + r * 17) % 11);
    });
    path = dir.file("tiled.tif");
    EXPECT_TRUE(write_geotiff(path, dem.elevation, dem.georef, -9999.0).ok());
  }
};

bool same_cells(const Grid<float>& a, const Grid<float>& b) {
  if (a.width() != b.width() || a.height() != b.height()) return false;
  return std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;  // bitwise: NaN payloads too
}

Grid<float> crop(const Grid<float>& g, const Window& w) {
  Grid<float> out(w.width(), w.height());
  for (int r = w.row0; r < w.row1; ++r)
    for (int c = w.col0; c < w.col1; ++c) out.at(c - w.col0, r - w.row0) = g.at(c, r);
  return out;
}

TEST(WindowRead, HeaderMatchesFullReadWithoutDecodingPixels) {
  TiledFile f;
  auto header = read_dem_header(f.path);
  ASSERT_TRUE(header.ok()) << header.error().message;
  ReadStats stats;
  auto full = read_dem(f.path, {}, &stats);
  ASSERT_TRUE(full.ok()) << full.error().message;
  EXPECT_EQ(header->width, 1100);
  EXPECT_EQ(header->height, 900);
  EXPECT_EQ(header->georef.transform, full->georef.transform);
  EXPECT_EQ(header->georef.epsg, full->georef.epsg);
  EXPECT_EQ(header->nodata, full->nodata);
  EXPECT_EQ(header->format, full->format);
  EXPECT_TRUE(header->tiled);
  EXPECT_EQ(header->block_width, 256);
  EXPECT_EQ(header->block_height, 256);
  EXPECT_EQ(header->blocks_total, 20u);
  // A full read decodes every tile.
  EXPECT_EQ(stats.blocks_total, 20u);
  EXPECT_EQ(stats.blocks_read, 20u);
  EXPECT_EQ(stats.window, (Window{0, 0, 1100, 900}));
}

// The lowest and highest non-void value of a grid, by brute force.
std::pair<float, float> value_range(const Grid<float>& g) {
  float lo = std::numeric_limits<float>::infinity(), hi = -lo;
  for (std::size_t i = 0; i < g.size(); ++i) {
    if (std::isnan(g.data()[i])) continue;
    lo = std::min(lo, g.data()[i]);
    hi = std::max(hi, g.data()[i]);
  }
  return {lo, hi};
}

TEST(WindowRead, ReportsTheLowestAndHighestValueOfTheCellsItReturns) {
  // The range the elevation source checks plausibility by: exactly the
  // window's values, voids aside, infinities counted, whatever the window's
  // width (rows of 4 cells at a time, then the rest) and the threads.
  TempDir dir;
  Dem dem = testing::make_dem(700, 300, [](int c, int r) {
    if ((c * 7 + r * 13) % 41 == 0) return std::nan("");
    return 500.0 + 200.0 * std::sin(c * 0.02) * std::cos(r * 0.03);
  });
  dem.elevation.at(601, 250) = 12000.5f;
  dem.elevation.at(603, 250) = -std::numeric_limits<float>::infinity();
  const std::string path = dir.file("range.tif");
  ASSERT_TRUE(write_geotiff(path, dem.elevation, dem.georef, -9999.0).ok());
  const Window windows[] = {{0, 0, 700, 300}, {3, 2, 10, 9}, {600, 249, 603, 252}, {600, 240, 607, 260}, {5, 5, 6, 6}};
  for (const Window& w : windows) {
    for (unsigned threads : {1u, 2u}) {
      ReadOptions options;
      options.window = w;
      options.threads = threads;
      ReadStats stats;
      auto part = read_dem(path, options, &stats);
      ASSERT_TRUE(part.ok()) << part.error().message;
      const auto [lo, hi] = value_range(part->elevation);
      EXPECT_EQ(stats.value_min, lo) << w.col0 << "," << w.row0 << " on " << threads;
      EXPECT_EQ(stats.value_max, hi) << w.col0 << "," << w.row0 << " on " << threads;
    }
  }
  // The window holding the spike alone, then one with the -inf beside it.
  ReadOptions spike;
  spike.window = Window{600, 249, 603, 252};
  ReadStats stats;
  ASSERT_TRUE(read_dem(path, spike, &stats).ok());
  EXPECT_EQ(stats.value_max, 12000.5f);
  spike.window = Window{600, 240, 607, 260};
  ASSERT_TRUE(read_dem(path, spike, &stats).ok());
  EXPECT_EQ(stats.value_min, -std::numeric_limits<float>::infinity());
}

TEST(WindowRead, TiledWindowReadsOnlyItsTilesAndEqualsTheFullReadCrop) {
  TiledFile f;
  auto full = read_dem(f.path);
  ASSERT_TRUE(full.ok());
  // Inside one tile, across a tile corner (4 tiles), and a whole tile row.
  const struct {
    Window window;
    std::uint64_t tiles;
  } cases[] = {{{300, 300, 400, 380}, 1}, {{250, 250, 270, 262}, 4}, {{0, 512, 1100, 700}, 5}};
  for (const auto& c : cases) {
    ReadOptions options;
    options.window = c.window;
    ReadStats stats;
    auto part = read_dem(f.path, options, &stats);
    ASSERT_TRUE(part.ok()) << part.error().message;
    EXPECT_TRUE(same_cells(part->elevation, crop(full->elevation, c.window)));
    EXPECT_EQ(part->georef.transform, full->georef.transform.shifted(c.window.col0, c.window.row0));
    EXPECT_EQ(part->georef.epsg, full->georef.epsg);
    EXPECT_EQ(stats.blocks_read, c.tiles) << c.window.col0 << "," << c.window.row0;
    EXPECT_EQ(stats.blocks_total, 20u);
    EXPECT_EQ(stats.window, c.window);
    EXPECT_EQ(stats.cells_decoded, c.tiles * 256 * 256);
  }
}

TEST(WindowRead, WindowIsClippedToTheRaster) {
  TiledFile f;
  ReadOptions options;
  options.window = Window{1000, 850, 1300, 1000};
  ReadStats stats;
  auto part = read_dem(f.path, options, &stats);
  ASSERT_TRUE(part.ok());
  EXPECT_EQ(stats.window, (Window{1000, 850, 1100, 900}));
  EXPECT_EQ(part->width(), 100);
  EXPECT_EQ(part->height(), 50);
  EXPECT_EQ(stats.blocks_read, 2u);  // tile columns 768.. and 1024.., tile row 768..
}

TEST(WindowRead, RejectsWindowOutsideTheRaster) {
  TiledFile f;
  ReadOptions options;
  options.window = Window{1100, 0, 1200, 10};
  auto part = read_dem(f.path, options);
  ASSERT_FALSE(part.ok());
  EXPECT_EQ(part.error().code, ErrorCode::kOutOfRange);
  EXPECT_NE(part.error().message.find("tiled.tif"), std::string::npos);
  options.window = Window{5, 5, 5, 10};  // empty
  EXPECT_EQ(read_dem(f.path, options).error().code, ErrorCode::kOutOfRange);
}

TEST(WindowRead, StripedWindowReadsOnlyItsStrips) {
  TempDir dir;
  testing::RawTiff spec;  // one row per strip, uncompressed, Int16
  spec.width = 60;
  spec.height = 40;
  spec.int16 = true;
  for (int r = 0; r < spec.height; ++r)
    for (int c = 0; c < spec.width; ++c) spec.values.push_back(c * 100 + r);
  spec.pixel_scale = {10, 10, 0};
  spec.tiepoints = {0, 0, 0, 500000, 5000000, 0};
  spec.geokeys = {{1024, 1}, {1025, 1}, {3072, 32633}};
  const std::string path = dir.file("striped.tif");
  ASSERT_TRUE(testing::write_raw_tiff(path, spec));
  auto full = read_dem(path);
  ASSERT_TRUE(full.ok()) << full.error().message;
  ReadOptions options;
  options.window = Window{10, 5, 20, 12};
  ReadStats stats;
  auto part = read_dem(path, options, &stats);
  ASSERT_TRUE(part.ok()) << part.error().message;
  EXPECT_TRUE(same_cells(part->elevation, crop(full->elevation, *options.window)));
  EXPECT_FALSE(stats.tiled);
  EXPECT_EQ(stats.blocks_total, 40u);
  EXPECT_EQ(stats.blocks_read, 7u);
  EXPECT_EQ(part->elevation.at(0, 0), 10 * 100 + 5);
}

// A compressed file of one tall strip (some tools write them): a window
// near the top decodes the strip down to its own last row and no further; a
// window at the bottom needs the whole strip. Both equal the full read.
TEST(WindowRead, OneCompressedStripIsDecodedOnlyDownToTheWindow) {
  TempDir dir;
  testing::RawTiff spec = testing::utm_raw_tiff(200, 3000);
  spec.int16 = true;
  spec.rows_per_strip = 3000;
  spec.deflate = true;
  for (int r = 0; r < spec.height; ++r)
    for (int c = 0; c < spec.width; ++c) spec.values[static_cast<std::size_t>(r * spec.width + c)] = c * 7 + r % 500;
  const std::string path = dir.file("one_strip.tif");
  ASSERT_TRUE(testing::write_raw_tiff(path, spec));
  auto full = read_dem(path);
  ASSERT_TRUE(full.ok()) << full.error().message;
  const struct {
    Window window;
    std::uint64_t cells_decoded;
  } cases[] = {{{10, 5, 60, 40}, 200u * 40}, {{0, 2990, 200, 3000}, 200u * 3000}};
  for (const auto& c : cases) {
    ReadOptions options;
    options.window = c.window;
    ReadStats stats;
    auto part = read_dem(path, options, &stats);
    ASSERT_TRUE(part.ok()) << part.error().message;
    EXPECT_TRUE(same_cells(part->elevation, crop(full->elevation, c.window))) << c.window.row0;
    EXPECT_EQ(stats.blocks_total, 1u);
    EXPECT_EQ(stats.blocks_read, 1u);
    EXPECT_EQ(stats.cells_decoded, c.cells_decoded) << c.window.row0;
  }
}

TEST(WindowRead, BundledDeflateTilesMatchFullRead) {
  // Real files: Int16 with voids (Everest) and Float32 with NaN (Andes), both tiled deflate.
  for (const char* name : {"everest_summit_voids_srtm3_300x300.tif", "ecuador_andes_utm17s_10m_383x415.tif"}) {
    const std::string path = testing::bundled_dem(name);
    auto full = read_dem(path);
    ASSERT_TRUE(full.ok());
    const Window w{17, 101, full->width() - 3, full->height() - 40};
    ReadOptions options;
    options.window = w;
    auto part = read_dem(path, options);
    ASSERT_TRUE(part.ok()) << part.error().message;
    EXPECT_TRUE(same_cells(part->elevation, crop(full->elevation, w))) << name;
    ASSERT_EQ(part->nodata.has_value(), full->nodata.has_value());
    if (full->nodata) {
      EXPECT_TRUE(*part->nodata == *full->nodata || (std::isnan(*part->nodata) && std::isnan(*full->nodata)));
    }
  }
}

TEST(WindowRead, LocatedPointShiftedByTheWindowResolvesAsOnTheFullDem) {
  TiledFile f;
  auto full = read_dem(f.path);
  auto header = read_dem_header(f.path);
  ASSERT_TRUE(full.ok() && header.ok());
  geodesy::PointSpec spec;
  spec.x = 500000 + 10 * 612.37;
  spec.y = 5000000 - 10 * 433.81;
  spec.height = 3;
  auto whole = geodesy::resolve_point(*full, spec, "observer");
  ASSERT_TRUE(whole.ok());
  auto located = geodesy::locate_point(header->georef, header->width, header->height, spec, "observer", f.path);
  ASSERT_TRUE(located.ok());
  const Window w = geodesy::cells_within(header->georef, header->width, header->height, *located, 500.0, 2);
  // 500 m at 10 m cells: 50 cells each way, plus the margin.
  EXPECT_LE(w.width(), 2 * 52 + 2);
  EXPECT_GE(w.width(), 2 * 50);
  EXPECT_TRUE(w.contains(612, 434));
  ReadOptions options;
  options.window = w;
  auto part = read_dem(f.path, options);
  ASSERT_TRUE(part.ok());
  located->col -= w.col0;
  located->row -= w.row0;
  auto placed = geodesy::place_on_ground(*part, *located, spec, "observer");
  ASSERT_TRUE(placed.ok());
  EXPECT_EQ(placed->col + w.col0, whole->col);
  EXPECT_EQ(placed->row + w.row0, whole->row);
  EXPECT_EQ(placed->ground, whole->ground);
  EXPECT_EQ(placed->elevation, whole->elevation);
  // Outside the raster: the same error as resolve_point.
  spec.x = 400000;
  auto outside = geodesy::locate_point(header->georef, header->width, header->height, spec, "observer", f.path);
  ASSERT_FALSE(outside.ok());
  EXPECT_EQ(outside.error().code, ErrorCode::kOutOfRange);
  EXPECT_EQ(outside.error().message, geodesy::resolve_point(*full, spec, "observer").error().message);
}

}  // namespace
}  // namespace horizon::terrain
