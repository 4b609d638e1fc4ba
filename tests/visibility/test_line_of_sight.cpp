// Line of sight: explained single sight lines, consistent with the viewshed.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "horizon/visibility/line_of_sight.hpp"
#include "horizon/visibility/viewshed.hpp"
#include "test_support.hpp"
#include "visibility_test_util.hpp"

namespace horizon {
namespace {

using testing::eye_at;
using testing::grid_dem;

TEST(LineOfSight, WallBlocksAtItsTop) {
  const auto dem = grid_dem(30, 21, [](int c, int) { return c == 10 ? 10.0 : 0.0; });
  visibility::LosOptions o;
  o.curvature_coefficient = 0;
  auto los = visibility::line_of_sight(dem, eye_at(dem, 5, 10, 2.0), eye_at(dem, 20, 10, 0.0), o);
  ASSERT_TRUE(los.ok()) << los.error().message;
  EXPECT_FALSE(los->visible);
  ASSERT_TRUE(los->first_block.has_value());
  EXPECT_DOUBLE_EQ(los->first_block->col, 10.0);
  EXPECT_DOUBLE_EQ(los->first_block->terrain, 10.0);
  EXPECT_NEAR(los->first_block->distance, 50.0, 1e-9);
  // Sight line at the wall: 2 m falling to 0 m over 150 m, 50 m along.
  EXPECT_NEAR(los->first_block->sight_line, 2.0 - 2.0 * 50.0 / 150.0, 1e-9);
  EXPECT_NEAR(los->distance, 150.0, 1e-9);
  EXPECT_NEAR(los->clearance, (2.0 - 2.0 / 3.0) - 10.0, 1e-9);
  // Columns 6..19 are crossed; the path runs along row 10, which is not crossed.
  EXPECT_EQ(los->profile.size(), 14u);
  for (std::size_t i = 1; i < los->profile.size(); ++i)
    EXPECT_LT(los->profile[i - 1].distance, los->profile[i].distance);
  // CRS coordinates of the crossing: x of column 10's centre.
  EXPECT_DOUBLE_EQ(los->first_block->x, dem.georef.transform.x_at(10));

  // Over the wall with a tall enough mast.
  auto over = visibility::line_of_sight(dem, eye_at(dem, 5, 10, 2.0), eye_at(dem, 20, 10, 40.0), o);
  ASSERT_TRUE(over.ok());
  EXPECT_TRUE(over->visible);
  EXPECT_FALSE(over->first_block.has_value());
}

// The viewshed and a single line of sight answer the same question the same way.
TEST(LineOfSight, AgreesWithTheR3ViewshedEverywhere) {
  const auto dem = testing::make_random_terrain(90, 70, 31);
  const auto eye = eye_at(dem, 44.5, 30.25, 3.0);
  visibility::ViewshedOptions vo;
  vo.algorithm = visibility::Algorithm::kR3;
  auto vs = visibility::compute_viewshed(dem, eye, vo);
  ASSERT_TRUE(vs.ok());
  const auto mask = visibility::visibility_mask(*vs, 0.0);
  std::mt19937 rng(4);
  int checked = 0;
  for (int i = 0; i < 400; ++i) {
    const int col = static_cast<int>(rng() % 90), row = static_cast<int>(rng() % 70);
    if (std::abs(col - 44.5) < 2 && std::abs(row - 30.25) < 2) continue;
    auto los = visibility::line_of_sight(dem, eye, eye_at(dem, col, row, 0.0));
    ASSERT_TRUE(los.ok());
    const float mth = visibility::min_target_height(*vs).at(col, row);
    if (std::abs(mth) < 1e-3f) continue;  // a tie decided by rounding either way
    EXPECT_EQ(los->visible, mask.at(col, row) == visibility::kVisible) << col << "," << row;
    ++checked;
  }
  EXPECT_GT(checked, 300);
}

TEST(LineOfSight, RejectsBadCurvature) {
  const auto dem = grid_dem(10, 10, [](int, int) { return 0.0; });
  visibility::LosOptions o;
  o.curvature_coefficient = -1;
  auto los = visibility::line_of_sight(dem, eye_at(dem, 1, 1, 2), eye_at(dem, 8, 8, 0), o);
  ASSERT_FALSE(los.ok());
  EXPECT_EQ(los.error().field, "curvature_coefficient");
}

}  // namespace
}  // namespace horizon
