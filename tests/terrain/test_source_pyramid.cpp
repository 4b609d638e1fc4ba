// Source pyramids: every level of a mosaic equals brute force over the
// raster it was cut from, for min, max and mean with voids; a read builds
// only the blocks under its window, keeps them in the shared cache (under its
// budget, rebuilt after eviction, built once for concurrent readers); a
// missing or corrupt tile fails only the reads that need it, naming it.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <thread>
#include <vector>

#include "horizon/terrain/source_pyramid.hpp"
#include "test_support.hpp"

namespace horizon::terrain {
namespace {

using testing::TempDir;

constexpr float kInf = std::numeric_limits<float>::infinity();

BlockCache::Options cache_of(std::uint64_t budget) {
  BlockCache::Options o;
  o.budget_bytes = budget;
  o.io_threads = 2;
  return o;
}

SourcePyramidOptions shape_of(int factor, int block_cells, int levels = PyramidShape::kToOneCell) {
  SourcePyramidOptions o;
  o.factor = factor;
  o.block_cells = block_cells;
  o.levels = levels;
  return o;
}

// A 301 x 203 terrain with voids: scattered cells and one 16 x 16 hole
// (whole level-1..4 cells of voids for factor 2, from cell (32, 48)).
Dem terrain_with_voids() {
  Dem dem = testing::make_random_terrain(301, 203, 17, 400.0, 10.0);
  dem.georef.epsg = 32633;
  dem.georef.transform = {500000.0, 10.0, 5000000.0, -10.0};
  for (int k = 0; k < 300; ++k) dem.elevation.at((k * 37) % 301, (k * 53) % 203) = std::nanf("");
  for (int r = 48; r < 64; ++r)
    for (int c = 32; c < 48; ++c) dem.elevation.at(c, r) = std::nanf("");
  return dem;
}

// Cell (i, j) of level `level` by brute force over the raster, by pyramid.hpp's rules.
float brute(const Grid<float>& z, Reduction r, int side, int i, int j) {
  double sum = 0;
  std::uint64_t n = 0;
  float m = r == Reduction::kMin ? kInf : -kInf;
  for (int row = j * side; row < std::min((j + 1) * side, z.height()); ++row)
    for (int col = i * side; col < std::min((i + 1) * side, z.width()); ++col) {
      const float v = z.at(col, row);
      if (r == Reduction::kMin) m = std::min(m, std::isnan(v) ? -kInf : v);
      if (r == Reduction::kMax && v > m) m = v;
      if (r == Reduction::kMean && !std::isnan(v)) {
        sum += v;
        ++n;
      }
    }
  if (r != Reduction::kMean) return m;
  return n ? static_cast<float>(sum / double(n)) : std::nanf("");
}

bool same(float a, float b) {
  return a == b || (std::isnan(a) && std::isnan(b));
}

struct Mosaic {
  TempDir dir;
  Dem dem = terrain_with_voids();
  std::vector<std::string> tiles;
  std::shared_ptr<const ElevationSource> source;

  explicit Mosaic(int n, SourceOptions options = {}) {
    tiles = testing::write_tiles(dem, n, n, dir.path().string());
    options.block_cells = 64 * 64;
    auto opened = ElevationSource::open(dir.path().string(), options);
    if (opened.ok()) source = *opened;
  }
};

TEST(SourcePyramid, EveryLevelOfAMosaicEqualsBruteForceOverTheRaster) {
  Mosaic mosaic(3);
  ASSERT_TRUE(mosaic.source);
  BlockCache cache(cache_of(64 << 20));
  for (Reduction r : {Reduction::kMin, Reduction::kMax, Reduction::kMean})
    for (const auto& [factor, block] : {std::pair{2, 64}, std::pair{4, 64}, std::pair{8, 512}}) {
      auto pyramid = SourcePyramid::make(mosaic.source, cache, r, shape_of(factor, block));
      ASSERT_TRUE(pyramid.ok()) << pyramid.error().message;
      const SourcePyramid& p = **pyramid;
      ASSERT_GE(p.levels(), 2);
      for (int l = 0; l <= p.levels(); ++l) {
        auto got = p.read(l, {0, 0, p.level_width(l), p.level_height(l)});
        ASSERT_TRUE(got.ok()) << got.error().message;
        ASSERT_EQ(got->width(), (301 + p.cell_side(l) - 1) / p.cell_side(l));
        ASSERT_EQ(got->height(), (203 + p.cell_side(l) - 1) / p.cell_side(l));
        int wrong = 0;
        for (int j = 0; j < got->height(); ++j)
          for (int i = 0; i < got->width(); ++i) {
            const float want =
                l == 0 ? mosaic.dem.elevation.at(i, j) : brute(mosaic.dem.elevation, r, p.cell_side(l), i, j);
            wrong += !same(got->at(i, j), want);
          }
        EXPECT_EQ(wrong, 0) << "reduction " << int(r) << " factor " << factor << " level " << l;
      }
    }
  // The hole: a level-4 cell (16 x 16) of voids only.
  auto max = SourcePyramid::make(mosaic.source, cache, Reduction::kMax, shape_of(2, 64));
  auto mean = SourcePyramid::make(mosaic.source, cache, Reduction::kMean, shape_of(2, 64));
  auto min = SourcePyramid::make(mosaic.source, cache, Reduction::kMin, shape_of(2, 64));
  ASSERT_TRUE(max.ok() && mean.ok() && min.ok());
  EXPECT_EQ((*max)->read(4, {2, 3, 3, 4})->at(0, 0), -kInf);
  EXPECT_TRUE(std::isnan((*mean)->read(4, {2, 3, 3, 4})->at(0, 0)));
  EXPECT_EQ((*min)->read(4, {2, 3, 3, 4})->at(0, 0), -kInf);
  EXPECT_TRUE(std::isfinite((*max)->read(4, {3, 3, 4, 4})->at(0, 0)));  // its neighbour has terrain
}

TEST(SourcePyramid, AReadBuildsOnlyTheBlocksUnderItsWindowAndKeepsThemInTheCache) {
  Mosaic mosaic(2);
  ASSERT_TRUE(mosaic.source);
  BlockCache cache(cache_of(64 << 20));
  auto made = SourcePyramid::make(mosaic.source, cache, Reduction::kMean, shape_of(2, 64));
  ASSERT_TRUE(made.ok());
  const SourcePyramid& p = **made;
  EXPECT_EQ(p.block_count(), 5u * 4u);  // 301 x 203 in blocks of 64
  // A corner of level 2 (cells of 4): 10 x 10 cells = source cells 0..39, one block.
  SourcePyramidStats first;
  auto corner = p.read(2, {0, 0, 10, 10}, nullptr, &first);
  ASSERT_TRUE(corner.ok());
  EXPECT_EQ(first.blocks, 1u);
  EXPECT_EQ(first.builds, 1u);
  EXPECT_GE(first.elevation_blocks_decoded, 1u);
  EXPECT_EQ(cache.stats().builds, 1u);
  EXPECT_GT(cache.resident_bytes_of(p.id()), 0u);
  // Another level, same block: a hit, nothing decoded.
  SourcePyramidStats second;
  ASSERT_TRUE(p.read(5, {0, 0, 2, 2}, nullptr, &second).ok());
  EXPECT_EQ(second.hits, 1u);
  EXPECT_EQ(second.builds, 0u);
  EXPECT_EQ(second.elevation_blocks_decoded, 0u);
  // A window across four blocks builds the three it lacks.
  SourcePyramidStats third;
  ASSERT_TRUE(p.read(1, {20, 20, 40, 40}, nullptr, &third).ok());
  EXPECT_EQ(third.blocks, 4u);
  EXPECT_EQ(third.hits, 1u);
  EXPECT_EQ(third.builds, 3u);
  EXPECT_EQ(p.blocks_in(1, {20, 20, 40, 40}).size(), 4u);
  EXPECT_EQ(cache.stats().builds, 4u);
}

TEST(SourcePyramid, TheCacheBudgetHoldsAndEvictedBlocksAreRebuiltTheSame) {
  Mosaic mosaic(2);
  ASSERT_TRUE(mosaic.source);
  // Room for a few blocks only: the 20 pyramid blocks alone (5.4 KB each)
  // exceed it, and the elevation blocks they are built from share it.
  constexpr std::uint64_t kBudget = 48 << 10;
  BlockCache cache(cache_of(kBudget));
  auto made = SourcePyramid::make(mosaic.source, cache, Reduction::kMax, shape_of(2, 64));
  ASSERT_TRUE(made.ok());
  const SourcePyramid& p = **made;
  auto before = p.read(1, {0, 0, 16, 16});
  ASSERT_TRUE(before.ok());
  // Read everything, block by block: the first block is evicted on the way.
  for (int by = 0; by < 4; ++by)
    for (int bx = 0; bx < 5; ++bx) ASSERT_TRUE(p.read(1, {bx * 32, by * 32, bx * 32 + 32, by * 32 + 32}).ok());
  const BlockCacheStats s = cache.stats();
  EXPECT_LE(s.peak_resident_bytes, kBudget);
  EXPECT_GT(s.evictions, 0u);
  SourcePyramidStats again;
  auto after = p.read(1, {0, 0, 16, 16}, nullptr, &again);
  ASSERT_TRUE(after.ok());
  EXPECT_EQ(again.builds, 1u);  // rebuilt
  for (int j = 0; j < 16; ++j)
    for (int i = 0; i < 16; ++i) EXPECT_TRUE(same(after->at(i, j), before->at(i, j)));
  EXPECT_LE(cache.stats().peak_resident_bytes, kBudget);
}

TEST(SourcePyramid, ConcurrentReadersBuildEachBlockOnce) {
  Mosaic mosaic(2);
  ASSERT_TRUE(mosaic.source);
  BlockCache cache(cache_of(64 << 20));
  auto made = SourcePyramid::make(mosaic.source, cache, Reduction::kMin, shape_of(2, 64));
  ASSERT_TRUE(made.ok());
  const SourcePyramid& p = **made;
  const Window all{0, 0, p.level_width(3), p.level_height(3)};
  auto reference = p.read(3, all);  // on another pyramid below, so this one starts cold
  ASSERT_TRUE(reference.ok());
  auto cold = SourcePyramid::make(mosaic.source, cache, Reduction::kMin, shape_of(2, 64));
  ASSERT_TRUE(cold.ok());
  const std::uint64_t builds_before = cache.stats().builds;
  std::atomic<int> equal{0};
  std::vector<std::thread> threads;
  for (int t = 0; t < 6; ++t)
    threads.emplace_back([&] {
      auto got = (*cold)->read(3, all);
      if (!got.ok()) return;
      for (std::size_t k = 0; k < got->size(); ++k)
        if (!same(got->values()[k], reference->values()[k])) return;
      ++equal;
    });
  for (auto& t : threads) t.join();
  EXPECT_EQ(equal.load(), 6);
  EXPECT_EQ(cache.stats().builds - builds_before, (*cold)->block_count());
}

TEST(SourcePyramid, AMissingTileFailsOnlyTheReadsThatNeedItNamingIt) {
  Mosaic mosaic(3);
  ASSERT_TRUE(mosaic.source);
  std::filesystem::remove(mosaic.tiles[4]);  // the centre: cells 100..199 x 67..133
  auto strict = ElevationSource::open(mosaic.dir.path().string());
  ASSERT_TRUE(strict.ok());
  BlockCache cache(cache_of(64 << 20));
  auto made = SourcePyramid::make(*strict, cache, Reduction::kMean, shape_of(2, 64));
  ASSERT_TRUE(made.ok());
  auto over = (*made)->read(1, {60, 40, 70, 45});  // source cells 120..139 x 80..89
  ASSERT_FALSE(over.ok());
  EXPECT_EQ(over.error().code, ErrorCode::kNotFound);
  EXPECT_NE(over.error().message.find("no file covers"), std::string::npos) << over.error().message;
  EXPECT_EQ(cache.resident_bytes_of((*made)->id()), 0u);  // nothing kept for the failed block
  EXPECT_TRUE((*made)->read(1, {0, 0, 30, 30}).ok());     // cells 0..59: another block
  // Read as voids when asked: the mean there is NaN, and outside it is not.
  SourceOptions lenient;
  lenient.missing_as_nodata = true;
  auto open = ElevationSource::open(mosaic.dir.path().string(), lenient);
  ASSERT_TRUE(open.ok());
  auto voids = SourcePyramid::make(*open, cache, Reduction::kMean, shape_of(2, 64));
  ASSERT_TRUE(voids.ok());
  auto got = (*voids)->read(2, {30, 20, 31, 21});  // source cells 120..123 x 80..83
  ASSERT_TRUE(got.ok()) << got.error().message;
  EXPECT_TRUE(std::isnan(got->at(0, 0)));
}

TEST(SourcePyramid, ACorruptTileFailsTheReadNamingTheFile) {
  TempDir dir;
  Dem dem = testing::make_random_terrain(600, 300, 6, 400.0, 10.0);
  dem.georef.epsg = 32633;
  dem.georef.transform = {500000.0, 10.0, 5000000.0, -10.0};
  const auto tiles = testing::write_tiles(dem, 2, 1, dir.path().string());
  testing::overwrite_middle(tiles[1]);  // the east tile's compressed pixels
  auto source = ElevationSource::open(dir.path().string());
  ASSERT_TRUE(source.ok());
  BlockCache cache(cache_of(16 << 20));
  auto made = SourcePyramid::make(*source, cache, Reduction::kMax, shape_of(8, 512));
  ASSERT_TRUE(made.ok());
  auto got = (*made)->read(1, {0, 0, 75, 38});  // the whole raster; its first block spans both tiles
  ASSERT_FALSE(got.ok());
  EXPECT_EQ(got.error().code, ErrorCode::kDataError);
  EXPECT_NE(got.error().message.find("tile_0_1.tif"), std::string::npos) << got.error().message;
}

TEST(SourcePyramid, RejectsOptionsAndWindowsOutOfRangeNamingThem) {
  Mosaic mosaic(2);
  ASSERT_TRUE(mosaic.source);
  BlockCache cache(cache_of(1 << 20));
  auto factor = SourcePyramid::make(mosaic.source, cache, Reduction::kMax, shape_of(3, 64));
  ASSERT_FALSE(factor.ok());
  EXPECT_EQ(factor.error().field, "factor");
  auto block = SourcePyramid::make(mosaic.source, cache, Reduction::kMax, shape_of(2, 100));
  ASSERT_FALSE(block.ok());
  EXPECT_EQ(block.error().field, "block_cells");
  auto levels = SourcePyramid::make(mosaic.source, cache, Reduction::kMax, shape_of(4, 64, 4));
  ASSERT_FALSE(levels.ok());
  EXPECT_EQ(levels.error().field, "levels");
  EXPECT_NE(levels.error().message.find("1..3"), std::string::npos) << levels.error().message;
  auto ok = SourcePyramid::make(mosaic.source, cache, Reduction::kMax, shape_of(2, 64));
  ASSERT_TRUE(ok.ok());
  EXPECT_EQ((*ok)->levels(), 6);
  auto level = (*ok)->read(7, {0, 0, 1, 1});
  ASSERT_FALSE(level.ok());
  EXPECT_EQ(level.error().field, "level");
  auto outside = (*ok)->read(1, {200, 0, 210, 10});  // level 1 is 151 cells wide
  ASSERT_FALSE(outside.ok());
  EXPECT_EQ(outside.error().code, ErrorCode::kOutOfRange);
  auto clipped = (*ok)->read(1, {140, 95, 200, 200});
  ASSERT_TRUE(clipped.ok());
  EXPECT_EQ(clipped->width(), 11);
  EXPECT_EQ(clipped->height(), 7);
}

}  // namespace
}  // namespace horizon::terrain
