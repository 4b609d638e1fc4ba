// Box culling: hand-computed wall cases, rejects, and brute force over the
// OHF of the whole DEM.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "horizon/geodesy/crs.hpp"
#include "horizon/visibility/cull.hpp"
#include "visibility_test_util.hpp"

namespace horizon::visibility {
namespace {

using horizon::testing::eye_at;
using horizon::testing::grid_dem;

constexpr float kMinusInf = -std::numeric_limits<float>::infinity();

// A box over grid cells [c0, c1] x [r0, r1] (centres, inclusive) of `dem`.
BoxSpec box_over(const terrain::Dem& dem, double c0, double r0, double c1, double r1, double z0, double z1) {
  const auto& t = dem.georef.transform;
  BoxSpec b;
  b.x_min = t.x_at(c0);
  b.x_max = t.x_at(c1);
  b.y_min = std::min(t.y_at(r0), t.y_at(r1));
  b.y_max = std::max(t.y_at(r0), t.y_at(r1));
  b.z_min = z0;
  b.z_max = z1;
  return b;
}

CullOptions flat(Algorithm algorithm) {
  CullOptions o;
  o.viewshed.curvature_coefficient = 0.0;
  o.viewshed.algorithm = algorithm;
  return o;
}

// Flat ground at 0 with a 100 m wall on column 10; eye 10 m up at column 2.
// 10 m cells: the sight line over the wall top (8 cells away, +90 m) rises
// 90/8 m per cell, so behind the wall at column 18 the OHF is 10 + 16 * 90/8 = 190 m.
terrain::Dem wall_dem() {
  return grid_dem(30, 9, [](int c, int) { return c == 10 ? 100.0 : 0.0; });
}

TEST(Cull, BoxBehindTheWallIsHiddenUnlessItRisesAboveTheSightLine) {
  const terrain::Dem dem = wall_dem();
  const auto eye = eye_at(dem, 2, 4, 10.0);
  const std::vector<BoxSpec> boxes = {
      box_over(dem, 18, 4, 18, 4, 0, 150),      // below the 190 m OHF
      box_over(dem, 18, 4, 18, 4, 0, 200),      // above it
      box_over(dem, 5, 3, 6, 5, 0, 1),          // in front of the wall: the ground is seen
      box_over(dem, 17.2, 4, 17.6, 4, 0, 180),  // between centres 17 and 18: min of both (180 at 17)
  };
  auto result = cull_boxes(dem, eye, boxes, flat(Algorithm::kR3));
  ASSERT_TRUE(result.ok()) << result.error().message;
  ASSERT_EQ(result->boxes.size(), 4u);
  EXPECT_EQ(result->boxes[0].state, Visibility::kOccluded);
  EXPECT_NEAR(result->boxes[0].ohf_min, 190.0, 1e-3);
  EXPECT_EQ(result->boxes[1].state, Visibility::kSeen);
  EXPECT_EQ(result->boxes[2].state, Visibility::kSeen);
  EXPECT_LE(result->boxes[2].ohf_min, 0.0f + kTieTolerance);
  EXPECT_NEAR(result->boxes[3].ohf_min, 10.0 + 15 * 90.0 / 8, 1e-3);
  EXPECT_EQ(result->boxes[3].state, Visibility::kSeen);
  EXPECT_EQ(result->visible_count, 3u);
  EXPECT_EQ(result->algorithm, Algorithm::kR3);
}

TEST(Cull, VisibilityNamesAreTheApiWords) {
  EXPECT_EQ(visibility_name(Visibility::kSeen), "visible");
  EXPECT_EQ(visibility_name(Visibility::kOccluded), "hidden");
  EXPECT_EQ(visibility_name(Visibility::kUndetermined), "undetermined");
  EXPECT_EQ(visibility_name(Visibility::kOutOfRange), "out_of_range");
  EXPECT_EQ(BoxVisibility{}.state, Visibility::kSeen);
}

TEST(Cull, ConservativeFlagUsesTheConservativeAlgorithm) {
  const terrain::Dem dem = wall_dem();
  auto result = cull_boxes(dem, eye_at(dem, 2, 4, 10.0), std::vector{box_over(dem, 18, 4, 18, 4, 0, 150)}, [] {
    auto o = flat(Algorithm::kRadial);
    o.conservative = true;
    return o;
  }());
  ASSERT_TRUE(result.ok()) << result.error().message;
  EXPECT_EQ(result->algorithm, Algorithm::kConservative);
  EXPECT_EQ(result->boxes[0].state, Visibility::kOccluded);
}

TEST(Cull, ComputesOnlyTheWindowTheBoxesNeed) {
  const terrain::Dem dem = horizon::testing::make_random_terrain(200, 200, 3);
  const auto eye = eye_at(dem, 100, 100, 2.0);
  auto result = cull_boxes(dem, eye, std::vector{box_over(dem, 103, 98, 104, 99, 0, 5000)}, flat(Algorithm::kRadial));
  ASSERT_TRUE(result.ok()) << result.error().message;
  EXPECT_TRUE(result->window.contains(104, 98));
  EXPECT_TRUE(result->window.contains(96, 102));  // the reach is a disc around the eye
  EXPECT_LE(result->window.width(), 11);
  EXPECT_LE(result->stats.window_cells, 121u);
  EXPECT_EQ(result->stats.dem_cells, 40000u);
}

// The daemon's workers keep their OHF raster between calls (ResultStorage);
// a run cancelled after taking it must leave it fit for the next run. It
// once kept the shape of the cells it had handed on, and the next call with
// the same window wrote its NaNs through a null pointer (found by flooding
// horizond with cancelled 100 000-box calls).
TEST(Cull, ACancelledRunLeavesItsStorageFitForTheNext) {
  const terrain::Dem dem = horizon::testing::make_random_terrain(120, 90, 11, 300.0);
  const auto eye = eye_at(dem, 60, 45, 5.0);
  ViewshedOptions options;
  terrain::Grid<float> kept_ohf, kept_terrain;
  const ResultStorage storage{&kept_ohf, &kept_terrain};
  auto first = compute_viewshed(dem, eye, options, nullptr, nullptr, nullptr, storage);
  ASSERT_TRUE(first.ok()) << first.error().message;
  kept_ohf = std::move(first->ohf);  // handed back, as run_cull does
  EXPECT_EQ(first->ohf.width(), 0);  // a grid moved from is 0 x 0
  EXPECT_EQ(first->ohf.height(), 0);
  EXPECT_TRUE(first->ohf.empty());

  CancelToken token;
  token.cancel();
  RunControl control;
  control.cancel = &token;
  auto cancelled = compute_viewshed(dem, eye, options, &control, nullptr, nullptr, storage);
  ASSERT_FALSE(cancelled.ok());
  EXPECT_EQ(cancelled.error().code, ErrorCode::kCancelled);
  EXPECT_EQ(kept_ohf.size(), static_cast<std::size_t>(kept_ohf.width()) * static_cast<std::size_t>(kept_ohf.height()));

  auto again = compute_viewshed(dem, eye, options, nullptr, nullptr, nullptr, storage);
  auto fresh = compute_viewshed(dem, eye, options);
  ASSERT_TRUE(again.ok() && fresh.ok());
  ASSERT_EQ(again->ohf.size(), fresh->ohf.size());
  for (std::size_t i = 0; i < fresh->ohf.size(); ++i) {
    const float a = again->ohf.values()[i], b = fresh->ohf.values()[i];
    ASSERT_TRUE(a == b || (std::isnan(a) && std::isnan(b))) << i;
  }
}

TEST(Cull, EqualsBruteForceOverTheWholeDemOhf) {
  const terrain::Dem dem = horizon::testing::make_random_terrain(120, 90, 11, 300.0);
  const auto& t = dem.georef.transform;
  std::mt19937 rng(99);
  std::uniform_real_distribution<double> col(-0.5, 119.5), row(-0.5, 89.5), size(0.0, 6.0), z(0.0, 450.0);
  for (int trial = 0; trial < 3; ++trial) {
    const auto eye = eye_at(dem, 10 + 40 * trial, 45, 5.0);
    std::vector<BoxSpec> boxes;
    for (int i = 0; i < 500; ++i) {
      const double c0 = col(rng), r0 = row(rng);
      const double c1 = std::min(c0 + size(rng), 119.5), r1 = std::min(r0 + size(rng), 89.5);
      const double z0 = z(rng);
      boxes.push_back(
          {geodesy::PointFrame::kDatasetCrs, t.x_at(c0), t.y_at(r1), t.x_at(c1), t.y_at(r0), z0, z0 + size(rng) * 10});
    }
    const CullOptions options = flat(Algorithm::kR3);
    auto culled = cull_boxes(dem, eye, boxes, options);
    ASSERT_TRUE(culled.ok()) << culled.error().message;
    auto whole = compute_viewshed(dem, eye, options.viewshed);
    ASSERT_TRUE(whole.ok());
    for (std::size_t i = 0; i < boxes.size(); ++i) {
      // Every centre bracketing the footprint, NaN as -inf.
      const double c0 = t.col_at(boxes[i].x_min), c1 = t.col_at(boxes[i].x_max);
      const double r0 = t.row_at(boxes[i].y_max), r1 = t.row_at(boxes[i].y_min);
      float m = std::numeric_limits<float>::infinity();
      for (int r = std::max(0, int(std::floor(r0))); r <= std::min(89, int(std::ceil(r1))); ++r)
        for (int c = std::max(0, int(std::floor(c0))); c <= std::min(119, int(std::ceil(c1))); ++c) {
          const float v = horizon::testing::ohf_at(*whole, c, r);
          m = std::min(m, std::isnan(v) ? kMinusInf : v);
        }
      ASSERT_EQ(culled->boxes[i].ohf_min, m) << "box " << i;
      ASSERT_EQ(culled->boxes[i].state, boxes[i].z_max >= m - kTieTolerance ? Visibility::kSeen : Visibility::kOccluded)
          << "box " << i;
    }
    EXPECT_GT(culled->visible_count, 0u);
    EXPECT_LT(culled->visible_count, boxes.size());
  }
}

// Conservative never hides a box that R3 shows: checked against R3 itself.
TEST(Cull, ConservativeNeverHidesABoxR3Sees) {
  const terrain::Dem dem = horizon::testing::make_random_terrain(100, 100, 5, 250.0);
  const auto& t = dem.georef.transform;
  const auto eye = eye_at(dem, 50, 50, 3.0);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> pos(0.0, 96.0), z(0.0, 400.0);
  std::vector<BoxSpec> boxes;
  for (int i = 0; i < 1000; ++i) {
    const double c0 = pos(rng), r0 = pos(rng), z0 = z(rng);
    boxes.push_back(
        {geodesy::PointFrame::kDatasetCrs, t.x_at(c0), t.y_at(r0 + 3), t.x_at(c0 + 3), t.y_at(r0), z0, z0 + 20});
  }
  CullOptions conservative = flat(Algorithm::kRadial);
  conservative.conservative = true;
  auto c = cull_boxes(dem, eye, boxes, conservative);
  auto r3 = cull_boxes(dem, eye, boxes, flat(Algorithm::kR3));
  ASSERT_TRUE(c.ok() && r3.ok());
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    if (r3->boxes[i].state == Visibility::kSeen) {
      ASSERT_EQ(c->boxes[i].state, Visibility::kSeen) << "box " << i;
    }
  }
}

TEST(Cull, WgsBoxesResolveLikeTheirDatasetCrsRectangle) {
  // UTM 33N DEM: a lon/lat box converts to (about) the same footprint.
  const terrain::Dem dem = horizon::testing::make_dem(
      50, 50, [](int c, int r) { return c + r; }, 10.0, 32633);
  const geodesy::Crs crs = *geodesy::Crs::from_epsg(32633);
  const auto& t = dem.georef.transform;
  const auto sw = *crs.to_lonlat({t.x_at(10.2), t.y_at(20.8)});
  const auto ne = *crs.to_lonlat({t.x_at(12.7), t.y_at(18.3)});
  BoxSpec b{geodesy::PointFrame::kWgs84, sw.lon, sw.lat, ne.lon, ne.lat, 0, 10};
  auto f = resolve_boxes(dem, std::vector{b});
  ASSERT_TRUE(f.ok()) << f.error().message;
  EXPECT_EQ((*f)[0].cells.col0, 10);
  EXPECT_EQ((*f)[0].cells.col1, 14);  // centres 10..13 bracket [10.2, 12.7] (and the conversion's slack)
  EXPECT_EQ((*f)[0].cells.row0, 18);
  EXPECT_EQ((*f)[0].cells.row1, 22);
}

TEST(Cull, RejectsMalformedBoxesNamingTheField) {
  const terrain::Dem dem = wall_dem();
  const auto eye = eye_at(dem, 2, 4, 10.0);
  const CullOptions o = flat(Algorithm::kRadial);
  auto empty = cull_boxes(dem, eye, std::vector<BoxSpec>{}, o);
  ASSERT_FALSE(empty.ok());
  EXPECT_EQ(empty.error().field, "boxes");

  std::vector<BoxSpec> boxes{box_over(dem, 3, 3, 4, 4, 0, 1), box_over(dem, 3, 3, 4, 4, 5, 1)};
  auto inverted = cull_boxes(dem, eye, boxes, o);
  ASSERT_FALSE(inverted.ok());
  EXPECT_EQ(inverted.error().code, ErrorCode::kInvalidArgument);
  EXPECT_EQ(inverted.error().field, "boxes[1].z_max");

  boxes[1] = box_over(dem, 3, 3, 4, 4, 0, 1);
  boxes[1].x_min = std::numeric_limits<double>::quiet_NaN();
  auto nan = cull_boxes(dem, eye, boxes, o);
  ASSERT_FALSE(nan.ok());
  EXPECT_EQ(nan.error().field, "boxes[1].x_min");

  // Off the map: refused by resolve_boxes when asked to, answered by culling.
  boxes[1] = box_over(dem, 28, 3, 31, 4, 0, 1);  // beyond the last column
  auto refused = resolve_boxes(dem, boxes);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().code, ErrorCode::kOutOfRange);
  EXPECT_EQ(refused.error().field, "boxes[1]");
  auto outside = cull_boxes(dem, eye, boxes, o);
  ASSERT_TRUE(outside.ok()) << outside.error().message;
  EXPECT_EQ(outside->boxes[1].state, Visibility::kOutOfRange);
  EXPECT_NE(outside->boxes[0].state, Visibility::kOutOfRange);
  EXPECT_EQ(outside->out_of_range_count, 1u);

  boxes[1] = box_over(dem, 3, 3, 4, 4, 0, 1);
  boxes[1].frame = geodesy::PointFrame::kWgs84;  // the wall DEM has no CRS
  auto no_crs = cull_boxes(dem, eye, boxes, o);
  ASSERT_FALSE(no_crs.ok());
  EXPECT_EQ(no_crs.error().code, ErrorCode::kUnsupported);
}

TEST(Cull, ABoxMeetingAVoidIsDecidedOnItsKnownCellsOrUndetermined) {
  terrain::Dem dem = wall_dem();
  for (int r = 3; r <= 5; ++r)
    for (int c = 18; c <= 19; ++c) dem.elevation.at(c, r) = std::nanf("");
  const auto eye = eye_at(dem, 2, 4, 10.0);
  const double ohf17 = 10.0 + 15 * 90.0 / 8;  // the sight line over the wall at column 17
  const std::vector<BoxSpec> boxes = {
      box_over(dem, 17, 4, 19, 4, 0, 150),  // buried where known, part over the void
      box_over(dem, 17, 4, 19, 4, 0, 185),  // above the known part: seen there
      box_over(dem, 18, 4, 19, 4, 0, 150),  // over the void alone
      box_over(dem, 20, 4, 21, 4, 0, 150),  // no void: hidden as usual
  };
  auto result = cull_boxes(dem, eye, boxes, flat(Algorithm::kR3));
  ASSERT_TRUE(result.ok()) << result.error().message;
  EXPECT_EQ(result->boxes[0].state, Visibility::kUndetermined);
  EXPECT_NEAR(result->boxes[0].ohf_min, ohf17, 1e-3);
  EXPECT_EQ(result->boxes[1].state, Visibility::kSeen);
  EXPECT_NEAR(result->boxes[1].ohf_min, ohf17, 1e-3);
  EXPECT_EQ(result->boxes[2].state, Visibility::kUndetermined);
  EXPECT_EQ(result->boxes[2].ohf_min, kMinusInf);
  EXPECT_EQ(result->boxes[3].state, Visibility::kOccluded);
  EXPECT_EQ(result->visible_count, 3u);  // undetermined boxes may be seen: a client must draw them

  // Voids filled as ground at 0 m: the buried boxes are hidden.
  CullOptions filled = flat(Algorithm::kR3);
  filled.viewshed.nodata = NodataPolicy::kFill;
  filled.viewshed.nodata_fill_height = 0.0;
  auto fill = cull_boxes(dem, eye, boxes, filled);
  ASSERT_TRUE(fill.ok()) << fill.error().message;
  EXPECT_EQ(fill->boxes[0].state, Visibility::kOccluded);
  EXPECT_NEAR(fill->boxes[0].ohf_min, ohf17, 1e-3);
  EXPECT_EQ(fill->boxes[2].state, Visibility::kOccluded);
  EXPECT_EQ(fill->boxes[1].state, Visibility::kSeen);
}

TEST(Cull, BoxesAllOffTheMapAreAnsweredWithoutAnOhf) {
  const terrain::Dem dem = wall_dem();
  const auto eye = eye_at(dem, 2, 4, 10.0);
  const std::vector<BoxSpec> boxes = {box_over(dem, 28, 3, 31, 4, 0, 1), box_over(dem, -3, 3, 1, 4, 0, 1)};
  auto plan = plan_cull(dem, eye, boxes, flat(Algorithm::kR3));
  ASSERT_TRUE(plan.ok());
  EXPECT_FALSE(plan->any_on_map);
  auto result = cull_boxes(dem, eye, boxes, flat(Algorithm::kR3));
  ASSERT_TRUE(result.ok()) << result.error().message;
  for (const BoxVisibility& b : result->boxes) EXPECT_EQ(b.state, Visibility::kOutOfRange);
  EXPECT_EQ(result->out_of_range_count, 2u);
  EXPECT_EQ(result->visible_count, 2u);
  EXPECT_TRUE(result->window.empty());  // nothing was computed
}

TEST(Cull, HonoursCancellation) {
  const terrain::Dem dem = horizon::testing::make_random_terrain(64, 64, 2);
  CancelToken token;
  token.cancel();
  RunControl control;
  control.cancel = &token;
  auto r = cull_boxes(dem, eye_at(dem, 32, 32, 2), std::vector{box_over(dem, 1, 1, 2, 2, 0, 1)}, flat(Algorithm::kR3),
                      &control);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kCancelled);
}

}  // namespace
}  // namespace horizon::visibility
