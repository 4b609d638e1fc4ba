// Elevation sources: a mosaic of tiles reads the same cells as the raster it
// was cut from, with or without the block cache; SRTM .hgt folders; missing,
// mismatched and corrupt tiles named in errors.
#include <gtest/gtest.h>

#include <limits>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <vector>

#include "horizon/terrain/dem_reader.hpp"
#include "horizon/terrain/geotiff_writer.hpp"
#include "horizon/terrain/source.hpp"
#include "test_support.hpp"

namespace horizon::terrain {
namespace {

using testing::TempDir;

bool same_cells(const Grid<float>& a, const Grid<float>& b) {
  if (a.width() != b.width() || a.height() != b.height()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const float x = a.values()[i], y = b.values()[i];
    if (!(x == y || (std::isnan(x) && std::isnan(y)))) return false;
  }
  return true;
}

BlockCache::Options cache_of(std::uint64_t budget, unsigned io_threads = 2) {
  BlockCache::Options o;
  o.budget_bytes = budget;
  o.io_threads = io_threads;
  return o;
}

SourceOptions blocks_of(std::uint64_t cells) {
  SourceOptions o;
  o.block_cells = cells;
  return o;
}

SourceOptions missing_as_nodata() {
  SourceOptions o;
  o.missing_as_nodata = true;
  return o;
}

std::string numbered(const char* prefix, int n) {
  std::string s(prefix);
  s += std::to_string(n);
  return s;
}

Dem georeferenced_terrain(int width, int height, unsigned seed) {
  Dem dem = testing::make_random_terrain(width, height, seed, 400.0, 10.0);
  dem.georef.epsg = 32633;
  dem.georef.transform = {500000.0, 10.0, 5000000.0, -10.0};
  return dem;
}

TEST(ElevationSource, AMosaicHasTheGeoreferenceOfTheRasterItWasCutFrom) {
  TempDir dir;
  const Dem dem = georeferenced_terrain(301, 257, 3);
  for (int n : {2, 3, 4}) {
    const auto sub = dir.file(numbered("m", n));
    std::filesystem::create_directory(sub);
    ASSERT_EQ(testing::write_tiles(dem, n, n, sub).size(), static_cast<std::size_t>(n * n));
    auto source = ElevationSource::open(sub);
    ASSERT_TRUE(source.ok()) << source.error().message;
    const DemHeader& h = (*source)->header();
    EXPECT_TRUE((*source)->is_mosaic());
    EXPECT_EQ(h.width, 301);
    EXPECT_EQ(h.height, 257);
    EXPECT_EQ(h.georef.epsg, 32633);
    EXPECT_EQ(h.georef.transform, dem.georef.transform);  // bit for bit
    EXPECT_EQ((*source)->files().size(), static_cast<std::size_t>(n * n));
    EXPECT_NE(h.format.find("mosaic of " + std::to_string(n * n) + " files"), std::string::npos) << h.format;
  }
}

TEST(ElevationSource, TiledEqualsUntiledForEveryWindowWithAndWithoutTheCache) {
  TempDir dir;
  const Dem dem = georeferenced_terrain(301, 257, 5);
  const std::string merged = dir.file("merged.tif");
  ASSERT_TRUE(write_geotiff(merged, dem.elevation, dem.georef, std::nullopt).ok());
  auto whole = ElevationSource::open(merged);
  ASSERT_TRUE(whole.ok());
  std::mt19937 rng(11);
  for (int n : {2, 3, 4}) {
    const auto sub = dir.file(numbered("t", n));
    std::filesystem::create_directory(sub);
    testing::write_tiles(dem, n, n, sub);
    // Small blocks so that windows cross many of them.
    auto tiled = ElevationSource::open(sub, blocks_of(900));
    ASSERT_TRUE(tiled.ok()) << tiled.error().message;
    BlockCache cache(cache_of(1 << 20, 2));
    std::uniform_int_distribution<int> col(-20, 300), row(-20, 256), size(1, 200);
    for (int i = 0; i < 25; ++i) {
      const int c0 = col(rng), r0 = row(rng);
      const Window w{c0, r0, c0 + size(rng), r0 + size(rng)};
      ReadOptions window_only;
      window_only.window = w;
      auto expect = read_dem(merged, window_only);
      if (!expect.ok()) continue;  // outside: both refuse
      for (BlockCache* c : {static_cast<BlockCache*>(nullptr), &cache}) {
        SourceReadStats stats;
        auto got = (*tiled)->read(w, c, nullptr, &stats);
        ASSERT_TRUE(got.ok()) << got.error().message;
        EXPECT_TRUE(same_cells(got->elevation, expect->elevation)) << n << " tiles, window " << i;
        EXPECT_EQ(got->georef.transform, expect->georef.transform);
        EXPECT_EQ(stats.blocks, (*tiled)->blocks_in(stats.window).size());
        auto single = (*whole)->read(w, c);
        ASSERT_TRUE(single.ok());
        EXPECT_TRUE(same_cells(single->elevation, expect->elevation));
      }
    }
    const BlockCacheStats s = cache.stats();
    EXPECT_GT(s.hits, 0u);
    EXPECT_LE(s.peak_resident_bytes, 1u << 20);
  }
}

TEST(ElevationSource, BlocksUnderAWindowAreExactlyThoseThatMeetIt) {
  TempDir dir;
  const Dem dem = georeferenced_terrain(300, 200, 1);
  testing::write_tiles(dem, 3, 2, dir.path().string());
  auto source = ElevationSource::open(dir.path().string(), blocks_of(1000));
  ASSERT_TRUE(source.ok());
  const ElevationSource& s = **source;
  const Window w{95, 40, 213, 171};
  const auto blocks = s.blocks_in(w);
  std::uint64_t cells = 0;
  std::vector<bool> named(s.block_count(), false);
  for (std::uint64_t b : blocks) named[b] = true;
  for (std::uint64_t b = 0; b < s.block_count(); ++b) {
    const Window c = s.block_cells(b);
    const bool meets =
        std::max(c.col0, w.col0) < std::min(c.col1, w.col1) && std::max(c.row0, w.row0) < std::min(c.row1, w.row1);
    EXPECT_EQ(named[b], meets) << "block " << b;
    cells += c.cell_count();
  }
  EXPECT_EQ(cells, 300u * 200u);  // the blocks tile the mosaic
}

TEST(ElevationSource, AFolderOfHgtTilesIsOneRasterWithSharedEdgesOnce) {
  TempDir dir;
  for (int lat : {46, 47})
    for (int lon : {-122, -121}) testing::write_hgt(dir.path().string(), lat, lon, 1201);
  auto source = ElevationSource::open(dir.path().string());
  ASSERT_TRUE(source.ok()) << source.error().message;
  const DemHeader& h = (*source)->header();
  EXPECT_EQ(h.width, 2401);
  EXPECT_EQ(h.height, 2401);
  EXPECT_EQ(h.georef.epsg, 4326);
  EXPECT_DOUBLE_EQ(h.georef.transform.x_at(0), -122.0);
  EXPECT_DOUBLE_EQ(h.georef.transform.y_at(0), 48.0);
  // Every cell, through the cache, is the tile's own sample.
  BlockCache cache(cache_of(64 << 20));
  auto all = (*source)->read({0, 0, 2401, 2401}, &cache);
  ASSERT_TRUE(all.ok()) << all.error().message;
  auto nw = read_hgt(dir.file("N47W122.hgt"));
  auto se = read_hgt(dir.file("N46W121.hgt"));
  ASSERT_TRUE(nw.ok() && se.ok());
  for (int r = 0; r < 1201; r += 37)
    for (int c = 0; c < 1201; c += 41) {
      const float a = all->elevation.at(c, r), b = nw->elevation.at(c, r);
      EXPECT_TRUE(a == b || (std::isnan(a) && std::isnan(b))) << c << "," << r;
      const float d = all->elevation.at(1200 + c, 1200 + r), e = se->elevation.at(c, r);
      EXPECT_TRUE(d == e || (std::isnan(d) && std::isnan(e))) << c << "," << r;
    }
  // The uncached read of a window across all four tiles gives the same cells.
  auto direct = (*source)->read({1100, 1150, 1300, 1260}, nullptr);
  auto cached = (*source)->read({1100, 1150, 1300, 1260}, &cache);
  ASSERT_TRUE(direct.ok() && cached.ok());
  EXPECT_TRUE(same_cells(direct->elevation, cached->elevation));
}

TEST(ElevationSource, RejectsAMissingTileByDefaultAndReadsItAsVoidsWhenAsked) {
  TempDir dir;
  const Dem dem = georeferenced_terrain(90, 90, 2);
  const auto tiles = testing::write_tiles(dem, 3, 3, dir.path().string());
  std::filesystem::remove(tiles[4]);  // the centre tile, cells 30..59 (the window below meets 30..49)
  auto source = ElevationSource::open(dir.path().string());
  ASSERT_TRUE(source.ok());
  auto away = (*source)->read({0, 0, 25, 25}, nullptr);
  EXPECT_TRUE(away.ok());  // a window that does not need it is served
  auto over = (*source)->read({20, 20, 50, 50}, nullptr);
  ASSERT_FALSE(over.ok());
  EXPECT_EQ(over.error().code, ErrorCode::kNotFound);
  EXPECT_NE(over.error().message.find("no file covers cols 30..49, rows 30..49"), std::string::npos)
      << over.error().message;
  auto lenient = ElevationSource::open(dir.path().string(), missing_as_nodata());
  ASSERT_TRUE(lenient.ok());
  BlockCache cache(cache_of(1 << 20));
  for (BlockCache* c : {static_cast<BlockCache*>(nullptr), &cache}) {
    auto got = (*lenient)->read({20, 20, 50, 50}, c);
    ASSERT_TRUE(got.ok()) << got.error().message;
    EXPECT_TRUE(std::isnan(got->elevation.at(15, 15)));            // cell (35, 35)
    EXPECT_EQ(got->elevation.at(0, 0), dem.elevation.at(20, 20));  // cell (20, 20)
  }
}

TEST(ElevationSource, ATileThatVanishedAfterOpenFailsTheReadNamingIt) {
  TempDir dir;
  const Dem dem = georeferenced_terrain(60, 60, 4);
  const auto tiles = testing::write_tiles(dem, 2, 2, dir.path().string());
  auto source = ElevationSource::open(dir.path().string());
  ASSERT_TRUE(source.ok());
  std::filesystem::remove(tiles[3]);
  BlockCache cache(cache_of(1 << 20));
  auto got = (*source)->read({0, 0, 60, 60}, &cache);
  ASSERT_FALSE(got.ok());
  EXPECT_NE(got.error().message.find("tile_1_1.tif"), std::string::npos) << got.error().message;
  EXPECT_NE(got.error().message.find("block"), std::string::npos) << got.error().message;
  EXPECT_TRUE((*source)->read({0, 0, 25, 25}, &cache).ok());  // the other tiles still serve
}

TEST(ElevationSource, ACorruptTileFailsTheReadNamingTheFileAndBlock) {
  TempDir dir;
  const Dem dem = georeferenced_terrain(600, 300, 6);
  const auto tiles = testing::write_tiles(dem, 2, 1, dir.path().string());
  testing::overwrite_middle(tiles[1]);  // the east tile's compressed pixels
  auto source = ElevationSource::open(dir.path().string());
  ASSERT_TRUE(source.ok()) << source.error().message;
  BlockCache cache(cache_of(4 << 20));
  auto got = (*source)->read({0, 0, 600, 300}, &cache);
  ASSERT_FALSE(got.ok());
  EXPECT_EQ(got.error().code, ErrorCode::kDataError);
  EXPECT_NE(got.error().message.find("tile_0_1.tif"), std::string::npos) << got.error().message;
  EXPECT_NE(got.error().message.find("block"), std::string::npos) << got.error().message;
  EXPECT_TRUE((*source)->read({0, 0, 250, 300}, &cache).ok());  // the west tile is fine
}

TEST(ElevationSource, ImplausibleCheckNamesTheFirstBadCellInRowOrderOnAnyThreads) {
  // The check runs over bands of rows on several threads: whichever finds
  // one first, the error names the first bad cell in reading order, and a
  // void (NaN) is never one.
  TempDir dir;
  Dem dem = georeferenced_terrain(40, 400, 8);
  dem.elevation.at(5, 300) = -3.0e38f;
  dem.elevation.at(33, 70) = 1.0e20f;
  dem.elevation.at(2, 70) = std::numeric_limits<float>::quiet_NaN();
  dem.elevation.at(39, 399) = 2.0e30f;
  const auto tiles = testing::write_tiles(dem, 1, 1, dir.path().string());
  auto source = ElevationSource::open(tiles[0]);
  ASSERT_TRUE(source.ok()) << source.error().message;
  for (unsigned threads : {1u, 2u, 4u}) {
    auto got = (*source)->read({0, 0, 40, 400}, nullptr, nullptr, nullptr, threads);
    ASSERT_FALSE(got.ok());
    EXPECT_NE(got.error().message.find("cell (col 33, row 70) holds 1e+20"), std::string::npos)
        << threads << ": " << got.error().message;
  }
  auto below = (*source)->read({0, 71, 40, 400}, nullptr, nullptr, nullptr, 2);
  ASSERT_FALSE(below.ok());
  EXPECT_NE(below.error().message.find("cell (col 5, row 300)"), std::string::npos) << below.error().message;
  EXPECT_TRUE((*source)->read({0, 0, 40, 69}, nullptr, nullptr, nullptr, 2).ok());  // NaN passes
}

TEST(ElevationSource, ImplausibleElevationsFailTheReadNamingFileBlockAndCell) {
  TempDir dir;
  Dem dem = georeferenced_terrain(200, 100, 8);
  dem.elevation.at(150, 40) = 3.4e38f;  // what a few overwritten bytes of a float file decode to
  const auto tiles = testing::write_tiles(dem, 2, 1, dir.path().string());
  auto source = ElevationSource::open(dir.path().string(), blocks_of(50 * 50));
  ASSERT_TRUE(source.ok()) << source.error().message;
  BlockCache cache(cache_of(4 << 20));
  for (BlockCache* c : {static_cast<BlockCache*>(nullptr), &cache}) {
    auto got = (*source)->read({120, 0, 200, 100}, c);
    ASSERT_FALSE(got.ok());
    EXPECT_EQ(got.error().code, ErrorCode::kDataError);
    const std::string& m = got.error().message;
    EXPECT_NE(m.find("tile_0_1.tif"), std::string::npos) << m;
    EXPECT_NE(m.find("cell (col 150, row 40) holds 3.4e+38"), std::string::npos) << m;
    EXPECT_NE(m.find("[-12000, 9000]"), std::string::npos) << m;
    if (c) {
      EXPECT_NE(m.find("block"), std::string::npos) << m;
    }
    EXPECT_TRUE((*source)->read({0, 0, 100, 100}, c).ok());  // the west tile is fine
  }
  EXPECT_GE(cache.stats().failures, 1u);      // the corrupt block was not kept
  auto scanned = (*source)->scan(1, &cache);  // the load-time check refuses it too
  ASSERT_FALSE(scanned.ok());
  EXPECT_NE(scanned.error().message.find("tile_0_1.tif"), std::string::npos) << scanned.error().message;
  // A single file, read whole in place.
  auto single = ElevationSource::open(tiles[1]);
  ASSERT_TRUE(single.ok());
  auto whole = (*single)->read({0, 0, 100, 100}, nullptr);
  ASSERT_FALSE(whole.ok());
  EXPECT_NE(whole.error().message.find("cell (col 50, row 40)"), std::string::npos) << whole.error().message;
  // A range wide enough for it reads it as it is; one the wrong way round is refused.
  SourceOptions wide;
  wide.valid_max = 3.5e38;
  auto lenient = ElevationSource::open(dir.path().string(), wide);
  ASSERT_TRUE(lenient.ok());
  auto got = (*lenient)->read({120, 0, 200, 100}, &cache);
  ASSERT_TRUE(got.ok()) << got.error().message;
  EXPECT_EQ(got->elevation.at(30, 40), 3.4e38f);
  SourceOptions reversed;
  reversed.valid_min = 10;
  reversed.valid_max = -10;
  auto refused = ElevationSource::open(dir.path().string(), reversed);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().field, "valid_range");
}

// Found by fuzz_raster: a file with one internal block was cut into bands
// of rows, and for a TIFF of one strip every band decoded the whole strip
// again. Such a TIFF is one block; an .hgt, whose rows read alone, is cut.
TEST(ElevationSource, ATiffOfOneStripIsOneBlockAndAnHgtIsCutIntoBands) {
  TempDir dir;
  const Dem dem = georeferenced_terrain(300, 200, 9);
  const std::string tiled = dir.file("tiled.tif"), strip = dir.file("strip.tif");
  ASSERT_TRUE(write_geotiff(tiled, dem.elevation, dem.georef, std::nullopt).ok());
  const auto made = testing::run_command("gdal_translate -q -co TILED=NO -co BLOCKYSIZE=200 -co COMPRESS=DEFLATE " +
                                         tiled + " " + strip);
  ASSERT_EQ(made.exit_code, 0) << made.output;
  auto source = ElevationSource::open(strip, blocks_of(64 * 64));
  ASSERT_TRUE(source.ok()) << source.error().message;
  EXPECT_EQ((*source)->block_count(), 1u);
  SourceReadStats stats;
  BlockCache cache(cache_of(4 << 20));
  auto got = (*source)->read({10, 10, 30, 30}, &cache, nullptr, &stats);
  ASSERT_TRUE(got.ok()) << got.error().message;
  EXPECT_EQ(stats.cache.misses, 1u);  // the strip, decoded once
  EXPECT_EQ(got->elevation.at(0, 0), dem.elevation.at(10, 10));
  testing::write_hgt(dir.path().string(), 46, -122, 1201);
  auto hgt = ElevationSource::open(dir.file("N46W122.hgt"), blocks_of(64 * 64));
  ASSERT_TRUE(hgt.ok()) << hgt.error().message;
  EXPECT_GT((*hgt)->block_count(), 1u);  // bands of rows
}

TEST(ElevationSource, RejectsFilesNotOnOneGrid) {
  const Dem dem = georeferenced_terrain(40, 40, 8);
  {
    TempDir dir;
    testing::write_tiles(dem, 2, 1, dir.path().string());
    Georeference off = dem.georef;
    off.transform.origin_x += 3.5;  // a third of a cell off the grid
    ASSERT_TRUE(write_geotiff(dir.file("z_off.tif"), dem.elevation, off, std::nullopt).ok());
    auto s = ElevationSource::open(dir.path().string());
    ASSERT_FALSE(s.ok());
    EXPECT_NE(s.error().message.find("z_off.tif"), std::string::npos) << s.error().message;
    EXPECT_NE(s.error().message.find("one grid"), std::string::npos) << s.error().message;
  }
  {
    TempDir dir;
    testing::write_tiles(dem, 2, 1, dir.path().string());
    Georeference coarse = dem.georef;
    coarse.transform.pixel_width = 20.0;
    ASSERT_TRUE(write_geotiff(dir.file("z_coarse.tif"), dem.elevation, coarse, std::nullopt).ok());
    auto s = ElevationSource::open(dir.path().string());
    ASSERT_FALSE(s.ok());
    EXPECT_NE(s.error().message.find("z_coarse.tif"), std::string::npos);
    EXPECT_NE(s.error().message.find("cell size"), std::string::npos) << s.error().message;
  }
  {
    TempDir dir;
    testing::write_tiles(dem, 2, 1, dir.path().string());
    Georeference other = dem.georef;
    other.epsg = 32634;
    ASSERT_TRUE(write_geotiff(dir.file("z_crs.tif"), dem.elevation, other, std::nullopt).ok());
    auto s = ElevationSource::open(dir.path().string());
    ASSERT_FALSE(s.ok());
    EXPECT_NE(s.error().message.find("EPSG:32634"), std::string::npos) << s.error().message;
  }
}

TEST(ElevationSource, RejectsAnEmptyFolderAndAMissingPath) {
  TempDir dir;
  std::ofstream(dir.file("README.txt")) << "not a raster";
  auto empty = ElevationSource::open(dir.path().string());
  ASSERT_FALSE(empty.ok());
  EXPECT_NE(empty.error().message.find("no .tif, .tiff or .hgt file"), std::string::npos);
  auto missing = ElevationSource::open(dir.file("nope"));
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.error().code, ErrorCode::kNotFound);
}

}  // namespace
}  // namespace horizon::terrain
