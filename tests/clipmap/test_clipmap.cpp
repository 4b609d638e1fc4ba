// Clip-maps: under random walks of the clip centre (jumps wider than a level,
// diagonals, reversals) every resident sample equals the source pyramid's
// cell at its world position, bit for bit; an update loads exactly the newly
// revealed sub-tiles; slots left behind are never read; samples whose level
// is not resident fall back to the next coarser one; levels follow their
// schedules; a loader thread and readers running together only ever see
// consistent, correct terrain.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstring>
#include <random>
#include <set>
#include <thread>
#include <utility>
#include <vector>

#include "horizon/clipmap/clipmap.hpp"
#include "horizon/clipmap/clipmap_updater.hpp"
#include "clipmap_world.hpp"
#include "visibility/simd.hpp"

namespace horizon::clipmap {
namespace {

using terrain::ElevationSource;
using terrain::Grid;
using terrain::Reduction;
using terrain::SourcePyramid;
using testing::ClipWorld;
using testing::kHeight;
using testing::kWidth;
using testing::small_shape;

// The sub-tiles of level k's window at `o` that lie in the source.
std::set<std::pair<int, int>> window_tiles(const Clipmap& map, int k, const LevelOrigin& o) {
  std::set<std::pair<int, int>> tiles;
  const int t = map.shape().subtile, m = map.shape().level_size / t;
  for (int ty = o.row0 / t; ty < o.row0 / t + m; ++ty)
    for (int tx = o.col0 / t; tx < o.col0 / t + m; ++tx)
      if (tx * t < map.level_width(k) && ty * t < map.level_height(k)) tiles.insert({tx, ty});
  return tiles;
}

// Every resident cell of every level equals the reference; returns the number checked.
std::uint64_t check_resident_cells(const ClipWorld& world, const Clipmap& map) {
  ClipmapReader view(map);
  std::uint64_t checked = 0;
  for (int k = 0; k < map.shape().levels; ++k) {
    const LevelState state = view.level(k);
    const Grid<float>& want = world.levels[static_cast<std::size_t>(k)];
    for (int j = state.origin.row0; j < std::min(state.origin.row0 + map.shape().level_size, want.height()); ++j)
      for (int i = state.origin.col0; i < std::min(state.origin.col0 + map.shape().level_size, want.width()); ++i) {
        if (!view.resident(k, i, j)) continue;
        ++checked;
        const float got = view.cell(k, i, j);
        if (got != want.at(i, j)) {
          ADD_FAILURE() << "level " << k << " cell (" << i << ", " << j << "): " << got << " != " << want.at(i, j);
          return checked;
        }
      }
  }
  return checked;
}

TEST(Clipmap, ShapesOutOfRangeAreRefusedNamingTheField) {
  auto refused = [](ClipmapShape s, int w = kWidth, int h = kHeight) {
    auto made = Clipmap::make(w, h, s);
    return made.ok() ? Error{} : made.error();
  };
  ClipmapShape s = small_shape();
  s.levels = 0;
  EXPECT_EQ(refused(s).field, "clipmap.levels");
  s = small_shape();
  s.level_size = 100;
  EXPECT_EQ(refused(s).field, "clipmap.level_size");
  s = small_shape();
  s.subtile = 128;  // > level_size / 2
  EXPECT_EQ(refused(s).field, "clipmap.subtile");
  s = small_shape();
  s.levels = 2;  // 128 << 1 = 256 cells < 1000
  const Error e = refused(s);
  EXPECT_EQ(e.field, "clipmap.levels");
  EXPECT_NE(e.message.find("use at least 4 levels"), std::string::npos) << e.message;
  s = small_shape();
  EXPECT_EQ(refused(s, 1 << 20, 1 << 20).code, ErrorCode::kInvalidArgument);  // 10 levels of 128 reach 65 536
}

TEST(Clipmap, RandomWalksKeepEveryResidentSampleEqualToTheSourceAndLoadOnlyWhatIsRevealed) {
  ClipWorld world;
  auto map = world.map();
  ClipmapUpdater updater = world.updater(map);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> small(-60.0, 60.0);
  double col = 500.0, row = 350.0;
  std::uint64_t checked = 0;
  std::vector<LevelOrigin> before(4);
  for (int step = 0; step < 60; ++step) {
    if (step % 10 == 7) {  // a jump wider than any partial level
      col = std::uniform_real_distribution<double>(-50.0, kWidth + 50.0)(rng);
      row = std::uniform_real_distribution<double>(-50.0, kHeight + 50.0)(rng);
    } else if (step % 10 == 3) {  // a reversal of the last few moves
      col = 1000.0 - col;
      row = 700.0 - row;
    } else {  // diagonal drift
      col += small(rng);
      row += small(rng);
    }
    {
      ClipmapReader view(*map);
      for (int k = 0; k < 4; ++k) before[static_cast<std::size_t>(k)] = view.level(k).origin;
    }
    const bool first = step == 0;
    auto report = updater.update_all({.col = col, .row = row});
    ASSERT_TRUE(report.ok()) << report.error().message;
    std::uint64_t revealed = 0;
    {
      ClipmapReader view(*map);
      for (int k = 0; k < 4; ++k) {
        const LevelOrigin now = view.level(k).origin;
        EXPECT_EQ(now, map->origin_for(k, col, row)) << "level " << k;
        const auto tiles = window_tiles(*map, k, now);
        EXPECT_EQ(view.level(k).resident_subtiles, tiles.size()) << "level " << k << " is complete";
        const auto old = window_tiles(*map, k, before[static_cast<std::size_t>(k)]);
        for (const auto& tile : tiles) revealed += first || !old.count(tile);
      }
    }
    EXPECT_EQ(report->subtiles_loaded, revealed) << "step " << step;
    checked += check_resident_cells(world, *map);
  }
  EXPECT_GT(checked, 60u * 3u * 128u * 64u);
}

TEST(Clipmap, SlotsLeftBehindAreNeverReadAndSamplesFallBackToTheNextCoarserLevel) {
  ClipWorld world;
  auto map = world.map();
  ClipmapUpdater updater = world.updater(map);
  ASSERT_TRUE(updater.update_all({.col = 100.0, .row = 100.0}).ok());
  {
    ClipmapReader view(*map);
    ASSERT_TRUE(view.resident(0, 100, 100));
  }
  // Move level 0 by exactly one level width: every slot is now another world sub-tile.
  ASSERT_TRUE(updater.update_all({.col = 100.0 + 128.0, .row = 100.0}).ok());
  ClipmapReader view(*map);
  EXPECT_FALSE(view.resident(0, 100, 100)) << "the slot holds (228, 100) now";
  EXPECT_TRUE(view.resident(0, 228, 100));
  // (100, 100) is outside level 0 now: the sample comes from level 1, whose window still holds it.
  SampleStats stats;
  int used = -1;
  const float z = view.sample(0, 100.0, 100.0, stats, &used);
  EXPECT_EQ(used, 1);
  EXPECT_EQ(stats.fallbacks, 1u);
  EXPECT_EQ(z, world.bilinear(1, 100.0, 100.0));
  // Far away only the full-extent level holds the terrain.
  const float far = view.sample(0, 990.0, 690.0, stats, &used);
  EXPECT_EQ(used, 3);
  EXPECT_EQ(far, world.bilinear(3, 990.0, 690.0));
  // In the window, level 0 itself, equal to the source.
  const float near = view.sample(0, 230.25, 101.5, stats, &used);
  EXPECT_EQ(used, 0);
  EXPECT_EQ(near, world.bilinear(0, 230.25, 101.5));
  // Outside the source: no terrain.
  EXPECT_TRUE(std::isnan(view.sample(0, -3.0, 10.0, stats)));
  // Every sample over the whole source is finite: the NaN poison of unwritten slots never shows.
  for (double r = 0.0; r < kHeight; r += 7.3)
    for (double c = 0.0; c < kWidth; c += 7.7)
      ASSERT_TRUE(std::isfinite(view.sample(0, c, r, stats, &used))) << c << ", " << r;
}

// Level k's update to `origin` with every other missing sub-tile (half a move).
LevelUpdate half_update(const ClipWorld& world, const Clipmap& map, int k, const LevelOrigin& origin) {
  LevelUpdate update{k, origin, 0, {}, {}};
  const int t = map.shape().subtile;
  const Grid<float>& level = world.levels[static_cast<std::size_t>(k)];
  const auto missing = map.missing_subtiles(k, origin);
  for (std::size_t i = 0; i < missing.size(); i += 2) {
    update.keys.push_back(missing[i]);
    for (int r = 0; r < t; ++r)
      for (int c = 0; c < t; ++c) {
        const int col = missing[i].tx * t + c, row = missing[i].ty * t + r;
        update.samples.push_back(col < level.width() && row < level.height() ? level.at(col, row) : NAN);
      }
  }
  return update;
}

using visibility::sweep::simd::Isa;

TEST(Clipmap, SamplingManyPointsAtOnceEqualsSamplingEachBitForBit) {
  ClipWorld world;
  auto map = world.map();
  ClipmapUpdater updater = world.updater(map);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> cols(-20.0, kWidth + 20.0), rows(-20.0, kHeight + 20.0);
  std::uint64_t fast_levels = 0, partial_levels = 0, fallbacks = 0, lowest_checked = 0;
  for (int step = 0; step < 24; ++step) {
    const double col = cols(rng), row = rows(rng);
    if (step % 3 == 2) {
      // Levels 0 and 1 half moved: incomplete, with slots left behind.
      for (int k = 0; k < 2; ++k) map->publish(half_update(world, *map, k, map->origin_for(k, col, row)));
    } else {
      ASSERT_TRUE(updater.update_all({.col = col, .row = row}).ok());
    }
    ClipmapReader view(*map);
    for (int k = 0; k < map->shape().levels; ++k) {
      // Points around the clip centre (in and past the level's window) and anywhere on the map.
      std::vector<double> xs, ys;
      std::normal_distribution<double> near_x(col, 40.0 * (1 << k)), near_y(row, 40.0 * (1 << k));
      for (int i = 0; i < 3000; ++i) {
        xs.push_back(i % 3 ? near_x(rng) : cols(rng));
        ys.push_back(i % 3 ? near_y(rng) : rows(rng));
      }
      xs.push_back(-0.5), ys.push_back(-0.5);
      xs.push_back(kWidth - 0.5), ys.push_back(kHeight - 0.5);
      // Every form of the batch sampler this CPU runs: the scalar loop, the AVX2 and AVX-512 ones.
      for (const Isa isa : {Isa::kScalar, Isa::kAvx2, Isa::kAvx512}) {
        if (isa > visibility::sweep::simd::cpu_isa()) continue;
        visibility::sweep::simd::isa_limit() = isa;
        std::vector<float> many(xs.size());
        SampleStats each_stats, many_stats;
        view.sample_many(k, xs.size(), xs.data(), ys.data(), many.data(), many_stats);
        visibility::sweep::simd::isa_limit() = Isa::kAvx512;
        for (std::size_t i = 0; i < xs.size(); ++i) {
          const float one = view.sample(k, xs[i], ys[i], each_stats);
          ASSERT_TRUE(std::memcmp(&one, &many[i], sizeof one) == 0 || (std::isnan(one) && std::isnan(many[i])))
              << "level " << k << " at (" << xs[i] << ", " << ys[i] << "), isa " << static_cast<int>(isa) << ": "
              << many[i] << " != " << one;
        }
        EXPECT_EQ(many_stats.samples, each_stats.samples);
        EXPECT_EQ(many_stats.fallbacks, each_stats.fallbacks);
        fallbacks += many_stats.fallbacks;
      }
      // lowest() over small rectangles inside a complete level's window: the least reference cell.
      const LevelState state = view.level(k);
      if (state.resident_subtiles == window_tiles(*map, k, state.origin).size()) {
        const Grid<float>& ref = world.levels[static_cast<std::size_t>(k)];
        for (int i = 0; i < 200; ++i) {
          const int c0 = static_cast<int>(near_x(rng)), r0 = static_cast<int>(near_y(rng));
          const int c1 = c0 + static_cast<int>(rng() % 9), r1 = r0 + static_cast<int>(rng() % 9);
          const int i0 = std::max(c0, 0) >> k, i1 = std::min(c1, kWidth - 1) >> k;
          const int j0 = std::max(r0, 0) >> k, j1 = std::min(r1, kHeight - 1) >> k;
          const int n = map->shape().level_size;
          if (c1 < 0 || r1 < 0 || c0 >= kWidth || r0 >= kHeight || i0 < state.origin.col0 || i1 >= state.origin.col0 + n ||
              j0 < state.origin.row0 || j1 >= state.origin.row0 + n)
            continue;
          float want = std::numeric_limits<float>::infinity();
          for (int j = j0; j <= j1; ++j)
            for (int ii = i0; ii <= i1; ++ii) want = std::min(want, ref.at(ii, j));
          SampleStats lowest_stats;
          ASSERT_EQ(view.lowest(k, c0, r0, c1, r1, lowest_stats), want) << "level " << k << " at " << c0 << ", " << r0;
          ++lowest_checked;
        }
      }
      (view.level(k).resident_subtiles == window_tiles(*map, k, view.level(k).origin).size() ? fast_levels
                                                                                             : partial_levels)++;
    }
  }
  // Both kinds of level, and samples that fell back, were met.
  EXPECT_GT(fast_levels, 20u);
  EXPECT_GT(partial_levels, 8u);
  EXPECT_GT(fallbacks, 1000u);
  EXPECT_GT(lowest_checked, 1000u);
}

TEST(Clipmap, LevelsFollowTheirOwnSchedules) {
  ClipWorld world;
  auto map = world.map();
  UpdaterOptions options;
  options.every = {2, 4, 8, 1};
  ClipmapUpdater updater = world.updater(map, options);
  std::vector<std::vector<int>> published;
  double col = 200.0;
  for (int pose = 1; pose <= 16; ++pose) {
    col += 40.0;  // more than a sub-tile at every partial level each pose
    auto report = updater.update({.col = col, .row = 350.0});
    ASSERT_TRUE(report.ok()) << report.error().message;
    published.push_back(report->levels);
  }
  EXPECT_EQ(published[0], (std::vector<int>{0, 1, 2, 3})) << "the first pose loads every level";
  for (int pose = 2; pose <= 16; ++pose) {
    std::vector<int> want;
    if (pose % 2 == 0) want.push_back(0);
    if (pose % 4 == 0) want.push_back(1);
    if (pose % 8 == 0) want.push_back(2);
    EXPECT_EQ(published[static_cast<std::size_t>(pose - 1)], want) << "pose " << pose;  // level 3 is full extent
  }
  ClipmapReader view(*map);
  EXPECT_EQ(view.level(0).pose, 16u);
  EXPECT_EQ(view.level(2).pose, 16u);
  EXPECT_EQ(view.level(3).pose, 1u);
  EXPECT_EQ(view.level(3).version, 1u);
}

TEST(Clipmap, AMissingTileFailsTheUpdateAndPublishesNothingForThatLevel) {
  ClipWorld world;
  terrain::SourceOptions options;
  options.block_cells = 128 * 128;
  // Reopen the mosaic without its south-east tile.
  std::filesystem::remove(world.dir.file("tile_1_1.tif"));
  auto opened = ElevationSource::open(world.dir.path().string(), options);
  ASSERT_TRUE(opened.ok()) << opened.error().message;
  auto pyramid = SourcePyramid::make(*opened, world.cache, Reduction::kMean, pyramid_options_for(small_shape()));
  ASSERT_TRUE(pyramid.ok());
  auto map = Clipmap::make((*opened)->width(), (*opened)->height(), small_shape());
  ASSERT_TRUE(map.ok()) << map.error().message;
  auto updater = ClipmapUpdater::make(*map, *pyramid, {});
  ASSERT_TRUE(updater.ok());
  auto report = updater->update_all({.col = 100.0, .row = 100.0});
  ASSERT_FALSE(report.ok());
  EXPECT_NE(report.error().message.find("missing"), std::string::npos) << report.error().message;
  ClipmapReader view(**map);
  EXPECT_EQ(view.level(0).version, 1u) << "level 0 lies over present tiles";
  EXPECT_EQ(view.level(3).version, 0u) << "the full-extent level needs the missing tile";
}

TEST(Clipmap, ALoaderThreadAndReadersTogetherOnlyEverSeeCorrectTerrain) {
  ClipWorld world;
  auto map = world.map();
  std::atomic<bool> done{false};
  std::atomic<std::uint64_t> reads{0}, wrong{0};
  std::thread reader([&] {
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> c(0.0, kWidth - 1.0), r(0.0, kHeight - 1.0);
    while (!done.load()) {
      ClipmapReader view(*map);
      SampleStats stats;
      for (int i = 0; i < 200; ++i) {
        const double x = c(rng), y = r(rng);
        int used = -1;
        const float z = view.sample(0, x, y, stats, &used);
        if (used >= 4) continue;  // nothing loaded there yet
        ++reads;
        if (z != world.bilinear(used, x, y)) ++wrong;
      }
    }
  });
  {
    AsyncClipmapUpdater loader(world.updater(map));
    for (int pose = 0; pose < 400; ++pose) {
      loader.post({.col = 50.0 + pose * 2.2, .row = 80.0 + pose * 1.4});
      std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
    loader.wait_idle();
    const LoaderStats stats = loader.stats();
    EXPECT_EQ(stats.posted, 400u);
    EXPECT_EQ(stats.applied + stats.skipped, stats.posted);
    EXPECT_FALSE(stats.last_error.has_value());
    EXPECT_GT(stats.subtiles_loaded, 0u);
  }
  done = true;
  reader.join();
  EXPECT_GT(reads.load(), 0u);
  EXPECT_EQ(wrong.load(), 0u);
  EXPECT_GT(check_resident_cells(world, *map), 0u);
}

}  // namespace
}  // namespace horizon::clipmap
