// The fast viewshed against exact R3 on the real DEMs bundled in data/dem,
// at summit, ridge, valley and edge observers (tests/accuracy/observer_picks).
//
// Bar of issue #2, pooled over each DEM's four observers: visible-set IoU >=
// 99.0 % and missed-visible <= 0.5 %. Each single observer must stay above
// 97 % IoU: some see only a few dozen cells (Rainier's summit dome: 33), where
// one cell is 3 %. docs/accuracy.md has the per-observer table on all shared DEMs.
#include <gtest/gtest.h>

#include "horizon/geodesy/observer.hpp"
#include "horizon/terrain/dem_reader.hpp"
#include "horizon/visibility/agreement.hpp"
#include "horizon/visibility/viewshed.hpp"
#include "observer_picks.hpp"
#include "test_support.hpp"

namespace horizon {
namespace {

class BundledAccuracy : public ::testing::TestWithParam<const char*> {};

TEST_P(BundledAccuracy, FastMeetsTheBarAgainstR3) {
  auto dem = terrain::read_dem(testing::bundled_dem(GetParam()));
  ASSERT_TRUE(dem.ok()) << dem.error().message;
  std::uint64_t both = 0, missed = 0, extra = 0, ref_visible = 0;
  for (const auto& pick : accuracy::pick_observers(*dem)) {
    auto eye = accuracy::pick_eye(*dem, pick, 2.0);
    ASSERT_TRUE(eye.ok()) << eye.error().message;
    visibility::ViewshedOptions o;
    o.algorithm = visibility::Algorithm::kR3;
    auto exact = visibility::compute_viewshed(*dem, *eye, o);
    o.algorithm = visibility::Algorithm::kRadial;
    auto fast = visibility::compute_viewshed(*dem, *eye, o);
    ASSERT_TRUE(exact.ok() && fast.ok());
    const auto a = visibility::compare_viewsheds(*fast, *exact, 0.0);
    EXPECT_GE(a.iou, 0.97) << pick.kind << " (" << pick.col << "," << pick.row << ")";
    both += a.both_visible;
    missed += a.missed_visible;
    extra += a.extra_visible;
    ref_visible += a.reference_visible;
  }
  ASSERT_GT(ref_visible, 0u);
  EXPECT_GE(double(both) / double(both + missed + extra), 0.99);
  EXPECT_LE(double(missed) / double(ref_visible), 0.005);
}

INSTANTIATE_TEST_SUITE_P(DataDem, BundledAccuracy,
                         ::testing::Values("ecuador_andes_utm17s_10m_383x415.tif",
                                           "everest_summit_voids_srtm3_300x300.tif", "olinda_coast_utm25s_111x111.tif",
                                           "rainier_summit_srtm3_400x400.tif", "zion_canyon_srtm3_465x457.tif"),
                         [](const ::testing::TestParamInfo<const char*>& test) {
                           return testing::dem_name(test.param);
                         });

}  // namespace
}  // namespace horizon
