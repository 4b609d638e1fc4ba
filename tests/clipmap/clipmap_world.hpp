// The clip-map tests' world: a 1000 x 700 random terrain at 30 m cut into
// 2 x 2 GeoTIFF tiles, opened as a mosaic, with its source pyramid and every
// pyramid level read whole as the reference.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <vector>

#include "horizon/clipmap/clipmap.hpp"
#include "horizon/clipmap/clipmap_updater.hpp"
#include "test_support.hpp"

namespace horizon::testing {

using clipmap::Clipmap;
using clipmap::ClipmapShape;
using clipmap::ClipmapUpdater;
using clipmap::pyramid_options_for;
using clipmap::UpdaterOptions;
using terrain::BlockCache;
using terrain::ElevationSource;
using terrain::Grid;
using terrain::Reduction;
using terrain::SourcePyramid;

inline constexpr int kWidth = 1000, kHeight = 700;

inline ClipmapShape small_shape(Reduction reduction = Reduction::kMean) {
  ClipmapShape s;
  s.levels = 4;  // level 3: 125 x 88 cells, full extent
  s.level_size = 128;
  s.subtile = 16;
  s.reduction = reduction;
  return s;
}

inline BlockCache::Options cache_options() {
  BlockCache::Options o;
  o.budget_bytes = 64 << 20;
  o.io_threads = 2;
  return o;
}

// A 1000 x 700 terrain cut into 2 x 2 GeoTIFF tiles, opened as a mosaic, with
// every pyramid level read whole as the reference.
struct ClipWorld {
  TempDir dir;
  terrain::Dem dem = make_random_terrain(kWidth, kHeight, 5, 600.0, 30.0);
  std::shared_ptr<const ElevationSource> source;
  BlockCache cache{cache_options()};
  std::shared_ptr<const SourcePyramid> pyramid;
  std::vector<Grid<float>> levels;

  // `voids`: cells made NaN (no terrain) before the tiles are written.
  explicit ClipWorld(const ClipmapShape& shape = small_shape(), terrain::Window voids = {}) {
    for (int r = voids.row0; r < voids.row1; ++r)
      for (int c = voids.col0; c < voids.col1; ++c) dem.elevation.at(c, r) = std::numeric_limits<float>::quiet_NaN();
    dem.georef.epsg = 32633;
    dem.georef.transform = {500000.0, 30.0, 5000000.0, -30.0};
    write_tiles(dem, 2, 2, dir.path().string());
    terrain::SourceOptions options;
    options.block_cells = 128 * 128;
    auto opened = ElevationSource::open(dir.path().string(), options);
    EXPECT_TRUE(opened.ok()) << opened.error().message;
    source = *opened;
    auto made = SourcePyramid::make(source, cache, shape.reduction, pyramid_options_for(shape));
    EXPECT_TRUE(made.ok()) << made.error().message;
    pyramid = *made;
    for (int k = 0; k < shape.levels; ++k)
      levels.push_back(*pyramid->read(k, {0, 0, pyramid->level_width(k), pyramid->level_height(k)}));
  }

  std::shared_ptr<Clipmap> map(const ClipmapShape& shape = small_shape()) const {
    auto made = Clipmap::make(kWidth, kHeight, shape);
    EXPECT_TRUE(made.ok()) << made.error().message;
    return *made;
  }
  ClipmapUpdater updater(std::shared_ptr<Clipmap> m, UpdaterOptions options = {}) const {
    options.lead_seconds = 0.0;
    auto made = ClipmapUpdater::make(std::move(m), pyramid, options);
    EXPECT_TRUE(made.ok()) << made.error().message;
    return std::move(*made);
  }
  // Levels 0 and 1 of `m` left at the far corner (990, 690) and the coarser
  // levels brought to (col, row): the terrain around (col, row) then comes
  // from levels 2 and 3, and samples there fall back.
  void lag_finest_levels(const std::shared_ptr<Clipmap>& m, double col, double row) const {
    ClipmapUpdater all = updater(m);
    ASSERT_TRUE(all.update_all({.col = 990.0, .row = 690.0}).ok());
    UpdaterOptions lagging;
    lagging.every = {1000, 1000, 1, 1};
    ClipmapUpdater slow = updater(m, lagging);
    ASSERT_TRUE(slow.update({.col = 990.0, .row = 690.0}).ok());  // first pose: every level in place
    ASSERT_TRUE(slow.update({.col = col, .row = row}).ok());      // only levels 2 and 3 follow
  }
  // The reference bilinear sample of level k at source coordinates, as ClipmapReader::sample defines it.
  float bilinear(int k, double col, double row) const {
    const Grid<float>& g = levels[static_cast<std::size_t>(k)];
    const double s = 1.0 / (1 << k);
    const double u = (col + 0.5) * s - 0.5, v = (row + 0.5) * s - 0.5;
    const double fi = std::floor(u), fj = std::floor(v);
    const int i0 = std::clamp(int(fi), 0, g.width() - 1), i1 = std::clamp(int(fi) + 1, 0, g.width() - 1);
    const int j0 = std::clamp(int(fj), 0, g.height() - 1), j1 = std::clamp(int(fj) + 1, 0, g.height() - 1);
    const double a = u - fi, b = v - fj;
    const float z00 = g.at(i0, j0), z10 = g.at(i1, j0), z01 = g.at(i0, j1), z11 = g.at(i1, j1);
    const double top = z00 + (z10 - z00) * a, bottom = z01 + (z11 - z01) * a;
    return static_cast<float>(top + (bottom - top) * b);
  }
};

}  // namespace horizon::testing
