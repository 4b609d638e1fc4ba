// From-region visibility: hand-computed verdicts, soundness against exact R3
// from densely sampled viewpoints, and the errors a caller can cause.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <optional>
#include <random>

#include "horizon/evaluation/region_check.hpp"
#include "horizon/region/region.hpp"
#include "horizon/terrain/dem_reader.hpp"
#include "region_spec.hpp"
#include "test_support.hpp"

namespace horizon {
namespace {

using region::Verdict;

using testing::region_over;

Verdict code_at(const region::RegionCellsResult& r, int c, int row) {
  return static_cast<Verdict>(r.codes.at(c - r.window.col0, row - r.window.row0));
}

region::RegionOptions flat(int resolution = 256) {
  region::RegionOptions o;
  o.curvature_coefficient = 0.0;
  o.face_resolution = resolution;
  return o;
}

// Flat ground at 0 with a wall 100 m high along column 20, rows 5..54, on a
// 60 x 60 grid of 10 m cells; the region sits west of it, rows 25..35,
// columns 5..8, 2..10 m up.
terrain::Dem walled() {
  return testing::make_dem(
      60, 60, [](int c, int r) { return (c == 20 && r >= 5 && r < 55) ? 100.0 : 0.0; }, 10.0, 0);
}

TEST(Region, AWallHidesWhatLiesBehindItFromTheWholeRegion) {
  const terrain::Dem dem = walled();
  auto res = region::classify_cells(dem, region_over(dem, 5, 25, 8, 35, 2, 10), flat());
  ASSERT_TRUE(res.ok()) << res.error().message;
  // Right behind the wall, level with the region: every sight line from the
  // region crosses column 20 below 100 m.
  for (int r = 27; r <= 33; ++r) EXPECT_EQ(code_at(*res, 25, r), Verdict::kAlwaysHidden) << "row " << r;
  EXPECT_EQ(code_at(*res, 59, 30), Verdict::kAlwaysHidden);
  // Between the region and the wall, on open flat ground: seen from all of it.
  EXPECT_EQ(code_at(*res, 12, 30), Verdict::kAlwaysVisible);
  EXPECT_EQ(code_at(*res, 2, 30), Verdict::kAlwaysVisible);
  // Past the wall's northern end, in the open: visible from everywhere.
  EXPECT_EQ(code_at(*res, 15, 3), Verdict::kAlwaysVisible);
  // The wall's own top is a target, not a crossing: never hidden.
  EXPECT_NE(code_at(*res, 20, 30), Verdict::kAlwaysHidden);
  // Behind the wall's end, where some of the region looks round it: neither.
  // From (5, 35) the line to (23, 59) passes column 20 at row 55, in the
  // open; from (8, 35) at row 54.2, 80 m up the wall's end.
  EXPECT_EQ(code_at(*res, 23, 59), Verdict::kUndetermined);
  EXPECT_EQ(code_at(*res, 40, 58), Verdict::kAlwaysHidden);  // every line crosses column 20 at rows 39..44
  EXPECT_GT(res->stats.always_hidden, 500u);
  EXPECT_EQ(res->stats.items, res->stats.always_hidden + res->stats.always_visible + res->stats.undetermined);
}

TEST(Region, ARegionAboveTheWallSeesOverIt) {
  const terrain::Dem dem = walled();
  // 200-300 m up: the far ground behind the wall is in view from all of it.
  auto res = region::classify_cells(dem, region_over(dem, 5, 25, 8, 35, 200, 300), flat());
  ASSERT_TRUE(res.ok()) << res.error().message;
  EXPECT_EQ(code_at(*res, 50, 30), Verdict::kAlwaysVisible);
  EXPECT_EQ(code_at(*res, 12, 30), Verdict::kAlwaysVisible);
  // Column 21, 10 m behind the wall, is hidden from all of it (from the
  // nearest, highest corner the line passes the wall at 300 * 10 / 130 = 23 m),
  // but the region is 100 m tall: the fuzzy bound pairs its highest
  // viewpoints with the wall and its lowest with the target, and decides
  // nothing. It must not call it visible.
  EXPECT_NE(code_at(*res, 21, 30), Verdict::kAlwaysVisible);
}

// Soundness: no sampled viewpoint contradicts a verdict, on the bundled DEMs
// and on synthetic terrain, for small and large regions near the ground and high.
struct Case {
  const char* dem;  // bundled file, or "" for synthetic terrain
  double size;      // region side, cells
  double z0, z1;    // above ground
};

class RegionSound : public ::testing::TestWithParam<Case> {};

TEST_P(RegionSound, NoSampledViewpointContradictsAVerdict) {
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
  options.face_resolution = 512;
  options.target_height = 1.5;
  options.max_distance = 60 * 30.0;  // keeps R3's checks short
  auto spec = region_over(dem, cc - k.size / 2, cr - k.size / 2, cc + k.size / 2, cr + k.size / 2, k.z0, k.z1,
                          geodesy::HeightMode::kAboveGround);
  auto res = region::classify_cells(dem, spec, options);
  ASSERT_TRUE(res.ok()) << res.error().message;
  evaluation::RegionSampling sampling;
  sampling.face_points = 4;
  sampling.interior_points = 24;
  const auto viewpoints = evaluation::sample_region(dem, spec, res->frame, sampling);
  const auto check = evaluation::check_cells(dem, *res, options, viewpoints, 2500, 0);
  EXPECT_EQ(check.wrong_hidden, 0u);
  EXPECT_EQ(check.wrong_visible, 0u);
  // The check really ran over many cells; what share the verdicts decide is
  // reported (docs/accuracy.md), not asserted here: on steep real terrain a
  // region 40 cells wide decides little.
  EXPECT_GT(check.items_checked, 500u);
  RecordProperty("decided", std::to_string(check.hidden_checked) + " hidden of " +
                                std::to_string(check.sampled_hidden) + ", " + std::to_string(check.visible_checked) +
                                " visible of " + std::to_string(check.sampled_visible));
  EXPECT_LE(check.hidden_checked, check.sampled_hidden);
  EXPECT_LE(check.visible_checked, check.sampled_visible);
}

INSTANTIATE_TEST_SUITE_P(Dems, RegionSound,
                         ::testing::Values(Case{"ecuador_andes_utm17s_10m_383x415.tif", 4, 2, 10},
                                           Case{"ecuador_andes_utm17s_10m_383x415.tif", 40, 5, 60},
                                           Case{"rainier_summit_srtm3_400x400.tif", 10, 2, 30},
                                           Case{"zion_canyon_srtm3_465x457.tif", 6, 300, 400},
                                           Case{"everest_summit_voids_srtm3_300x300.tif", 8, 2, 20},
                                           Case{"olinda_coast_utm25s_111x111.tif", 12, 2, 50}, Case{"", 3, 1, 5},
                                           Case{"", 30, 50, 500}),
                         [](const ::testing::TestParamInfo<Case>& p) {
                           return std::string(*p.param.dem ? testing::dem_name(p.param.dem) : "synthetic") + "_" +
                                  std::to_string(p.index);
                         });

TEST(Region, APointRegionAgreesWithR3WhereverItDecides) {
  const terrain::Dem dem = testing::make_random_terrain(120, 120, 11, 250.0, 30.0);
  region::RegionOptions options;
  options.max_distance = 50 * 30.0;
  const double c = 60.3, r = 58.7;
  const double ground = terrain::sample_bilinear(dem.elevation, c, r);
  auto spec = region_over(dem, c, r, c, r, ground + 5, ground + 5);
  auto res = region::classify_cells(dem, spec, options);
  ASSERT_TRUE(res.ok()) << res.error().message;
  evaluation::RegionSampling one;
  one.face_points = 0;
  one.interior_points = 0;
  const auto viewpoints = evaluation::sample_region(dem, spec, res->frame, one);
  const auto check = evaluation::check_cells(dem, *res, options, viewpoints, 1u << 20, 0);
  EXPECT_EQ(check.wrong_hidden, 0u);
  EXPECT_EQ(check.wrong_visible, 0u);
  // From one point the hidden test finds most of what R3 hides.
  EXPECT_GT(check.hidden_checked * 10, check.sampled_hidden * 8)
      << "hidden " << check.hidden_checked << "/" << check.sampled_hidden << " visible " << check.visible_checked << "/"
      << check.sampled_visible;
}

TEST(Region, BoxesGetVerdictsThatNoSampledViewpointContradicts) {
  const terrain::Dem dem = testing::make_random_terrain(160, 160, 3, 300.0, 30.0);
  region::RegionOptions options;
  options.face_resolution = 512;
  const double cc = 80, cr = 80;
  auto spec = region_over(dem, cc - 3, cr - 3, cc + 3, cr + 3, 2, 20, geodesy::HeightMode::kAboveGround);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> pos(2, 157), size(0, 3), up(0, 30);
  std::vector<visibility::BoxSpec> boxes;
  const auto& t = dem.georef.transform;
  for (int i = 0; i < 400; ++i) {
    const double c0 = pos(rng), r0 = pos(rng), c1 = std::min(158.0, c0 + size(rng)),
                 r1 = std::min(158.0, r0 + size(rng));
    const double g = terrain::sample_bilinear(dem.elevation, c0, r0);
    visibility::BoxSpec b;
    b.x_min = t.x_at(c0);
    b.x_max = t.x_at(c1);
    b.y_min = std::min(t.y_at(r0), t.y_at(r1));
    b.y_max = std::max(t.y_at(r0), t.y_at(r1));
    b.z_min = g - 5;
    b.z_max = g + up(rng);
    boxes.push_back(b);
  }
  auto res = region::classify_boxes(dem, spec, boxes, options);
  ASSERT_TRUE(res.ok()) << res.error().message;
  ASSERT_EQ(res->verdicts.size(), boxes.size());
  evaluation::RegionSampling sampling;
  sampling.face_points = 4;
  sampling.interior_points = 40;
  const auto check =
      evaluation::check_boxes(dem, *res, boxes, options, evaluation::sample_region(dem, spec, res->frame, sampling), 0);
  EXPECT_EQ(check.wrong_hidden, 0u);
  EXPECT_EQ(check.wrong_visible, 0u);
  EXPECT_GT(check.hidden_checked, 20u);
  EXPECT_EQ(res->stats.items, boxes.size());
}

TEST(Region, CurvatureOnlyEverHidesMore) {
  // Curvature raises occluders relative to every sight line, so a cell hidden
  // without it stays hidden with it; visible verdicts take a margin.
  const terrain::Dem dem = testing::make_random_terrain(160, 160, 9, 200.0, 90.0);
  auto spec = region_over(dem, 70, 70, 76, 76, 2, 10, geodesy::HeightMode::kAboveGround);
  region::RegionOptions no = flat(512), yes = flat(512);
  yes.curvature_coefficient = 2.0;  // exaggerated
  auto a = region::classify_cells(dem, spec, no);
  auto b = region::classify_cells(dem, spec, yes);
  ASSERT_TRUE(a.ok() && b.ok());
  for (int j = 0; j < a->codes.height(); ++j)
    for (int i = 0; i < a->codes.width(); ++i)
      if (a->codes.at(i, j) == 0) {
        EXPECT_EQ(b->codes.at(i, j), 0) << i << "," << j;
      }
  evaluation::RegionSampling sampling;
  sampling.face_points = 2;
  sampling.interior_points = 8;
  const auto check =
      evaluation::check_cells(dem, *b, yes, evaluation::sample_region(dem, spec, b->frame, sampling), 3000, 0);
  EXPECT_EQ(check.wrong_hidden, 0u);
  EXPECT_EQ(check.wrong_visible, 0u);
}

TEST(Region, AFinerFuzzyArrayDecidesAtLeastAsManyHidden) {
  const terrain::Dem dem = testing::make_random_terrain(200, 200, 21, 300.0, 30.0);
  auto spec = region_over(dem, 95, 95, 105, 105, 2, 10, geodesy::HeightMode::kAboveGround);
  std::uint64_t last = 0;
  for (int n : {64, 256, 1024, 4096}) {
    auto res = region::classify_cells(dem, spec, flat(n));
    ASSERT_TRUE(res.ok());
    EXPECT_GE(res->stats.always_hidden + res->stats.always_hidden / 50 + 5, last) << n;
    last = res->stats.always_hidden;
  }
  EXPECT_GT(last, 1000u);
}

// The seed's two-dimensional array (rows of slope) on the same occluders:
// each row grid nests in the next (16 | 256 | 4096), so its hidden cells are
// a subset of the next one's, and all of them of the continuous cover's;
// the visible verdicts do not depend on it. The coarse array loses some.
TEST(Region, TheSeedsSlopeRowsDecideASubsetOfTheContinuousCover) {
  const terrain::Dem dem = testing::make_random_terrain(200, 200, 21, 300.0, 30.0);
  auto spec = region_over(dem, 95, 95, 105, 105, 2, 10, geodesy::HeightMode::kAboveGround);
  auto continuous = region::classify_cells(dem, spec, flat(1024));
  ASSERT_TRUE(continuous.ok());
  const auto hidden = [](const region::RegionCellsResult& r, int i, int j) { return r.codes.at(i, j) == 0; };
  std::optional<region::RegionCellsResult> coarser;
  for (int rows : {16, 256, 4096}) {
    region::RegionOptions o = flat(1024);
    o.fuzzy_rows = rows;
    auto res = region::classify_cells(dem, spec, o);
    ASSERT_TRUE(res.ok()) << res.error().message;
    ASSERT_EQ(res->codes.width(), continuous->codes.width());
    for (int j = 0; j < res->codes.height(); ++j)
      for (int i = 0; i < res->codes.width(); ++i) {
        if (hidden(*res, i, j)) {
          EXPECT_TRUE(hidden(*continuous, i, j)) << rows << " rows, " << i << "," << j;
        }
        if (coarser && hidden(*coarser, i, j)) {
          EXPECT_TRUE(hidden(*res, i, j)) << rows << " rows, " << i << "," << j;
        }
        EXPECT_EQ(res->codes.at(i, j) == 1, continuous->codes.at(i, j) == 1) << rows << " rows, " << i << "," << j;
      }
    if (rows == 16) {
      EXPECT_LT(res->stats.always_hidden, continuous->stats.always_hidden * 9 / 10) << "16 rows lose cells";
    }
    EXPECT_LE(res->stats.always_hidden, continuous->stats.always_hidden);
    coarser = std::move(*res);
  }
  EXPECT_GT(continuous->stats.always_hidden, 1000u);
}

TEST(Region, BadInputsAreRefusedByName) {
  const terrain::Dem dem = walled();
  const region::RegionSpec good = region_over(dem, 5, 25, 8, 35, 2, 10);
  {
    region::RegionSpec s = good;
    s.x_max = s.x_min - 1;
    auto r = region::classify_cells(dem, s, flat());
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error().field, "region.x_max");
  }
  {
    region::RegionSpec s = good;
    s.z_max = std::nan("");
    auto r = region::classify_cells(dem, s, flat());
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error().field, "region.z_max");
  }
  {
    region::RegionSpec s = good;
    s.x_max += 1e6;
    auto r = region::classify_cells(dem, s, flat());
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error().code, ErrorCode::kOutOfRange);
    EXPECT_NE(r.error().message.find("region"), std::string::npos) << r.error().message;
  }
  for (auto [field, edit] : std::vector<std::pair<std::string, std::function<void(region::RegionOptions&)>>>{
           {"face_resolution", [](region::RegionOptions& o) { o.face_resolution = 4; }},
           {"curvature_coefficient", [](region::RegionOptions& o) { o.curvature_coefficient = -1; }},
           {"target_height", [](region::RegionOptions& o) { o.target_height = -1; }},
           {"max_distance", [](region::RegionOptions& o) { o.max_distance = 0; }},
           {"visible_test_budget", [](region::RegionOptions& o) { o.visible_test_budget = 1; }},
           {"fuzzy_rows", [](region::RegionOptions& o) { o.fuzzy_rows = 1; }},
           {"fuzzy_rows", [](region::RegionOptions& o) { o.fuzzy_rows = 70000; }}}) {
    region::RegionOptions o = flat();
    edit(o);
    auto r = region::classify_cells(dem, good, o);
    ASSERT_FALSE(r.ok()) << field;
    EXPECT_EQ(r.error().field, field);
  }
  auto none = region::classify_boxes(dem, good, {}, flat());
  ASSERT_FALSE(none.ok());
  EXPECT_EQ(none.error().field, "boxes");
}

TEST(Region, ThePlanBoundsTheWorkBeforeItStarts) {
  const terrain::Dem dem = walled();
  region::RegionOptions o = flat(256);
  o.max_distance = 100.0;
  auto plan = region::plan_region_cells(dem, region_over(dem, 5, 25, 8, 35, 2, 10), o);
  ASSERT_TRUE(plan.ok());
  // 100 m = 10 cells round the footprint.
  EXPECT_EQ(plan->window.col0, 0);
  EXPECT_EQ(plan->window.col1, 19);
  EXPECT_EQ(plan->window.row0, 15);
  EXPECT_EQ(plan->window.row1, 46);
  EXPECT_EQ(plan->test_work, plan->window.cell_count() * 4096u * 4u);  // 2 x 2 pieces
  auto res = region::classify_cells(dem, region_over(dem, 5, 25, 8, 35, 2, 10), o);
  ASSERT_TRUE(res.ok());
  EXPECT_LE(res->stats.pyramid_cells_read, plan->test_work);
  EXPECT_LE(res->stats.wall_nodes_read, plan->sweep_work);
  // A cell beyond max_distance of the footprint gets no answer even inside the window's corner.
  EXPECT_EQ(res->codes.at(0, 0), region::kNoAnswer);
}

TEST(Region, ACancelledRunReturnsTheCancellation) {
  const terrain::Dem dem = testing::make_random_terrain(200, 200, 1, 300.0, 30.0);
  CancelToken token;
  token.cancel();
  RunControl control;
  control.cancel = &token;
  auto res = region::classify_cells(dem, region_over(dem, 90, 90, 100, 100, 2, 10, geodesy::HeightMode::kAboveGround),
                                    flat(), &control);
  ASSERT_FALSE(res.ok());
  EXPECT_EQ(res.error().code, ErrorCode::kCancelled);
}

// From-region feeding per-frame culling: boxes classified once for a
// drone's path (30 m above the ground) need no test while it flies it. At every pose along the
// path, exact (R3) culling from that pose must agree with every verdict.
TEST(Region, VerdictsForAPathHoldAtEveryPoseAlongIt) {
  auto dem = terrain::read_dem(testing::bundled_dem("ecuador_andes_utm17s_10m_383x415.tif"));
  ASSERT_TRUE(dem.ok()) << dem.error().message;
  const double x0 = 713850, y0 = 9558900, x1 = 713900, y1 = 9558950;  // 71 m in one second
  const region::RegionSpec path =
      region::swept_region(x0, y0, x1, y1, 0.5, 0.5, 30.0, 30.0, geodesy::HeightMode::kAboveGround);
  const auto& t = dem->georef.transform;
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<visibility::BoxSpec> boxes;
  for (int i = 0; i < 400; ++i) {
    const double col = 20 + u(rng) * (dem->width() - 60), row = 20 + u(rng) * (dem->height() - 60);
    const double w = 10 + 30 * u(rng);
    const double ground = dem->elevation.at(static_cast<int>(col), static_cast<int>(row));
    visibility::BoxSpec b;
    b.x_min = t.x_at(col);
    b.x_max = b.x_min + w;
    b.y_max = t.y_at(row);
    b.y_min = b.y_max - w;
    b.z_min = ground;
    b.z_max = ground + 2 + 18 * u(rng);
    boxes.push_back(b);
  }
  region::RegionOptions options;
  options.threads = 1;
  auto verdicts = region::classify_boxes(*dem, path, boxes, options);
  ASSERT_TRUE(verdicts.ok()) << verdicts.error().message;
  EXPECT_GT(verdicts->stats.always_hidden, 40u);
  EXPECT_GT(verdicts->stats.always_visible, 20u);
  EXPECT_GT(verdicts->stats.undetermined, 0u);

  visibility::CullOptions exact;
  exact.viewshed.algorithm = visibility::Algorithm::kR3;
  exact.viewshed.curvature_coefficient = options.curvature_coefficient;
  for (int pose = 0; pose <= 10; ++pose) {
    const double f = pose / 10.0;
    geodesy::PointSpec at;
    at.x = x0 + f * (x1 - x0);
    at.y = y0 + f * (y1 - y0);
    at.height = 30.0;
    auto eye = geodesy::resolve_point(*dem, at, "observer");
    ASSERT_TRUE(eye.ok()) << eye.error().message;
    auto culled = visibility::cull_boxes(*dem, *eye, boxes, exact);
    ASSERT_TRUE(culled.ok()) << culled.error().message;
    for (std::size_t i = 0; i < boxes.size(); ++i) {
      const visibility::Visibility v = culled->boxes[i].state;
      if (verdicts->verdicts[i] == Verdict::kAlwaysHidden) {
        EXPECT_EQ(v, visibility::Visibility::kOccluded) << "box " << i << " at pose " << pose;
      } else if (verdicts->verdicts[i] == Verdict::kAlwaysVisible) {
        EXPECT_EQ(v, visibility::Visibility::kSeen) << "box " << i << " at pose " << pose;
      }
    }
  }
}

}  // namespace
}  // namespace horizon
