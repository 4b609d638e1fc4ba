// compute_viewshed_taking_elevation: the same answer as compute_viewshed,
// with the DEM's grid handed over instead of copied only when the window
// covers it, and the DEM left whole otherwise and on errors; and a run that
// is asked for its visibility mask alone (mask_only).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <vector>

#include "horizon/visibility/view_frame.hpp"
#include "horizon/visibility/viewshed_outputs.hpp"
#include "visibility_test_util.hpp"

namespace horizon {
namespace {

using testing::eye_at;
using testing::grid_dem;

terrain::Dem hills() {
  return grid_dem(61, 47, [](int c, int r) { return 30.0 * std::sin(c * 0.3) * std::cos(r * 0.2) + 0.5 * c; });
}

void expect_same(const visibility::ViewshedResult& a, const visibility::ViewshedResult& b) {
  ASSERT_EQ(a.frame.window, b.frame.window);
  ASSERT_EQ(a.ohf.size(), b.ohf.size());
  EXPECT_EQ(std::memcmp(a.ohf.data(), b.ohf.data(), a.ohf.size() * sizeof(float)), 0);
  ASSERT_EQ(a.terrain.size(), b.terrain.size());
  EXPECT_EQ(std::memcmp(a.terrain.data(), b.terrain.data(), a.terrain.size() * sizeof(float)), 0);
}

TEST(ViewshedDriver, TakingTheElevationsOfAWholeWindowGivesTheSameResultWithoutACopy) {
  const terrain::Dem reference = hills();
  terrain::Dem dem = hills();
  const float* grid = dem.elevation.data();
  const auto eye = eye_at(dem, 30, 20, 2.0);
  auto copied = visibility::compute_viewshed(reference, eye, {});
  auto taken = visibility::compute_viewshed_taking_elevation(dem, eye, {});
  ASSERT_TRUE(copied.ok() && taken.ok());
  expect_same(*copied, *taken);
  EXPECT_EQ(taken->terrain.data(), grid);  // the DEM's own grid, not a copy
  EXPECT_TRUE(dem.elevation.empty());
  EXPECT_EQ(dem.georef.transform.x_at(3), reference.georef.transform.x_at(3));  // the rest of the DEM stays
}

// Found by fuzz_requests: a max_distance whose square overflows (3.7e263 m)
// made the sweep's set-up cast an infinite reach to int. Any distance past
// the grid answers as no limit does, for every algorithm.
TEST(ViewshedDriver, AMaxDistanceBeyondAllTerrainAnswersAsNoLimit) {
  const terrain::Dem dem = hills();
  const auto eye = eye_at(dem, 30, 20, 2.0);
  for (visibility::Algorithm a : {visibility::Algorithm::kRadial, visibility::Algorithm::kConservative,
                                  visibility::Algorithm::kExact, visibility::Algorithm::kR3}) {
    visibility::ViewshedOptions unlimited;
    unlimited.algorithm = a;
    visibility::ViewshedOptions huge = unlimited;
    huge.max_distance = 3.690094671694659e+263;
    auto a_run = visibility::compute_viewshed(dem, eye, unlimited);
    auto b_run = visibility::compute_viewshed(dem, eye, huge);
    ASSERT_TRUE(a_run.ok() && b_run.ok()) << visibility::algorithm_name(a);
    expect_same(*a_run, *b_run);
  }
}

TEST(ViewshedDriver, AWindowSmallerThanTheGridIsCopiedAndTheDemKept) {
  terrain::Dem dem = hills();
  const auto eye = eye_at(dem, 30, 20, 2.0);
  visibility::ViewshedOptions options;
  options.max_distance = 120.0;  // 12 cells: a window inside the grid
  auto taken = visibility::compute_viewshed_taking_elevation(dem, eye, options);
  ASSERT_TRUE(taken.ok());
  EXPECT_LT(taken->frame.window.cell_count(), dem.elevation.size());
  EXPECT_EQ(dem.elevation.size(), std::size_t{61} * 47);
  expect_same(*visibility::compute_viewshed(dem, eye, options), *taken);
}

TEST(ViewshedDriver, AnErrorLeavesTheElevationsWhereTheyWere) {
  terrain::Dem dem = hills();
  const auto eye = eye_at(dem, 30, 20, 2.0);
  visibility::ViewshedOptions options;
  options.max_distance = -5.0;
  auto taken = visibility::compute_viewshed_taking_elevation(dem, eye, options);
  ASSERT_FALSE(taken.ok());
  EXPECT_EQ(dem.elevation.size(), std::size_t{61} * 47);
}

TEST(ViewshedDriver, FilledVoidsAreHandedOverAsTheFilledGrid) {
  terrain::Dem dem = hills();
  dem.elevation.at(5, 5) = std::nanf("");
  const auto eye = eye_at(dem, 30, 20, 2.0);
  visibility::ViewshedOptions options;
  options.nodata = visibility::NodataPolicy::kFill;
  options.nodata_fill_height = 12.5;
  auto result = visibility::compute_viewshed(dem, eye, options);
  ASSERT_TRUE(result.ok());
  EXPECT_EQ(result->terrain.at(5, 5), 12.5f);
  EXPECT_TRUE(std::isnan(dem.elevation.at(5, 5)));  // the caller's DEM keeps its void
}

// mask_only: the result's mask is the one visibility_mask() makes from an
// ordinary run, with the same counts, whichever road made it: the fast
// sweep coding its cells (no OHF then; a caller's OHF storage stays the
// caller's, only lending its memory to the sweep's transposed east and west
// lines), or an OHF coded afterwards (another algorithm, a field of view,
// another blend); and the recoded rasters match too.
TEST(ViewshedDriver, MaskOnlyGivesTheMaskOfAnOrdinaryRun) {
  terrain::Dem dem = hills();
  // Voids beyond max distance and inside it.
  for (int c = 10; c < 14; ++c) dem.elevation.at(c, 5) = std::numeric_limits<float>::quiet_NaN();
  dem.elevation.at(33, 22) = std::numeric_limits<float>::quiet_NaN();
  const auto eye = eye_at(dem, 30, 20, 2.0);
  struct Case {
    const char* name;
    visibility::ViewshedOptions options;
    bool swept;  // the sweep makes the mask itself
  };
  std::vector<Case> cases;
  visibility::ViewshedOptions o;
  o.max_distance = 220.0;  // 22 cells: the corners are out of range
  o.target_height = 1.5;
  cases.push_back({"fast", o, true});
  visibility::ViewshedOptions exact = o;
  exact.algorithm = visibility::Algorithm::kExact;
  exact.visibility_only = true;
  cases.push_back({"exact", exact, false});
  visibility::ViewshedOptions view = o;
  view.field_of_view.azimuth_start = 300;
  view.field_of_view.azimuth_end = 60;
  cases.push_back({"field of view", view, false});
  visibility::ViewshedOptions linear = o;
  linear.radial.blend = visibility::RayBlend::kLinear;
  cases.push_back({"linear blend", linear, false});
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    auto ordinary = visibility::compute_viewshed(dem, eye, c.options);
    ASSERT_TRUE(ordinary.ok());
    visibility::AnswerCounts expected;
    const auto want = visibility::visibility_mask(*ordinary, c.options.target_height, 1, &expected);
    visibility::ViewshedOptions masked = c.options;
    masked.mask_only = true;
    terrain::Grid<float> storage(5, 4, 42.0f);
    auto got = visibility::compute_viewshed(dem, eye, masked, nullptr, nullptr, nullptr, {.ohf = &storage});
    ASSERT_TRUE(got.ok());
    ASSERT_TRUE(got->mask.has_value());
    EXPECT_EQ(got->mask->values().size(), want.values().size());
    EXPECT_TRUE(std::equal(want.values().begin(), want.values().end(), got->mask->values().begin()));
    EXPECT_EQ(got->mask_counts.visible, expected.visible);
    EXPECT_EQ(got->mask_counts.hidden, expected.hidden);
    EXPECT_EQ(got->mask_counts.out_of_range, expected.out_of_range);
    EXPECT_EQ(got->mask_counts.nodata, expected.nodata);
    EXPECT_GT(expected.out_of_range, 0u);
    EXPECT_GT(expected.nodata, 0u);
    EXPECT_EQ(got->ohf.empty(), c.swept);
    if (c.swept) {  // the storage stayed the caller's, holding the sweep's east and west lines
      EXPECT_GE(storage.size(), got->frame.window.cell_count());
    }
    // Other codes, from the mask alone when there is no OHF.
    const visibility::ValueCodes codes{.visible = 7, .hidden = 3, .out_of_range = 9, .nodata = 200};
    visibility::AnswerCounts ordinary_counts, mask_counts;
    const auto a = visibility::visibility_codes(*ordinary, c.options.target_height, codes, 1, &ordinary_counts);
    const auto b = visibility::visibility_codes(*got, c.options.target_height, codes, 1, &mask_counts);
    EXPECT_TRUE(std::equal(a.values().begin(), a.values().end(), b.values().begin()));
    EXPECT_EQ(mask_counts.visible, ordinary_counts.visible);
    EXPECT_EQ(mask_counts.nodata, ordinary_counts.nodata);
    EXPECT_EQ(mask_counts.out_of_range, ordinary_counts.out_of_range);
  }
}

TEST(ViewshedDriver, ResetOutputLeavesEveryCellNoAnswerWhetherItReusesTheGridOrNot) {
  for (const unsigned threads : {1u, 2u, 0u}) {
    terrain::Grid<float> ohf(7, 3, 5.0f);
    const terrain::Window big{10, 20, 10 + 1100, 20 + 1300};  // 1.4 M cells: a new, mapped grid, many bands
    visibility::reset_output(ohf, big, threads);
    ASSERT_EQ(ohf.width(), 1100);
    ASSERT_EQ(ohf.height(), 1300);
    for (const float v : ohf.values()) ASSERT_TRUE(std::isnan(v));
    for (float& v : ohf.values()) v = 1.0f;
    visibility::reset_output(ohf, big, threads);  // same size: the storage is reused
    for (const float v : ohf.values()) ASSERT_TRUE(std::isnan(v));
  }
}

}  // namespace
}  // namespace horizon
