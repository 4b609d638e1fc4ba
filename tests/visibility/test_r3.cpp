// R3 reference: hand-computed grids with exact answers.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>

#include "horizon/visibility/r3.hpp"
#include "horizon/visibility/viewshed.hpp"
#include "test_support.hpp"
#include "visibility_test_util.hpp"

namespace horizon {
namespace {

using testing::eye_at;
using testing::flat_earth;
using testing::grid_dem;
using testing::ohf_at;
using visibility::Algorithm;

TEST(R3, FlatPlaneIsAllVisible) {
  const auto dem = grid_dem(41, 31, [](int, int) { return 100.0; });
  auto vs = visibility::compute_viewshed(dem, eye_at(dem, 20, 15, 2.0), flat_earth(Algorithm::kR3));
  ASSERT_TRUE(vs.ok()) << vs.error().message;
  const auto mask = visibility::visibility_mask(*vs, 0.0);
  for (std::uint8_t v : mask.values()) ASSERT_EQ(v, visibility::kVisible);
  // The sight line from 102 m down to a cell's centre is above 100 m everywhere
  // before it, so the OHF is below the ground except where nothing blocks.
  const auto mth = visibility::min_target_height(*vs);
  for (float v : mth.values()) ASSERT_EQ(v, 0.0f);
}

// A 10 m wall along column 10 on flat ground at 0 m, eye 2 m up at column 5,
// 10 m cells. Behind the wall the lowest visible point lies on the line from
// the eye over the wall top: OHF(col) = 2 + 8 * (col - 5) / 5, whatever the row.
TEST(R3, WallShadowIsTheLineOverTheWallTop) {
  const auto dem = grid_dem(30, 21, [](int c, int) { return c == 10 ? 10.0 : 0.0; });
  auto vs = visibility::compute_viewshed(dem, eye_at(dem, 5, 10, 2.0), flat_earth(Algorithm::kR3));
  ASSERT_TRUE(vs.ok());
  const auto mask = visibility::visibility_mask(*vs, 0.0);
  for (int row = 0; row < 21; ++row) {
    for (int col = 11; col < 30; ++col) {
      // Only targets whose segment crosses column 10 (all of them: the eye is at column 5).
      EXPECT_NEAR(ohf_at(*vs, col, row), 2.0 + 8.0 * (col - 5) / 5.0, 1e-4) << col << "," << row;
      EXPECT_EQ(mask.at(col, row), visibility::kHidden);
    }
    for (int col = 0; col <= 10; ++col) EXPECT_EQ(mask.at(col, row), visibility::kVisible) << col << "," << row;
  }
  // A 6 m mast at column 20 is still hidden (needs 2 + 8*15/5 = 26 m); a 30 m one is seen.
  EXPECT_EQ(visibility::visibility_mask(*vs, 25.9).at(20, 10), visibility::kHidden);
  EXPECT_EQ(visibility::visibility_mask(*vs, 26.1).at(20, 10), visibility::kVisible);
}

// A roof ridge along column 20 (z = 50 - 2|col - 20| metres, 10 m cells), eye
// 1 m up at column 12 (ground 34 m, eye 35 m). Beyond the ridge the OHF is the
// line from the eye over the ridge crest: 35 + 15 * (col - 12) / 8.
TEST(R3, RidgeAtKnownAngle) {
  const auto dem = grid_dem(40, 25, [](int c, int) { return 50.0 - 2.0 * std::abs(c - 20); });
  auto vs = visibility::compute_viewshed(dem, eye_at(dem, 12, 12, 1.0), flat_earth(Algorithm::kR3));
  ASSERT_TRUE(vs.ok());
  const auto mask = visibility::visibility_mask(*vs, 0.0);
  for (int row = 0; row < 25; ++row) {
    for (int col = 21; col < 40; ++col) {
      EXPECT_NEAR(ohf_at(*vs, col, row), 35.0 + 15.0 * (col - 12) / 8.0, 1e-3) << col << "," << row;
      EXPECT_EQ(mask.at(col, row), visibility::kHidden);
    }
    for (int col = 0; col <= 20; ++col) EXPECT_EQ(mask.at(col, row), visibility::kVisible) << col << "," << row;
  }
}

// Square pyramids are exactly linear along every grid line between nodes, so
// R3 sees the true surface. From the apex of a peak every straight ray down
// the faces is a straight line: all visible. From the bottom of a pit the
// surface is convex: all visible.
TEST(R3, PyramidPeakAndPitAreAllVisible) {
  const auto peak = grid_dem(33, 33, [](int c, int r) { return 500.0 - 5.0 * std::max(std::abs(c - 16), std::abs(r - 16)); });
  const auto pit = grid_dem(33, 33, [](int c, int r) { return 5.0 * std::max(std::abs(c - 16), std::abs(r - 16)); });
  for (const auto* dem : {&peak, &pit}) {
    auto vs = visibility::compute_viewshed(*dem, eye_at(*dem, 16, 16, 0.5), flat_earth(Algorithm::kR3));
    ASSERT_TRUE(vs.ok());
    const auto mask = visibility::visibility_mask(*vs, 0.0);
    for (std::uint8_t v : mask.values()) ASSERT_EQ(v, visibility::kVisible);
  }
}

// From the foot of a peak the far faces are hidden: targets directly behind
// the apex, on the same row, need to be above the line over the apex.
TEST(R3, FarSideOfAPeakIsHidden) {
  const auto dem = grid_dem(41, 21, [](int c, int r) { return 100.0 - 10.0 * std::max(std::abs(c - 20), std::abs(r - 10)); });
  auto vs = visibility::compute_viewshed(dem, eye_at(dem, 12, 10, 2.0), flat_earth(Algorithm::kR3));
  ASSERT_TRUE(vs.ok());
  // Eye: ground 20 m (8 cells from the apex) + 2 m = 22 m; apex 100 m, 8 cells away.
  for (int col = 21; col < 30; ++col)
    EXPECT_NEAR(ohf_at(*vs, col, 10), 22.0 + 78.0 * (col - 12) / 8.0, 1e-3) << col;
}

TEST(R3, CurvatureHidesTheFarPlain) {
  // Flat sea-level plain with 1 km cells, eye 10 m up: the geometric horizon
  // with GDAL's coefficient is sqrt(2 R h / 0.85714) = 12.2 km.
  const auto dem = grid_dem(60, 3, [](int, int) { return 0.0; }, 1000.0);
  visibility::ViewshedOptions o;
  o.algorithm = Algorithm::kR3;
  auto vs = visibility::compute_viewshed(dem, eye_at(dem, 0, 1, 10.0), o);
  ASSERT_TRUE(vs.ok());
  const auto mask = visibility::visibility_mask(*vs, 0.0);
  for (int col = 2; col <= 12; ++col) EXPECT_EQ(mask.at(col, 1), visibility::kVisible) << col;
  for (int col = 13; col < 60; ++col) EXPECT_EQ(mask.at(col, 1), visibility::kHidden) << col;
  // Slopes of the lowered plain, -c d - 10 / d, peak at d = sqrt(10 / c) =
  // 12.2 km: beyond it the 12 km crossing blocks, so the hidden height grows
  // with distance (d/dD of 10 + D s(12 km) + c D^2 > 0 there).
  const auto mth = visibility::min_target_height(*vs);
  for (int col = 14; col < 59; ++col) EXPECT_LT(mth.at(col, 1), mth.at(col + 1, 1));
}

TEST(R3, VoidsNeverBlockAndGetNoAnswer) {
  auto dem = grid_dem(30, 21, [](int c, int) { return c == 10 ? 10.0 : 0.0; });
  for (int row = 0; row < 21; ++row) dem.elevation.at(10, row) = std::nanf("");  // the wall is a void
  dem.elevation.at(20, 5) = std::nanf("");
  auto vs = visibility::compute_viewshed(dem, eye_at(dem, 5, 10, 2.0), flat_earth(Algorithm::kR3));
  ASSERT_TRUE(vs.ok());
  const auto mask = visibility::visibility_mask(*vs, 0.0);
  EXPECT_EQ(mask.at(20, 5), visibility::kNoAnswer);
  EXPECT_EQ(mask.at(10, 3), visibility::kNoAnswer);
  EXPECT_EQ(mask.at(25, 10), visibility::kVisible);

  // The same wall filled at 10 m blocks again.
  auto filled = flat_earth(Algorithm::kR3);
  filled.nodata = visibility::NodataPolicy::kFill;
  filled.nodata_fill_height = 10.0;
  auto vs2 = visibility::compute_viewshed(dem, eye_at(dem, 5, 10, 2.0), filled);
  ASSERT_TRUE(vs2.ok());
  EXPECT_EQ(visibility::visibility_mask(*vs2, 0.0).at(25, 10), visibility::kHidden);
}

TEST(R3, MaxDistanceLimitsTheWindowAndAnswersOnlyInside) {
  const auto dem = testing::make_random_terrain(80, 60, 7);
  auto full = visibility::compute_viewshed(dem, eye_at(dem, 30, 25, 2.0), flat_earth(Algorithm::kR3));
  auto opts = flat_earth(Algorithm::kR3);
  opts.max_distance = 300.0;  // 10 cells of 30 m
  auto near = visibility::compute_viewshed(dem, eye_at(dem, 30, 25, 2.0), opts);
  ASSERT_TRUE(full.ok() && near.ok());
  EXPECT_EQ(near->frame.window, (terrain::Window{20, 15, 41, 36}));
  int answered = 0;
  for (int row = 15; row < 36; ++row) {
    for (int col = 20; col < 41; ++col) {
      const bool inside = std::hypot(col - 30, row - 25) <= 10.0;
      const float v = ohf_at(*near, col, row);
      if (!inside) {
        EXPECT_TRUE(std::isnan(v)) << col << "," << row;
        continue;
      }
      ++answered;
      EXPECT_EQ(v, ohf_at(*full, col, row)) << col << "," << row;  // exactly the same crossings
    }
  }
  EXPECT_EQ(near->stats.cells_evaluated, static_cast<std::uint64_t>(answered));
  EXPECT_EQ(near->stats.window_cells, 21u * 21u);
}

TEST(R3, CancelledRequestReturnsCancelled) {
  const auto dem = testing::make_random_terrain(200, 200, 3);
  CancelToken token;
  token.cancel();
  RunControl control;
  control.cancel = &token;
  auto vs = visibility::compute_viewshed(dem, eye_at(dem, 100, 100, 2.0), flat_earth(Algorithm::kR3), &control);
  ASSERT_FALSE(vs.ok());
  EXPECT_EQ(vs.error().code, ErrorCode::kCancelled);

  RunControl late;
  late.deadline = std::chrono::steady_clock::now() - std::chrono::seconds(1);
  auto vs2 = visibility::compute_viewshed(dem, eye_at(dem, 100, 100, 2.0), flat_earth(Algorithm::kR3), &late);
  ASSERT_FALSE(vs2.ok());
  EXPECT_EQ(vs2.error().code, ErrorCode::kDeadlineExceeded);
}

}  // namespace
}  // namespace horizon
