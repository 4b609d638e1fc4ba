// Agreement measures on literal grids with hand-counted answers.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "horizon/visibility/agreement.hpp"

namespace horizon {
namespace {

visibility::ViewshedResult literal(const std::vector<float>& ohf) {
  visibility::ViewshedResult r;
  r.frame.window = {0, 0, 5, 5};
  r.frame.observer_col = 0;
  r.frame.observer_row = 0;
  r.ohf = terrain::Grid<float>(5, 5);
  r.terrain = terrain::Grid<float>(5, 5, 0.0f);
  for (int i = 0; i < 25; ++i) r.ohf.values()[i] = ohf[i];
  return r;
}

TEST(Agreement, CountsMissedExtraAndOhfError) {
  const float n = std::numeric_limits<float>::quiet_NaN();
  // Observer at (0,0): cells (0,0), (1,0), (0,1), (1,1) are excluded.
  // OHF <= 0 means the ground (0 m) is visible.
  const auto ref = literal({0, 0, 0, 5, 0,
                            0, 0, 0, 5, 5,
                            0, 0, 0, 0, n,
                            5, 5, 0, 0, 0,
                            0, 0, 0, 0, 0});
  const auto test = literal({0, 0, 0, 5, 5,     // (4,0): extra hidden -> missed visible
                             0, 0, 0, 0, 5,     // (3,1): ref hidden, test visible -> extra
                             0, 0, 0, 0, 0,     // (4,2): ref has no answer -> skipped
                             5, 5, 0, 0, 0,
                             0, 0, 0, 0, 3});   // (4,4): missed, OHF error 3 m
  const auto a = visibility::compare_viewsheds(test, ref, 0.0);
  EXPECT_EQ(a.cells_compared, 25u - 4u - 1u);
  EXPECT_EQ(a.reference_visible, 20u - 5u);  // (3,0) (3,1) (4,1) (0,3) (1,3) hidden in ref
  EXPECT_EQ(a.missed_visible, 2u);
  EXPECT_EQ(a.extra_visible, 1u);
  EXPECT_EQ(a.both_visible, 13u);
  EXPECT_DOUBLE_EQ(a.iou, 13.0 / 16.0);
  EXPECT_DOUBLE_EQ(a.missed_rate, 2.0 / 15.0);
  EXPECT_DOUBLE_EQ(a.extra_rate, 1.0 / 15.0);
  EXPECT_DOUBLE_EQ(a.ohf_max_error, 5.0);
  EXPECT_NEAR(a.ohf_rmse, std::sqrt((25.0 + 25.0 + 9.0) / 20.0), 1e-12);
}

TEST(Agreement, IdenticalResultsAgreeFully) {
  const auto r = literal(std::vector<float>(25, 1.0f));
  const auto a = visibility::compare_viewsheds(r, r, 0.0);
  EXPECT_EQ(a.missed_visible + a.extra_visible, 0u);
  EXPECT_DOUBLE_EQ(a.iou, 1.0);  // nothing visible at all: defined as full agreement
  EXPECT_DOUBLE_EQ(a.agreement, 1.0);
  EXPECT_DOUBLE_EQ(a.ohf_rmse, 0.0);
}

}  // namespace
}  // namespace horizon
