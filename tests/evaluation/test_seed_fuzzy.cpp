// The seed's own fuzzy projection (evaluation/seed_fuzzy.hpp): a wall hides
// what lies behind it from the whole region and not what lies before it;
// on every bundled DEM and synthetic terrain, for small, large, low and
// high regions, no viewpoint sampled in the region sees a cell it calls
// always hidden (exact R3); wrong options are named.
#include <gtest/gtest.h>

#include <string>

#include "horizon/evaluation/region_check.hpp"
#include "horizon/evaluation/seed_fuzzy.hpp"
#include "horizon/region/region.hpp"
#include "horizon/terrain/dem_reader.hpp"
#include "region_spec.hpp"
#include "test_support.hpp"

namespace horizon::evaluation {
namespace {

using testing::region_over;

// The seed's verdicts as a classification: hidden where it says so, the
// rest undetermined (for evaluation::check_cells).
region::RegionCellsResult as_cells(const region::RegionCellsResult& walls, const SeedFuzzyResult& seed) {
  region::RegionCellsResult r;
  r.window = seed.window;
  r.frame = walls.frame;
  r.codes = seed.codes;
  return r;
}

TEST(SeedFuzzy, AWallHidesWhatLiesBehindItAndNothingBeforeIt) {
  // Flat ground at 0, a wall 100 m high along column 20 (all rows), on
  // 60 x 60 cells of 10 m; the region west of it, columns 5..8, rows
  // 25..35, 2 to 10 m up.
  const terrain::Dem dem = testing::make_dem(
      60, 60, [](int c, int) { return c == 20 ? 100.0 : 0.0; }, 10.0, 0);
  const auto spec = region_over(dem, 5, 25, 8, 35, 2, 10, geodesy::HeightMode::kAbsolute);
  region::RegionOptions options;
  options.curvature_coefficient = 0;
  options.footprint_splits = 1;
  auto walls = region::classify_cells(dem, spec, options);
  ASSERT_TRUE(walls.ok()) << walls.error().message;
  auto seed = seed_fuzzy_hidden(dem, *walls, {.columns = 512, .rows = 512});
  ASSERT_TRUE(seed.ok()) << seed.error().message;
  const auto code = [&](int c, int r) { return seed->codes.at(c - seed->window.col0, r - seed->window.row0); };
  // Behind the wall, in its shadow from every point of the region: the
  // ground before the wall and its near side face the region and make one
  // sub-surface, whose far edge (the top) is a boundary; seen from the
  // region's top, the top is at slopes 0.6 to 0.75 and ground 20 cells
  // behind at -0.03, inside that sub-surface's umbra, which ends at
  // p = 200 m, before it.
  EXPECT_EQ(code(40, 30), 0);
  EXPECT_EQ(code(35, 33), 0);
  // Before it: seen.
  EXPECT_EQ(code(15, 30), 2);
  EXPECT_GT(seed->stats.sub_surfaces, 0u);
  EXPECT_GT(seed->stats.boundary_edges, 0u);
  EXPECT_GT(seed->stats.always_hidden, 300u);
}

struct Case {
  const char* dem;  // bundled file, or "" for synthetic terrain
  double size;      // region side, cells
  double z0, z1;    // above ground
};

class SeedFuzzySound : public ::testing::TestWithParam<Case> {};

TEST_P(SeedFuzzySound, NoSampledViewpointSeesACellItHides) {
  const Case k = GetParam();
  terrain::Dem dem;
  if (*k.dem) {
    auto d = terrain::read_dem(testing::bundled_dem(k.dem));
    ASSERT_TRUE(d.ok()) << d.error().message;
    dem = std::move(*d);
  } else {
    dem = testing::make_random_terrain(160, 160, 7, 300.0, 30.0);
  }
  const double cc = dem.width() / 2.0, cr = dem.height() / 2.0;
  region::RegionOptions options;
  options.target_height = 1.5;
  options.footprint_splits = 1;
  options.max_distance = 60 * 30.0;  // keeps R3's checks short
  const auto spec = region_over(dem, cc - k.size / 2, cr - k.size / 2, cc + k.size / 2, cr + k.size / 2, k.z0, k.z1,
                                geodesy::HeightMode::kAboveGround);
  auto walls = region::classify_cells(dem, spec, options);
  ASSERT_TRUE(walls.ok()) << walls.error().message;
  auto seed = seed_fuzzy_hidden(dem, *walls, {.columns = 512, .rows = 512, .target_height = 1.5});
  ASSERT_TRUE(seed.ok()) << seed.error().message;
  RegionSampling sampling;
  sampling.face_points = 4;
  sampling.interior_points = 24;
  const auto viewpoints = sample_region(dem, spec, walls->frame, sampling);
  const auto check = check_cells(dem, as_cells(*walls, *seed), options, viewpoints, 2500, 0);
  EXPECT_EQ(check.wrong_hidden, 0u);
  EXPECT_GT(check.items_checked, 500u);
  EXPECT_LE(check.hidden_checked, check.sampled_hidden);
  RecordProperty("hidden", std::to_string(seed->stats.always_hidden) + " seed, " +
                               std::to_string(walls->stats.always_hidden) + " walls");
}

INSTANTIATE_TEST_SUITE_P(Dems, SeedFuzzySound,
                         ::testing::Values(Case{"ecuador_andes_utm17s_10m_383x415.tif", 4, 2, 10},
                                           Case{"ecuador_andes_utm17s_10m_383x415.tif", 40, 5, 60},
                                           Case{"rainier_summit_srtm3_400x400.tif", 10, 2, 30},
                                           Case{"zion_canyon_srtm3_465x457.tif", 6, 300, 400},
                                           Case{"everest_summit_voids_srtm3_300x300.tif", 8, 2, 20},
                                           Case{"olinda_coast_utm25s_111x111.tif", 12, 2, 50}, Case{"", 3, 1, 5},
                                           Case{"", 30, 50, 500}),
                         [](const ::testing::TestParamInfo<Case>& p) {
                           return std::string(*p.param.dem ? testing::dem_name(p.param.dem) : "synthetic") + "_" +
                                  std::to_string(static_cast<int>(p.param.size));
                         });

TEST(SeedFuzzy, WrongArraySizesAreNamed) {
  const terrain::Dem dem = testing::make_random_terrain(40, 40, 3, 100.0, 30.0);
  region::RegionOptions options;
  options.footprint_splits = 1;
  auto walls =
      region::classify_cells(dem, region_over(dem, 18, 18, 20, 20, 2, 5, geodesy::HeightMode::kAboveGround), options);
  ASSERT_TRUE(walls.ok());
  auto a = seed_fuzzy_hidden(dem, *walls, {.columns = 4});
  ASSERT_FALSE(a.ok());
  EXPECT_EQ(a.error().field, "columns");
  auto b = seed_fuzzy_hidden(dem, *walls, {.columns = 64, .rows = 10000});
  ASSERT_FALSE(b.ok());
  EXPECT_EQ(b.error().field, "rows");
}

}  // namespace
}  // namespace horizon::evaluation
