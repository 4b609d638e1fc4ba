// The rasters of visibility/viewshed_outputs.hpp: value codes cell by cell,
// and r.viewshed's vertical angle and elevation difference against
// hand-computed cells.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <iterator>
#include <limits>
#include <numbers>

#include "horizon/visibility/viewshed_outputs.hpp"
#include "visibility_test_util.hpp"

namespace horizon {
namespace {

using testing::eye_at;
using testing::grid_dem;
using visibility::ValueCodes;
using visibility::ViewshedOutput;

constexpr double kDegrees = 180.0 / std::numbers::pi;

TEST(ViewshedOutputs, NamesRoundTrip) {
  for (ViewshedOutput o : {ViewshedOutput::kVisibility, ViewshedOutput::kBoolean, ViewshedOutput::kOhf,
                           ViewshedOutput::kMinTargetHeight, ViewshedOutput::kVerticalAngle,
                           ViewshedOutput::kElevationDifference})
    EXPECT_EQ(visibility::parse_output(visibility::output_name(o)), o);
  EXPECT_FALSE(visibility::parse_output("angle").has_value());
}

// A 9 x 9 DEM of 10 m cells: flat at 0, a void at (1, 1) and a 50 m wall at
// column 6 (rows 2-6); eye 10 m above (4, 4), reach 45 m: (7, 4) and (8, 4) are behind
// the wall, the corners beyond reach.
struct Scene {
  terrain::Dem dem = grid_dem(9, 9, [](int c, int r) { return c == 6 && r >= 2 && r <= 6 ? 50.0 : 0.0; });
  visibility::ViewshedResult result;
  Scene() {
    dem.elevation.at(1, 1) = std::numeric_limits<float>::quiet_NaN();
    auto o = testing::flat_earth(visibility::Algorithm::kR3);
    o.max_distance = 45;
    result = *visibility::compute_viewshed(dem, eye_at(dem, 4, 4, 10.0), o);
  }
};

TEST(ViewshedOutputs, CodesClassifyVoidThenOutOfRangeThenVisibility) {
  const Scene s;
  const ValueCodes codes{.visible = 7, .hidden = 3, .out_of_range = 9, .nodata = 200};
  visibility::AnswerCounts counts;
  const auto coded = visibility::visibility_codes(s.result, 0.0, codes, 1, &counts);
  const auto plain = visibility::visibility_mask(s.result, 0.0);
  ASSERT_EQ(s.result.frame.window, (terrain::Window{0, 0, 9, 9}));
  int seen = 0, hidden = 0, out = 0;
  for (int r = 0; r < 9; ++r)
    for (int c = 0; c < 9; ++c) {
      const std::uint8_t v = coded.at(c, r);
      if (c == 1 && r == 1) {
        EXPECT_EQ(v, 200);  // the void: its own code, though within reach
      } else if (std::hypot(c - 4, r - 4) * 10 > 45) {
        EXPECT_EQ(v, 9) << c << "," << r;
        ++out;
      } else {
        EXPECT_EQ(v, plain.at(c, r) == visibility::kVisible ? 7 : 3) << c << "," << r;
        (v == 7 ? seen : hidden) += 1;
      }
    }
  EXPECT_EQ(coded.at(7, 4), 3);  // behind the wall
  EXPECT_EQ(coded.at(6, 4), 7);  // the wall's face
  EXPECT_GT(out, 0);
  EXPECT_GT(hidden, 0);
  EXPECT_GT(seen, 20);
  // Counted as the raster was made, class by class.
  EXPECT_EQ(counts.visible, static_cast<std::uint64_t>(seen));
  EXPECT_EQ(counts.hidden, static_cast<std::uint64_t>(hidden));
  EXPECT_EQ(counts.out_of_range, static_cast<std::uint64_t>(out));
  EXPECT_EQ(counts.nodata, 1u);
  // The default codes are visibility_mask's.
  const auto defaults = visibility::visibility_codes(s.result, 0.0, {});
  for (std::size_t i = 0; i < plain.size(); ++i) ASSERT_EQ(defaults.values()[i], plain.values()[i]);
}

TEST(ViewshedOutputs, CountsOfALargeRasterOnSeveralThreadsAreTheRastersOwn) {
  // 700 x 500 cells: two chunks of the parallel pass and a part; voids,
  // cells beyond reach, visible and hidden cells in each.
  terrain::Dem dem = grid_dem(700, 500, [](int c, int r) { return 30.0 * std::sin(c * 0.05) * std::cos(r * 0.07); });
  for (int r = 0; r < 500; r += 7)
    for (int c = r % 11; c < 700; c += 13) dem.elevation.at(c, r) = std::numeric_limits<float>::quiet_NaN();
  auto o = testing::flat_earth(visibility::Algorithm::kRadial);
  o.max_distance = 3000;  // 10 m cells: a disc of radius 300 cells
  const auto result = visibility::compute_viewshed(dem, eye_at(dem, 350, 250, 5.0), o);
  ASSERT_TRUE(result.ok()) << result.error().message;
  const ValueCodes codes{.visible = 1, .hidden = 2, .out_of_range = 3, .nodata = 4};
  for (unsigned threads : {1u, 2u, 3u}) {
    visibility::AnswerCounts counts;
    const auto coded = visibility::visibility_codes(*result, 0.0, codes, threads, &counts);
    std::uint64_t by_code[5] = {};
    for (std::uint8_t v : coded.values()) ++by_code[v];
    EXPECT_EQ(counts.visible, by_code[1]) << threads;
    EXPECT_EQ(counts.hidden, by_code[2]) << threads;
    EXPECT_EQ(counts.out_of_range, by_code[3]) << threads;
    EXPECT_EQ(counts.nodata, by_code[4]) << threads;
    EXPECT_EQ(by_code[0], 0u);
    EXPECT_GT(by_code[1], 1000u);
    EXPECT_GT(by_code[2], 1000u);
    EXPECT_GT(by_code[3], 1000u);
    EXPECT_GT(by_code[4], 1000u);
  }
}

TEST(ViewshedOutputs, CodesFollowTheMinTargetHeightRuleCellByCell) {
  // Every kind of OHF and ground value, at and around the tie tolerance, in
  // runs that are not a multiple of the 16 cells the pass takes at a time:
  // each code is the rule's, worked out here cell by cell.
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  const float tol = visibility::kTieTolerance;
  const float ohf_above[] = {0.0f, tol, tol * 1.5f, 2 * tol, -1.0f, 0.5f, 3.0f, 1e6f, nan, -inf, inf, -tol};
  const float grounds[] = {0.0f, 100.0f, -50.25f, 8848.0f, nan};
  for (int width : {1, 15, 16, 17, 61}) {
    visibility::ViewshedResult r;
    r.ohf = terrain::Grid<float>(width, 13);
    r.terrain = terrain::Grid<float>(width, 13);
    for (std::size_t i = 0; i < r.ohf.size(); ++i) {
      const float ground = grounds[(i * 7) % std::size(grounds)];
      const float above = ohf_above[(i * 5 + i / 3) % std::size(ohf_above)];
      r.terrain.values()[i] = ground;
      r.ohf.values()[i] = std::isnan(ground) || std::isinf(above) ? above : ground + above;
    }
    for (float th : {0.0f, tol, 1.0f, 2.5f}) {
      const ValueCodes codes{.visible = 1, .hidden = 2, .out_of_range = 3, .nodata = 4};
      visibility::AnswerCounts counts;
      const auto coded = visibility::visibility_codes(r, th, codes, 1, &counts);
      std::uint64_t by_code[5] = {};
      for (std::size_t i = 0; i < coded.size(); ++i) {
        const float o = r.ohf.values()[i], g = r.terrain.values()[i];
        const std::uint8_t want = std::isnan(g)   ? 4
                                  : std::isnan(o) ? 3
                                  : th >= visibility::min_target_height_at(o, g) ? 1
                                                                                 : 2;
        ASSERT_EQ(coded.values()[i], want) << "width " << width << " cell " << i << " ohf " << o << " ground " << g
                                           << " target " << th;
        ++by_code[want];
      }
      EXPECT_EQ(counts.visible, by_code[1]);
      EXPECT_EQ(counts.hidden, by_code[2]);
      EXPECT_EQ(counts.out_of_range, by_code[3]);
      EXPECT_EQ(counts.nodata, by_code[4]);
    }
  }
}

TEST(ViewshedOutputs, BooleanCodesAreRViewshedsMinusB) {
  const Scene s;
  const auto b = visibility::visibility_codes(s.result, 0.0, visibility::kBooleanCodes);
  EXPECT_EQ(b.at(1, 1), 255);  // a void stays no data
  EXPECT_EQ(b.at(0, 8), 0);    // beyond reach: not visible
  EXPECT_EQ(b.at(7, 4), 0);    // hidden
  EXPECT_EQ(b.at(5, 4), 1);
}

TEST(ViewshedOutputs, ValueCodesNeedAVisibleCodeOfItsOwn) {
  EXPECT_TRUE(visibility::validate_value_codes({}).ok());
  EXPECT_TRUE(visibility::validate_value_codes(visibility::kBooleanCodes).ok());
  EXPECT_TRUE(visibility::validate_value_codes({.visible = 1, .hidden = 255, .out_of_range = 255, .nodata = 255}).ok());
  for (ValueCodes bad : {ValueCodes{.visible = 0, .hidden = 0}, ValueCodes{.visible = 255},
                         ValueCodes{.visible = 4, .hidden = 0, .out_of_range = 4, .nodata = 5}}) {
    const Status s = visibility::validate_value_codes(bad);
    ASSERT_FALSE(s.ok());
    EXPECT_EQ(s.error().field, "visible_value");
  }
}

TEST(ViewshedOutputs, VerticalAngleByHand) {
  const Scene s;
  const auto angle = visibility::vertical_angle_raster(s.result, 0.0);
  EXPECT_FLOAT_EQ(angle.at(4, 4), 180.0f);  // the eye's own cell, as r.viewshed
  // (5, 4): 10 m east, ground 10 m below the eye: 45 degrees down, 45 from straight down.
  EXPECT_NEAR(angle.at(5, 4), 45.0, 1e-5);
  // (6, 4): the wall's top 40 m above the eye, 20 m away.
  EXPECT_NEAR(angle.at(6, 4), 90.0 + std::atan2(40.0, 20.0) * kDegrees, 1e-4);
  // (4, 7): 30 m south, 10 m down.
  EXPECT_NEAR(angle.at(4, 7), 90.0 - std::atan2(10.0, 30.0) * kDegrees, 1e-4);
  EXPECT_TRUE(std::isnan(angle.at(7, 4)));  // hidden
  EXPECT_TRUE(std::isnan(angle.at(1, 1)));  // void
  EXPECT_TRUE(std::isnan(angle.at(0, 8)));  // out of range
  // A target height raises the point looked at: (4, 7) with a 10 m mast is level with the eye.
  EXPECT_NEAR(visibility::vertical_angle_raster(s.result, 10.0).at(4, 7), 90.0, 1e-4);
}

TEST(ViewshedOutputs, VerticalAngleCountsTheCurvature) {
  // 30 km over a flat sea with an eye 1000 m up: the far cell sinks d^2 * c / 2R.
  const terrain::Dem sea = grid_dem(31, 3, [](int, int) { return 0.0; }, 1000.0);
  visibility::ViewshedOptions o;
  o.algorithm = visibility::Algorithm::kR3;
  auto v = visibility::compute_viewshed(sea, eye_at(sea, 0, 1, 1000.0), o);
  ASSERT_TRUE(v.ok());
  const double d = 30000.0;
  const double drop = 0.85714 * d * d / (2 * 6378137.0);
  EXPECT_NEAR(visibility::vertical_angle_raster(*v, 0.0).at(30, 1), 90.0 - std::atan2(1000.0 + drop, d) * kDegrees,
              1e-4);
}

TEST(ViewshedOutputs, ElevationDifferenceByHand) {
  const Scene s;
  const auto diff = visibility::elevation_difference_raster(s.result, 0.0);
  EXPECT_FLOAT_EQ(diff.at(4, 4), -10.0f);
  EXPECT_FLOAT_EQ(diff.at(6, 4), 40.0f);
  EXPECT_FLOAT_EQ(diff.at(2, 4), -10.0f);
  EXPECT_TRUE(std::isnan(diff.at(7, 4)));
  EXPECT_TRUE(std::isnan(diff.at(1, 1)));
  // float_raster names every float output.
  const auto via = visibility::float_raster(s.result, ViewshedOutput::kElevationDifference, 0.0);
  EXPECT_FLOAT_EQ(via.at(6, 4), 40.0f);
}

TEST(ViewshedOutputs, TheFieldOfViewReachesEveryOutput) {
  Scene s;
  auto o = testing::flat_earth(visibility::Algorithm::kR3);
  o.max_distance = 45;
  o.field_of_view.azimuth_start = 45;  // the east quadrant
  o.field_of_view.azimuth_end = 135;
  auto v = visibility::compute_viewshed(s.dem, eye_at(s.dem, 4, 4, 10.0), o);
  ASSERT_TRUE(v.ok());
  const auto codes = visibility::visibility_codes(*v, 0.0, {.visible = 1, .hidden = 0, .out_of_range = 9, .nodata = 200});
  const auto angle = visibility::vertical_angle_raster(*v, 0.0);
  EXPECT_EQ(codes.at(5, 4), 1);
  EXPECT_EQ(codes.at(3, 4), 9);  // west: out of view
  EXPECT_EQ(codes.at(4, 2), 9);  // north
  EXPECT_EQ(codes.at(1, 1), 200);
  EXPECT_TRUE(std::isnan(angle.at(3, 4)));
  EXPECT_FALSE(std::isnan(angle.at(5, 4)));
  EXPECT_EQ(codes.at(4, 4), 1);  // the eye's own cell has no azimuth: in every wedge
}

}  // namespace
}  // namespace horizon
