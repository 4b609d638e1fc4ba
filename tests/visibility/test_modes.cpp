// The accuracy promises of the algorithm modes (options.hpp), checked against
// brute-force R3 on synthetic terrain with voids and on the bundled real DEMs:
//   exact         bit-identical OHF to R3 (so identical viewsheds at any target height);
//   conservative  OHF never above R3's (so never a missed-visible cell);
//   fast          re-sampled horizons err only towards visible, within float rounding.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <mutex>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "horizon/terrain/dem_reader.hpp"
#include "horizon/visibility/agreement.hpp"
#include "horizon/visibility/viewshed.hpp"
#include "observer_picks.hpp"
#include "test_support.hpp"
#include "visibility_test_util.hpp"

namespace horizon {
namespace {

using testing::eye_at;
using visibility::Algorithm;

// Random hills with a sprinkling of voids, so void-adjacent samples are exercised.
terrain::Dem holey_terrain(int size, unsigned seed, double cell_size = 30.0, double relief = 200.0) {
  auto dem = testing::make_random_terrain(size, size, seed, relief, cell_size);
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> pick(0, size - 1);
  for (int i = 0; i < size * size / 50; ++i) dem.elevation.at(pick(rng), pick(rng)) = std::nanf("");
  return dem;
}

visibility::ViewshedResult run(const terrain::Dem& dem, const geodesy::GridPoint& eye, Algorithm algorithm,
                               double max_distance = std::numeric_limits<double>::infinity(),
                               double curvature = 0.85714) {
  visibility::ViewshedOptions o;
  o.algorithm = algorithm;
  o.max_distance = max_distance;
  o.curvature_coefficient = curvature;
  auto vs = visibility::compute_viewshed(dem, eye, o);
  EXPECT_TRUE(vs.ok()) << vs.error().message;
  return std::move(vs).value();
}

// Bitwise equality of two OHF grids (NaN equal to NaN).
::testing::AssertionResult same_ohf(const visibility::ViewshedResult& a, const visibility::ViewshedResult& b) {
  if (a.frame.window != b.frame.window) return ::testing::AssertionFailure() << "windows differ";
  for (int r = 0; r < a.ohf.height(); ++r)
    for (int c = 0; c < a.ohf.width(); ++c) {
      const float x = a.ohf.at(c, r), y = b.ohf.at(c, r);
      if (std::memcmp(&x, &y, sizeof x) != 0 && !(std::isnan(x) && std::isnan(y)))
        return ::testing::AssertionFailure() << "cell " << c << "," << r << ": " << x << " vs " << y;
    }
  return ::testing::AssertionSuccess();
}

// Cells where `a`'s OHF exceeds `b`'s (both answered).
int cells_above(const visibility::ViewshedResult& a, const visibility::ViewshedResult& b) {
  int n = 0;
  for (std::size_t i = 0; i < a.ohf.size(); ++i) {
    const float x = a.ohf.values()[i], y = b.ohf.values()[i];
    if (!std::isnan(x) && !std::isnan(y) && x > y) ++n;
  }
  return n;
}

TEST(Modes, ExactIsBitIdenticalToR3OnSyntheticTerrainWithVoids) {
  for (unsigned seed : {31u, 32u, 33u}) {
    const auto dem = holey_terrain(121, seed);
    for (auto [col, row] : {std::pair{60.0, 60.0}, {0.0, 0.0}, {119.5, 33.25}, {3.0, 110.0}}) {
      const auto eye = eye_at(dem, col, row, 2.0);
      if (!std::isfinite(eye.elevation)) continue;  // observer on a void
      EXPECT_TRUE(same_ohf(run(dem, eye, Algorithm::kExact), run(dem, eye, Algorithm::kR3)))
          << "seed " << seed << " eye " << col << "," << row;
    }
  }
}

// Regression: at continental scale (1-degree cells, OHF in the millions of
// metres from curvature) and at 2 m cells, the float rounding of the lower
// bound exceeded the pruning margin and the exact sweep pruned R3's maximum.
TEST(Modes, ExactSurvivesTheFloatRoundingOfItsBoundAtEveryScale) {
  for (auto [cell, relief] : {std::pair{111000.0, 6000.0}, std::pair{2.0, 60.0}}) {
    const auto dem = holey_terrain(91, 35, cell, relief);
    for (auto [col, row] : {std::pair{45.0, 45.0}, {3.0, 60.0}}) {
      const auto eye = eye_at(dem, col, row, 2.0);
      if (!std::isfinite(eye.elevation)) continue;
      EXPECT_TRUE(same_ohf(run(dem, eye, Algorithm::kExact), run(dem, eye, Algorithm::kR3))) << "cell " << cell;
    }
  }
}

TEST(Modes, ExactIsBitIdenticalToR3WithMaxDistanceAndFlatEarth) {
  const auto dem = holey_terrain(151, 34);
  const auto eye = eye_at(dem, 75, 70, 10.0);
  EXPECT_TRUE(same_ohf(run(dem, eye, Algorithm::kExact, 400.0), run(dem, eye, Algorithm::kR3, 400.0)));
  EXPECT_TRUE(same_ohf(run(dem, eye, Algorithm::kExact, 1e9, 0.0), run(dem, eye, Algorithm::kR3, 1e9, 0.0)));
}

TEST(Modes, ConservativeOhfNeverExceedsR3) {
  for (unsigned seed : {41u, 42u}) {
    const auto dem = holey_terrain(131, seed);
    for (auto [col, row] : {std::pair{65.0, 65.0}, {2.0, 128.0}, {100.5, 20.5}}) {
      const auto eye = eye_at(dem, col, row, 2.0);
      if (!std::isfinite(eye.elevation)) continue;
      const auto cons = run(dem, eye, Algorithm::kConservative);
      const auto r3 = run(dem, eye, Algorithm::kR3);
      EXPECT_EQ(cells_above(cons, r3), 0) << "seed " << seed;
      EXPECT_EQ(visibility::compare_viewsheds(cons, r3, 0.0).missed_visible, 0u);
      EXPECT_EQ(visibility::compare_viewsheds(cons, r3, 3.0).missed_visible, 0u);
      // A max-distance window starts away from the DEM's corner (window-based indices inside).
      EXPECT_EQ(cells_above(run(dem, eye, Algorithm::kConservative, 1500.0), run(dem, eye, Algorithm::kR3, 1500.0)), 0);
    }
  }
}

// The bundled real DEMs, at the accuracy report's observers: exact agrees
// 100 %, conservative misses nothing, and neither is trivially loose.
class BundledModes : public ::testing::TestWithParam<const char*> {};

// The accuracy report's observers on `dem`, 2 m above ground: (kind, eye).
std::vector<std::pair<std::string, geodesy::GridPoint>> report_eyes(const terrain::Dem& dem) {
  std::vector<std::pair<std::string, geodesy::GridPoint>> eyes;
  for (const auto& pick : accuracy::pick_observers(dem)) {
    auto eye = accuracy::pick_eye(dem, pick, 2.0);
    EXPECT_TRUE(eye.ok()) << eye.error().message;
    if (eye.ok()) eyes.emplace_back(pick.kind, *eye);
  }
  return eyes;
}

TEST_P(BundledModes, ExactMatchesAndConservativeNeverMisses) {
  auto dem = terrain::read_dem(testing::bundled_dem(GetParam()));
  ASSERT_TRUE(dem.ok()) << dem.error().message;
  for (const auto& [kind, eye] : report_eyes(*dem)) {
    const auto r3 = run(*dem, eye, Algorithm::kR3);
    EXPECT_TRUE(same_ohf(run(*dem, eye, Algorithm::kExact), r3)) << kind;
    const auto cons = run(*dem, eye, Algorithm::kConservative);
    EXPECT_EQ(cells_above(cons, r3), 0) << kind;
    const auto a = visibility::compare_viewsheds(cons, r3, 0.0);
    EXPECT_EQ(a.missed_visible, 0u) << kind;
    EXPECT_GE(a.iou, 0.97) << kind;
  }
}

INSTANTIATE_TEST_SUITE_P(DataDem, BundledModes,
                         ::testing::Values("everest_summit_voids_srtm3_300x300.tif", "olinda_coast_utm25s_111x111.tif",
                                           "rainier_summit_srtm3_400x400.tif"),
                         [](const ::testing::TestParamInfo<const char*>& test) {
                           return testing::dem_name(test.param);
                         });

// ViewshedOptions::visibility_only: exact decides each cell as R3 does at the
// requested target height, without finding R3's OHF, and samples less.
::testing::AssertionResult same_mask(const visibility::ViewshedResult& a, const visibility::ViewshedResult& b,
                                     double target_height) {
  const auto ma = visibility::visibility_mask(a, target_height), mb = visibility::visibility_mask(b, target_height);
  for (int r = 0; r < ma.height(); ++r)
    for (int c = 0; c < ma.width(); ++c)
      if (ma.at(c, r) != mb.at(c, r))
        return ::testing::AssertionFailure() << "cell " << c << "," << r << ": " << int(ma.at(c, r)) << " vs "
                                             << int(mb.at(c, r)) << " (R3 OHF " << b.ohf.at(c, r) << ")";
  return ::testing::AssertionSuccess();
}

visibility::ViewshedResult run_decided(const terrain::Dem& dem, const geodesy::GridPoint& eye, double target_height,
                                       double max_distance = std::numeric_limits<double>::infinity()) {
  visibility::ViewshedOptions o;
  o.algorithm = Algorithm::kExact;
  o.visibility_only = true;
  o.target_height = target_height;
  o.max_distance = max_distance;
  auto vs = visibility::compute_viewshed(dem, eye, o);
  EXPECT_TRUE(vs.ok()) << vs.error().message;
  return std::move(vs).value();
}

TEST(Modes, ExactVisibilityOnlyGivesR3sViewshedAtEveryTargetHeight) {
  for (unsigned seed : {51u, 52u}) {
    const auto dem = holey_terrain(141, seed);
    for (auto [col, row] : {std::pair{70.0, 70.0}, {1.0, 139.0}, {100.5, 20.25}}) {
      const auto eye = eye_at(dem, col, row, 2.0);
      if (!std::isfinite(eye.elevation)) continue;
      const auto r3 = run(dem, eye, Algorithm::kR3);
      const auto full = run(dem, eye, Algorithm::kExact);
      for (double target : {0.0, 0.0005, 3.0, 40.0}) {
        const auto decided = run_decided(dem, eye, target);
        EXPECT_TRUE(same_mask(decided, r3, target)) << "seed " << seed << " target " << target;
        EXPECT_LT(decided.stats.terrain_samples, full.stats.terrain_samples) << "seed " << seed;
      }
      EXPECT_TRUE(same_mask(run_decided(dem, eye, 1.0, 1200.0), run(dem, eye, Algorithm::kR3, 1200.0), 1.0));
    }
  }
}

TEST_P(BundledModes, ExactVisibilityOnlyGivesR3sViewshed) {
  auto dem = terrain::read_dem(testing::bundled_dem(GetParam()));
  ASSERT_TRUE(dem.ok()) << dem.error().message;
  for (const auto& [kind, eye] : report_eyes(*dem)) {
    const auto r3 = run(*dem, eye, Algorithm::kR3);
    for (double target : {0.0, 10.0}) EXPECT_TRUE(same_mask(run_decided(*dem, eye, target), r3, target)) << kind;
  }
}

TEST(Modes, ThinningMarchesFewerRaySteps) {
  const auto dem = testing::make_random_terrain(201, 201, 51);
  const auto eye = eye_at(dem, 100, 100, 2.0);
  visibility::ViewshedOptions o;
  auto full = visibility::compute_viewshed(dem, eye, o);
  o.radial.thinning_levels = 4;
  auto thin = visibility::compute_viewshed(dem, eye, o);
  ASSERT_TRUE(full.ok() && thin.ok());
  EXPECT_LT(thin->stats.terrain_samples, full->stats.terrain_samples * 3 / 4);
  EXPECT_EQ(thin->stats.cells_evaluated, full->stats.cells_evaluated);
  o.radial.thinning_levels = 7;
  auto bad = visibility::compute_viewshed(dem, eye, o);
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().field, "thinning_levels");
}

TEST(Modes, AlgorithmNamesRoundTrip) {
  for (Algorithm a : {Algorithm::kRadial, Algorithm::kR3, Algorithm::kExact, Algorithm::kConservative})
    EXPECT_EQ(visibility::parse_algorithm(visibility::algorithm_name(a)), a);
  EXPECT_EQ(visibility::algorithm_name(Algorithm::kRadial), "fast");
  EXPECT_FALSE(visibility::parse_algorithm("fastest").has_value());
}

}  // namespace
}  // namespace horizon

namespace horizon {
namespace {

// float32 against double: fast re-samples in float, conservative takes the
// same candidate samples through R3's double arithmetic, so on void-free
// terrain the two OHFs differ only by rounding. Stated tolerance: 0.1 m plus
// 1e-5 of the OHF's height above or below the eye, from 0.25 m to 1 km cells
// and from the Dead Sea shore to Everest.
TEST(Modes, FloatAndDoubleAgreeWithinTheStatedTolerance) {
  struct Case {
    double cell, base, relief;
  };
  for (const Case& k : {Case{0.25, -430.0, 20.0}, Case{30.0, 1000.0, 800.0}, Case{1000.0, 8000.0, 848.0}}) {
    auto dem = testing::make_random_terrain(181, 181, 61, k.relief, k.cell);
    for (float& z : dem.elevation.values()) z += static_cast<float>(k.base);
    const auto eye = eye_at(dem, 90, 90, 2.0);
    const auto fast = run(dem, eye, Algorithm::kRadial);
    const auto precise = run(dem, eye, Algorithm::kConservative);
    double worst = 0;
    for (std::size_t i = 0; i < fast.ohf.size(); ++i) {
      const double a = fast.ohf.values()[i], b = precise.ohf.values()[i];
      if (!std::isfinite(a) || !std::isfinite(b)) {
        EXPECT_EQ(std::isnan(a), std::isnan(b));
        continue;
      }
      const double excess = std::abs(a - b) - (0.1 + 1e-5 * std::abs(b - eye.elevation));
      worst = std::max(worst, excess);
    }
    EXPECT_LE(worst, 0.0) << "cell " << k.cell << " m, base " << k.base << " m";
  }
}

}  // namespace
}  // namespace horizon

namespace horizon {
namespace {

TEST(Modes, ExactReportsProgressOnceThroughAndHonoursCancel) {
  const auto dem = testing::make_random_terrain(101, 101, 71);
  const auto eye = eye_at(dem, 50, 50, 2.0);
  visibility::ViewshedOptions o;
  o.algorithm = Algorithm::kExact;
  std::mutex m;
  std::vector<double> seen;
  RunControl control;
  control.progress = [&](double x) {
    std::lock_guard lock(m);
    seen.push_back(x);
  };
  ASSERT_TRUE(visibility::compute_viewshed(dem, eye, o, &control).ok());
  ASSERT_FALSE(seen.empty());
  EXPECT_DOUBLE_EQ(*std::max_element(seen.begin(), seen.end()), 1.0);
  // The bound's share comes first: nothing at or above 5 % is reported before the bound is done.
  const auto first_late = std::find_if(seen.begin(), seen.end(), [](double x) { return x > 0.05; });
  EXPECT_TRUE(std::all_of(first_late, seen.end(), [](double x) { return x > 0.05; }));

  CancelToken cancel;
  cancel.cancel();
  RunControl stopped;
  stopped.cancel = &cancel;
  auto vs = visibility::compute_viewshed(dem, eye, o, &stopped);
  ASSERT_FALSE(vs.ok());
  EXPECT_EQ(vs.error().code, ErrorCode::kCancelled);
}

}  // namespace
}  // namespace horizon

namespace horizon {
namespace {

// A window read hands the engine a crop of the file around the max-distance
// window; every algorithm must give the same bytes as on the whole file.
TEST(Modes, ResultsDoNotDependOnTerrainOutsideTheWindow) {
  const auto dem = holey_terrain(161, 81);
  const auto eye = eye_at(dem, 70, 90, 3.0);
  const double max_distance = 40 * 30.0;  // 40 cells
  terrain::Dem crop = dem;
  const int c0 = 70 - 43, r0 = 90 - 43, size = 87;  // window (81 x 81) plus a 3-cell margin
  crop.elevation = terrain::Grid<float>(size, size);
  for (int r = 0; r < size; ++r)
    for (int c = 0; c < size; ++c) crop.elevation.at(c, r) = dem.elevation.at(c0 + c, r0 + r);
  crop.georef.transform = dem.georef.transform.shifted(c0, r0);
  auto crop_eye = eye;
  crop_eye.col -= c0;
  crop_eye.row -= r0;
  for (Algorithm a : {Algorithm::kRadial, Algorithm::kConservative, Algorithm::kExact, Algorithm::kR3}) {
    const auto whole = run(dem, eye, a, max_distance);
    const auto part = run(crop, crop_eye, a, max_distance);
    ASSERT_EQ(whole.ohf.width(), part.ohf.width());
    ASSERT_EQ(whole.ohf.height(), part.ohf.height());
    for (std::size_t i = 0; i < whole.ohf.size(); ++i) {
      const float x = whole.ohf.values()[i], y = part.ohf.values()[i];
      ASSERT_TRUE(std::memcmp(&x, &y, sizeof x) == 0 || (std::isnan(x) && std::isnan(y)))
          << visibility::algorithm_name(a) << " cell " << i << ": " << x << " vs " << y;
    }
  }
}

}  // namespace
}  // namespace horizon
