// Radial sweep (fast OHF): analytic cases within tolerance, agreement with R3,
// and the properties that must hold whatever the terrain.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <ostream>
#include <random>
#include <sstream>
#include <string>

#include "horizon/visibility/agreement.hpp"
#include "horizon/visibility/radial_sweep.hpp"
#include "horizon/visibility/view_frame.hpp"
#include "horizon/visibility/viewshed.hpp"
#include "simd.hpp"
#include "test_support.hpp"
#include "visibility_test_util.hpp"

namespace horizon {
namespace {

using testing::eye_at;
using testing::flat_earth;
using testing::grid_dem;
using testing::ohf_at;
using visibility::Algorithm;

TEST(RadialSweep, FlatPlaneIsAllVisible) {
  const auto dem = grid_dem(101, 77, [](int, int) { return -430.0; });  // Dead Sea shore
  for (double col : {50.0, 0.0, 100.0, 33.5, 12.25}) {
    auto vs = visibility::compute_viewshed(dem, eye_at(dem, col, 40.5, 1.7), flat_earth(Algorithm::kRadial));
    ASSERT_TRUE(vs.ok()) << vs.error().message;
    const auto mask = visibility::visibility_mask(*vs, 0.0);
    for (std::uint8_t v : mask.values()) ASSERT_EQ(v, visibility::kVisible) << "observer col " << col;
  }
}

// The analytic wall and ridge of test_r3.cpp: every ray samples the wall top
// exactly, so only the angular blend of 1/distance errs (second order).
TEST(RadialSweep, WallShadowMatchesTheAnalyticLine) {
  const auto dem = grid_dem(30, 21, [](int c, int) { return c == 10 ? 10.0 : 0.0; });
  auto vs = visibility::compute_viewshed(dem, eye_at(dem, 5, 10, 2.0), flat_earth(Algorithm::kRadial));
  ASSERT_TRUE(vs.ok());
  for (int row = 0; row < 21; ++row)
    for (int col = 11; col < 30; ++col)
      EXPECT_NEAR(ohf_at(*vs, col, row), 2.0 + 8.0 * (col - 5) / 5.0, 0.05) << col << "," << row;
}

TEST(RadialSweep, RidgeMatchesTheAnalyticLine) {
  const auto dem = grid_dem(40, 25, [](int c, int) { return 50.0 - 2.0 * std::abs(c - 20); });
  auto vs = visibility::compute_viewshed(dem, eye_at(dem, 12, 12, 1.0), flat_earth(Algorithm::kRadial));
  ASSERT_TRUE(vs.ok());
  const auto mask = visibility::visibility_mask(*vs, 0.0);
  for (int row = 0; row < 25; ++row) {
    for (int col = 21; col < 40; ++col) {
      EXPECT_NEAR(ohf_at(*vs, col, row), 35.0 + 15.0 * (col - 12) / 8.0, 0.05) << col << "," << row;
      EXPECT_EQ(mask.at(col, row), visibility::kHidden);
    }
    for (int col = 0; col <= 20; ++col) EXPECT_EQ(mask.at(col, row), visibility::kVisible) << col << "," << row;
  }
}

TEST(RadialSweep, PyramidPeakIsAllVisible) {
  const auto peak =
      grid_dem(65, 65, [](int c, int r) { return 900.0 - 7.0 * std::max(std::abs(c - 32), std::abs(r - 32)); });
  auto vs = visibility::compute_viewshed(peak, eye_at(peak, 32, 32, 0.5), flat_earth(Algorithm::kRadial));
  ASSERT_TRUE(vs.ok());
  const auto mask = visibility::visibility_mask(*vs, 0.0);
  for (std::uint8_t v : mask.values()) ASSERT_EQ(v, visibility::kVisible);
}

struct Case {
  unsigned seed;
  double col, row, height;
};

void PrintTo(const Case& c, std::ostream* os) {
  *os << "seed " << c.seed << ", eye at (" << c.col << ", " << c.row << "), " << c.height << " m up";
}

class RadialVsR3 : public ::testing::TestWithParam<Case> {};

// On rough synthetic terrain the fast sweep stays within the bar
// against the exact reference: IoU >= 99 %, missed visible <= 0.5 %.
TEST_P(RadialVsR3, MeetsTheAccuracyBar) {
  const Case c = GetParam();
  const auto dem = testing::make_random_terrain(181, 143, c.seed);
  const auto eye = eye_at(dem, c.col, c.row, c.height);
  visibility::ViewshedOptions o;
  o.algorithm = Algorithm::kR3;
  auto exact = visibility::compute_viewshed(dem, eye, o);
  o.algorithm = Algorithm::kRadial;
  auto fast = visibility::compute_viewshed(dem, eye, o);
  ASSERT_TRUE(exact.ok() && fast.ok());
  const auto a = visibility::compare_viewsheds(*fast, *exact, 0.0);
  EXPECT_GT(a.cells_compared, 20000u);
  EXPECT_GE(a.iou, 0.99) << "seed " << c.seed;
  EXPECT_LE(a.missed_rate, 0.005) << "seed " << c.seed;
  EXPECT_LT(a.ohf_rmse, 2.0);
}

INSTANTIATE_TEST_SUITE_P(Terrains, RadialVsR3,
                         ::testing::Values(Case{1, 90, 71, 2.0}, Case{2, 10.5, 130.25, 10.0}, Case{3, 180, 0, 2.0},
                                           Case{4, 47.3, 88.8, 50.0}, Case{5, 120, 20, 0.0}),
                         [](const ::testing::TestParamInfo<Case>& test) {
                           const Case& c = test.param;
                           std::ostringstream name;
                           name << "seed" << c.seed << "_eye_" << c.col << "_" << c.row << "_up_" << c.height;
                           return testing::readable_name(name.str());
                         });

TEST(RadialSweep, RaisingTheObserverNeverHidesACell) {
  const auto dem = testing::make_random_terrain(150, 120, 11);
  terrain::Grid<std::uint8_t> previous;
  for (double h : {0.0, 1.0, 2.0, 5.0, 20.0, 100.0}) {
    auto vs = visibility::compute_viewshed(dem, eye_at(dem, 60.4, 70.6, h), visibility::ViewshedOptions{});
    ASSERT_TRUE(vs.ok());
    auto mask = visibility::visibility_mask(*vs, 0.0);
    if (!previous.empty()) {
      int lost = 0;
      for (std::size_t i = 0; i < mask.size(); ++i)
        lost += previous.values()[i] == visibility::kVisible && mask.values()[i] == visibility::kHidden;
      EXPECT_EQ(lost, 0) << "raising the eye to " << h << " m hid cells";
    }
    previous = std::move(mask);
  }
}

TEST(RadialSweep, RaisingTheTargetNeverHidesACell) {
  const auto dem = testing::make_random_terrain(150, 120, 12);
  auto vs = visibility::compute_viewshed(dem, eye_at(dem, 75, 60, 2.0), visibility::ViewshedOptions{});
  ASSERT_TRUE(vs.ok());
  const auto mth = visibility::min_target_height(*vs);
  const auto low = visibility::visibility_mask(*vs, 0.0), high = visibility::visibility_mask(*vs, 10.0);
  for (std::size_t i = 0; i < low.size(); ++i) {
    if (low.values()[i] == visibility::kVisible) {
      EXPECT_EQ(high.values()[i], visibility::kVisible);
    }
    // The minimum visible height is never negative and decides the mask.
    if (!std::isnan(mth.values()[i])) {
      EXPECT_GE(mth.values()[i], 0.0f);
      EXPECT_EQ(high.values()[i] == visibility::kVisible, mth.values()[i] <= 10.0f);
    }
  }
}

TEST(RadialSweep, ThreadCountDoesNotChangeTheAnswer) {
  const auto dem = testing::make_random_terrain(300, 200, 5);
  visibility::ViewshedOptions o;
  o.threads = 1;
  auto one = visibility::compute_viewshed(dem, eye_at(dem, 100.5, 80.5, 2.0), o);
  o.threads = 4;
  auto four = visibility::compute_viewshed(dem, eye_at(dem, 100.5, 80.5, 2.0), o);
  ASSERT_TRUE(one.ok() && four.ok());
  for (std::size_t i = 0; i < one->ohf.size(); ++i) {
    const float a = one->ohf.values()[i], b = four->ohf.values()[i];
    if (std::isnan(a)) {
      EXPECT_TRUE(std::isnan(b)) << i;
    } else {
      EXPECT_EQ(a, b) << i;
    }
  }
}

TEST(RadialSweep, MaxDistanceAnswersExactlyTheDisc) {
  const auto dem = testing::make_random_terrain(200, 160, 9);
  visibility::ViewshedOptions o;
  o.max_distance = 1500.0;  // 50 cells of 30 m
  auto vs = visibility::compute_viewshed(dem, eye_at(dem, 70.5, 90.25, 2.0), o);
  ASSERT_TRUE(vs.ok());
  std::uint64_t inside = 0;
  const auto& w = vs->frame.window;
  for (int row = w.row0; row < w.row1; ++row)
    for (int col = w.col0; col < w.col1; ++col) {
      const bool in = std::hypot((col - 70.5) * 30.0, (row - 90.25) * 30.0) <= 1500.0;
      inside += in;
      EXPECT_EQ(in, !std::isnan(ohf_at(*vs, col, row))) << col << "," << row;
    }
  EXPECT_EQ(vs->stats.cells_evaluated, inside);
  // Work stays proportional to the disc, not the DEM.
  EXPECT_LT(vs->stats.terrain_samples, 12 * inside);  // ~2 samples x ~4.5 ray steps per cell at spacing 0.5
  EXPECT_LT(vs->stats.window_cells, dem.elevation.size() / 2);
}

// One of the sweep's awkward cases (for_each_awkward_case).
struct AwkwardCase {
  terrain::HeightView z;
  visibility::ViewFrame frame;
  visibility::ViewshedOptions options;
  bool filled;  // voids read as terrain at 150 m
};

// The sweep's awkward cases: a random terrain with a block of voids,
// scattered voids and one at (20, 20); eyes on and off cell centres, in a
// corner, on that void (standing at a given altitude), with and without max
// distance (one beyond the grid), and one whose diagonals pass through cell
// centres that rounding puts a hair to either side (60.4, 66.6: 61 - 60.4
// and 66.6 - 66 differ in their last bits); voids transparent and filled; under every
// kernel form this CPU runs. Calls check(c) for each, with a trace naming it.
template <class Check>
void for_each_awkward_case(Check check) {
  constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
  auto dem = testing::make_random_terrain(90, 70, 21);
  for (int r = 30; r < 36; ++r)
    for (int c = 50; c < 58; ++c) dem.elevation.at(c, r) = kNaN;
  for (int i = 0; i < 200; ++i) dem.elevation.at((i * 37) % 90, (i * 11) % 70) = kNaN;
  dem.elevation.at(20, 20) = kNaN;
  struct Eye {
    double col, row, max_distance;
  };
  const double kNone = std::numeric_limits<double>::infinity();
  const Eye eyes[] = {{40.3, 33.7, kNone}, {44, 35, kNone},      {89, 0, kNone},  {89, 69, 900.0}, {20, 20, kNone},
                      {20, 20, 450.0},     {60.5, 10.25, 600.0}, {44, 35, 1e300}, {44, 35, 700.0}, {60.4, 66.6, kNone}};
  using visibility::sweep::simd::Isa;
  struct Restore {
    ~Restore() { visibility::sweep::simd::isa_limit() = Isa::kAvx512; }
  } restore;
  for (const Isa isa : {Isa::kScalar, Isa::kAvx2, Isa::kAvx512}) {
    if (visibility::sweep::simd::cpu_isa() < isa) continue;
    visibility::sweep::simd::isa_limit() = isa;
    for (const Eye& e : eyes)
      for (const bool filled : {false, true}) {
        std::ostringstream what;
        what << "isa " << int(isa) << ", eye " << e.col << "," << e.row << " reach " << e.max_distance
             << (filled ? ", voids filled" : "");
        SCOPED_TRACE(what.str());
        visibility::ViewshedOptions o;
        o.max_distance = e.max_distance;
        if (filled) {
          o.nodata = visibility::NodataPolicy::kFill;
          o.nodata_fill_height = 150.0;
        }
        // The eye on the void cell (20, 20) stands at a given altitude.
        geodesy::GridPoint eye = eye_at(dem, e.col, e.row, 2.0);
        if (std::isnan(eye.elevation)) eye.ground = 100.0, eye.elevation = 102.0;
        const auto f = visibility::make_view_frame(dem, eye, o);
        ASSERT_TRUE(f.ok()) << f.error().message;
        check(AwkwardCase{visibility::elevation_view(dem.elevation, o), *f, o, filled});
        if (::testing::Test::HasFatalFailure()) return;
      }
  }
}

// The sweep writes every cell it answers: into a grid full of a sentinel, of the
// window's size or reshaped from a larger one, it gives the bits of a run
// into a new grid, and a cell has no answer exactly when it is out of range
// or a void target. Every awkward case, with every blend, the lower bound
// and thinned rays.
TEST(RadialSweep, WritesEveryCellWhateverTheOutputHeld) {
  constexpr float kSentinel = 12345.0f;
  struct Sweep {
    visibility::RadialOptions options;
    visibility::RadialBound bound;
  };
  const Sweep sweeps[] = {{{}, visibility::RadialBound::kNone},
                          {{1.0, visibility::RayBlend::kLinear, 0}, visibility::RadialBound::kNone},
                          {{1.0, visibility::RayBlend::kMin, 0}, visibility::RadialBound::kNone},
                          {{1.0, visibility::RayBlend::kResample, 2}, visibility::RadialBound::kNone},
                          {{}, visibility::RadialBound::kLowerBound}};
  for_each_awkward_case([&](const AwkwardCase& c) {
    const terrain::Window& w = c.frame.window;
    for (std::size_t k = 0; k < std::size(sweeps); ++k) {
      SCOPED_TRACE("sweep " + std::to_string(k));
      visibility::WorkStats stats;
      terrain::Grid<float> fresh;
      ASSERT_TRUE(
          visibility::radial_ohf(c.z, c.frame, sweeps[k].options, 2, nullptr, fresh, stats, sweeps[k].bound).ok());
      terrain::Grid<float> same(w.width(), w.height(), kSentinel), larger(w.width() + 7, w.height() + 3, kSentinel);
      for (terrain::Grid<float>* reused : {&same, &larger}) {
        ASSERT_TRUE(
            visibility::radial_ohf(c.z, c.frame, sweeps[k].options, 2, nullptr, *reused, stats, sweeps[k].bound).ok());
        ASSERT_EQ(reused->width(), w.width());
        ASSERT_EQ(reused->height(), w.height());
        EXPECT_EQ(std::memcmp(reused->data(), fresh.data(), fresh.size() * sizeof(float)), 0);
      }
      std::size_t answered = 0;
      for (int row = w.row0; row < w.row1; ++row)
        for (int col = w.col0; col < w.col1; ++col) {
          const float v = same.at(col - w.col0, row - w.row0);
          ASSERT_NE(v, kSentinel) << col << "," << row;
          const bool answers = c.frame.in_range(col, row) && !std::isnan(c.z.at(col, row));
          ASSERT_EQ(!std::isnan(v), answers) << col << "," << row;
          answered += answers;
        }
      EXPECT_EQ(stats.cells_evaluated, answered);
    }
  });
}

// radial_mask codes each cell in the sweep: it must give, byte for byte,
// the mask visibility_mask() makes from radial_ohf's OHF, and the same
// counts, into a grid full of a sentinel that no code has. Every awkward
// case, at two target heights.
TEST(RadialSweep, MaskIsTheOhfsMaskByteForByte) {
  constexpr std::uint8_t kSentinel = 77;
  int with_out_of_range = 0, with_nodata_out_of_range = 0;
  for_each_awkward_case([&](const AwkwardCase& c) {
    const terrain::Window& w = c.frame.window;
    for (const double target : {0.0, 3.5}) {
      SCOPED_TRACE("target " + std::to_string(target));
      // The mask by way of the OHF.
      visibility::ViewshedResult by_ohf;
      by_ohf.frame = c.frame;
      visibility::WorkStats ohf_stats;
      ASSERT_TRUE(visibility::radial_ohf(c.z, c.frame, c.options.radial, 2, nullptr, by_ohf.ohf, ohf_stats).ok());
      terrain::copy_cells(c.z.sub(w), by_ohf.terrain);
      visibility::AnswerCounts expected;
      const auto want = visibility::visibility_mask(by_ohf, target, 2, &expected);
      // The mask from the sweep, into a sentinel grid larger than the window.
      terrain::Grid<std::uint8_t> got(w.width() + 5, w.height() + 2, kSentinel);
      visibility::AnswerCounts counts;
      visibility::WorkStats stats;
      ASSERT_TRUE(visibility::radial_mask(c.z, c.frame, c.options.radial, target, 2, nullptr, got, counts, stats).ok());
      ASSERT_EQ(got.width(), w.width());
      ASSERT_EQ(got.height(), w.height());
      for (int row = 0; row < w.height(); ++row)
        for (int col = 0; col < w.width(); ++col)
          ASSERT_EQ(int(got.at(col, row)), int(want.at(col, row))) << col + w.col0 << "," << row + w.row0;
      EXPECT_EQ(counts.visible, expected.visible);
      EXPECT_EQ(counts.hidden, expected.hidden);
      EXPECT_EQ(counts.out_of_range, expected.out_of_range);
      EXPECT_EQ(counts.nodata, expected.nodata);
      EXPECT_EQ(counts.visible + counts.hidden + counts.out_of_range + counts.nodata, w.cell_count());
      EXPECT_EQ(stats.cells_evaluated, ohf_stats.cells_evaluated);
      EXPECT_EQ(stats.terrain_samples, ohf_stats.terrain_samples);
      EXPECT_GT(counts.visible, 0u);
      EXPECT_GT(counts.hidden, 0u);
      with_out_of_range += counts.out_of_range > 0;
      with_nodata_out_of_range += counts.out_of_range > 0 && counts.nodata > 0 && !c.filled;
    }
  });
  // The cases reach every class, voids beyond max distance included.
  EXPECT_GT(with_out_of_range, 0);
  EXPECT_GT(with_nodata_out_of_range, 0);
}

// Only the re-sampling blend codes cells in the sweep; the others say so.
TEST(RadialSweep, MaskNeedsTheResamplingBlend) {
  const auto dem = testing::make_random_terrain(40, 40, 5);
  visibility::ViewshedOptions o;
  const auto f = visibility::make_view_frame(dem, eye_at(dem, 20, 20, 2.0), o);
  ASSERT_TRUE(f.ok());
  terrain::Grid<std::uint8_t> mask;
  visibility::AnswerCounts counts;
  visibility::WorkStats stats;
  const visibility::RadialOptions linear{1.0, visibility::RayBlend::kLinear, 0};
  const Status s = visibility::radial_mask(visibility::elevation_view(dem.elevation, o), *f, linear, 0.0, 1, nullptr,
                                           mask, counts, stats);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kInvalidArgument);
  EXPECT_EQ(s.error().field, "ray_blend");
}

TEST(RadialSweep, FinerRaySpacingApproachesR3) {
  const auto dem = testing::make_random_terrain(161, 161, 21);
  const auto eye = eye_at(dem, 80, 80, 2.0);
  visibility::ViewshedOptions o;
  o.algorithm = Algorithm::kR3;
  auto exact = visibility::compute_viewshed(dem, eye, o);
  ASSERT_TRUE(exact.ok());
  o.algorithm = Algorithm::kRadial;
  o.radial.ray_spacing = 2.0;
  auto coarse = visibility::compute_viewshed(dem, eye, o);
  o.radial.ray_spacing = 0.25;
  auto fine = visibility::compute_viewshed(dem, eye, o);
  ASSERT_TRUE(coarse.ok() && fine.ok());
  const auto ac = visibility::compare_viewsheds(*coarse, *exact, 0.0);
  const auto af = visibility::compare_viewsheds(*fine, *exact, 0.0);
  EXPECT_LT(af.ohf_rmse, ac.ohf_rmse);
  EXPECT_GE(af.iou, ac.iou);
  EXPECT_GT(fine->stats.terrain_samples, 4 * coarse->stats.terrain_samples);  // 8x the rays
}

TEST(RadialSweep, MinBlendNeverMissesMoreThanLinear) {
  const auto dem = testing::make_random_terrain(161, 161, 22);
  const auto eye = eye_at(dem, 40, 120, 2.0);
  visibility::ViewshedOptions o;
  o.algorithm = Algorithm::kR3;
  auto exact = visibility::compute_viewshed(dem, eye, o);
  o.algorithm = Algorithm::kRadial;
  o.radial.blend = visibility::RayBlend::kLinear;
  auto linear = visibility::compute_viewshed(dem, eye, o);
  o.radial.blend = visibility::RayBlend::kMin;
  auto low = visibility::compute_viewshed(dem, eye, o);
  ASSERT_TRUE(exact.ok() && linear.ok() && low.ok());
  EXPECT_LE(visibility::compare_viewsheds(*low, *exact, 0.0).missed_visible,
            visibility::compare_viewsheds(*linear, *exact, 0.0).missed_visible);
}

// A caller that skips the plan (compute_viewshed, radial_ohf, radial_mask)
// with a ray spacing so fine that the rays would overflow the sweep's int
// counts gets an error naming ray_spacing, not undefined behaviour.
TEST(RadialSweep, TooManyRaysAreRefusedWithoutAPlan) {
  const auto dem = grid_dem(30, 30, [](int c, int r) { return 0.5 * c + 0.25 * r; });
  visibility::ViewshedOptions o;
  o.radial.ray_spacing = 1e-300;
  auto vs = visibility::compute_viewshed(dem, eye_at(dem, 15, 15, 2), o);
  ASSERT_FALSE(vs.ok());
  EXPECT_EQ(vs.error().code, ErrorCode::kResourceExhausted);
  EXPECT_EQ(vs.error().field, "ray_spacing");
  const auto f = visibility::make_view_frame(dem, eye_at(dem, 15, 15, 2), o);
  ASSERT_TRUE(f.ok());
  terrain::Grid<std::uint8_t> mask;
  visibility::AnswerCounts counts;
  visibility::WorkStats stats;
  const Status s = visibility::radial_mask(visibility::elevation_view(dem.elevation, o), *f, o.radial, 0.0, 1, nullptr,
                                           mask, counts, stats);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().field, "ray_spacing");
  // The finest spacing the options allow in practice still runs.
  o.radial.ray_spacing = 0.01;
  EXPECT_TRUE(visibility::compute_viewshed(dem, eye_at(dem, 15, 15, 2), o).ok());
}

TEST(RadialSweep, RejectsBadKnobs) {
  const auto dem = grid_dem(10, 10, [](int, int) { return 0.0; });
  visibility::ViewshedOptions o;
  o.radial.ray_spacing = 0.0;
  auto vs = visibility::compute_viewshed(dem, eye_at(dem, 5, 5, 2), o);
  ASSERT_FALSE(vs.ok());
  EXPECT_EQ(vs.error().field, "ray_spacing");
  o = {};
  o.max_distance = -5;
  vs = visibility::compute_viewshed(dem, eye_at(dem, 5, 5, 2), o);
  ASSERT_FALSE(vs.ok());
  EXPECT_EQ(vs.error().field, "max_distance");
  EXPECT_NE(vs.error().message.find("-5"), std::string::npos);
  o = {};
  o.target_height = std::nan("");
  vs = visibility::compute_viewshed(dem, eye_at(dem, 5, 5, 2), o);
  ASSERT_FALSE(vs.ok());
  EXPECT_EQ(vs.error().field, "target_height");
  o = {};
  o.curvature_coefficient = std::numeric_limits<double>::infinity();
  vs = visibility::compute_viewshed(dem, eye_at(dem, 5, 5, 2), o);
  ASSERT_FALSE(vs.ok());
  EXPECT_EQ(vs.error().field, "curvature_coefficient");
}

}  // namespace
}  // namespace horizon
