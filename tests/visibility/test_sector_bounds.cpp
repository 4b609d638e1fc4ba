// SectorBounds (core/src/visibility/sector_bounds.hpp), the direction-sector
// and grid-line bounds the exact sweep skips near crossings with: every R3
// crossing of every sight line within reach has a slope at most its line's
// bound in the line's sector. Checked crossing by crossing, through R3's own
// enumeration (crossings.hpp), for eyes on a cell centre, on a grid line,
// off the grid lines and in a corner, over terrain with voids, with and
// without curvature, with square and oblong cells.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "crossings.hpp"
#include "horizon/visibility/view_frame.hpp"
#include "sector_bounds.hpp"
#include "test_support.hpp"
#include "visibility_test_util.hpp"

namespace horizon::visibility {
namespace {

using detail::Axis;
using detail::SectorBounds;

struct Count {
  long crossings = 0, bounded = 0;  // within reach, against their line's bound
  long far = 0, far_bounded = 0;    // beyond it, against beyond()
};

// The entry of `line` in `lines`, or -1 when the table has none.
int entry_of(const SectorBounds::Lines& lines, int line) {
  const int j = (line - lines.first) * lines.step;
  return j >= 0 && j < lines.count ? j : -1;
}

// Every crossing of the sight lines from the eye to each cell of `dem`
// within `reach_cells` cells, against its line's bound in the line's
// sector, and every one beyond, against beyond() (no tolerance: the bounds
// must hold as computed); and every block and span maximum against the
// entries it covers; targets every `target_step` cells each way. Returns
// how many crossings were checked and how many held.
Count check_every_crossing(const terrain::Dem& dem, const geodesy::GridPoint& eye, double curvature, double reach_cells,
                           int target_step = 1) {
  ViewshedOptions o;
  o.curvature_coefficient = curvature;
  auto frame = make_view_frame(dem, eye, o);
  EXPECT_TRUE(frame.ok()) << frame.error().message;
  const ViewFrame& f = *frame;
  const double reach = reach_cells * std::min(f.metres_per_col, f.metres_per_row);
  const terrain::Pyramid maxima(dem.elevation, f.window, terrain::Reduction::kMax, {}, {});
  const SectorBounds sectors(dem.elevation, maxima, f, reach, 2);
  EXPECT_EQ(sectors.reach(), reach);
  Count n;
  for (int row = 0; row < dem.elevation.height(); row += target_step)
    for (int col = 0; col < dem.elevation.width(); col += target_step) {
      const double total = f.distance(col, row);
      if (total == 0) continue;
      const double angle = SectorBounds::pseudo_angle(col - f.observer_col, row - f.observer_row);
      for (const Axis axis : {Axis::kColumns, Axis::kRows}) {
        const SectorBounds::Lines lines = sectors.lines(angle, axis);
        for (int b = 0; b * SectorBounds::kBlock < lines.count; ++b)
          for (int j = b * SectorBounds::kBlock; j < std::min(lines.count, (b + 1) * SectorBounds::kBlock); ++j) {
            EXPECT_GE(lines.block[b], lines.bound[j]);
            EXPECT_GE(lines.span[j / SectorBounds::kSpan], lines.bound[j]);
          }
        const auto visit = [&](double t, double c, double r, double terrain) {
          const double s = detail::r3_slope(f, total, t, terrain);
          if (std::isnan(s)) return;  // a void never wins
          if (t * total > reach) {
            ++n.far;
            const float b = sectors.beyond(angle, total);
            if (s <= b)
              ++n.far_bounded;
            else
              ADD_FAILURE() << "target (" << col << ", " << row << ") crossing at d " << t * total << " m: slope " << s
                            << " above beyond()'s " << b;
            return;
          }
          ++n.crossings;
          const int line = static_cast<int>(axis == Axis::kColumns ? c : r);
          const int j = entry_of(lines, line);
          if (j >= 0 && s <= lines.bound[j])
            ++n.bounded;
          else
            ADD_FAILURE() << "target (" << col << ", " << row << ") crossing line " << line << " at d " << t * total
                          << " m: slope " << s << " above its bound (entry " << j << ")";
        };
        constexpr int kAll[2] = {std::numeric_limits<int>::min(), std::numeric_limits<int>::max()};
        detail::for_each_crossing_on(axis, dem.elevation, f.observer_col, f.observer_row, col, row, kAll[0], kAll[1],
                                     visit);
      }
    }
  return n;
}

terrain::Dem holey(int size, unsigned seed) {
  auto dem = testing::make_random_terrain(size, size, seed, 300.0, 30.0);
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> pick(0, size - 1);
  for (int i = 0; i < size * size / 40; ++i) dem.elevation.at(pick(rng), pick(rng)) = std::nanf("");
  return dem;
}

TEST(SectorBounds, BoundEveryCrossingForEyesOnAndOffTheGridLines) {
  const auto dem = holey(61, 7);
  // Cell centre, on a column line, just off both lines, 30 nm off a column
  // line, a corner of the grid, just inside the outer edge; eye on the
  // ground and 2 m above it.
  const double spots[][2] = {{30, 30}, {30, 17.5}, {29.99999, 30.0001}, {17.000000001, 17.5}, {0, 0}, {60.49, 12.3}};
  for (const auto& spot : spots)
    for (const double height : {0.0, 2.0})
      for (const double curvature : {0.85714, 0.0}) {
        if (std::isnan(
                dem.elevation.at(static_cast<int>(std::lround(spot[0])), static_cast<int>(std::lround(spot[1])))))
          continue;
        for (const double reach : {40.0, 12.0}) {
          const auto eye = testing::eye_at(dem, spot[0], spot[1], height);
          const Count n = check_every_crossing(dem, eye, curvature, reach);
          EXPECT_GT(n.crossings, 10000) << spot[0] << "," << spot[1];
          EXPECT_EQ(n.bounded, n.crossings);
          EXPECT_GT(n.far, reach < 20 ? 10000 : 0) << spot[0] << "," << spot[1];
          EXPECT_EQ(n.far_bounded, n.far);
        }
      }
}

TEST(SectorBounds, BoundEveryCrossingWithOblongCells) {
  auto dem = holey(61, 11);
  dem.georef.transform = {500000.0, 20.0, 5000000.0, -45.0};  // 20 m across, 45 m down
  for (const double spot : {30.0, 22.5}) {
    const Count n = check_every_crossing(dem, testing::eye_at(dem, spot, 31.2, 2.0), 0.85714, 12.0);
    EXPECT_GT(n.crossings, 10000);
    EXPECT_EQ(n.bounded, n.crossings);
    EXPECT_GT(n.far, 10000);
    EXPECT_EQ(n.far_bounded, n.far);
  }
}

// beyond() over a grid of 7 x 7 of its tiles (64 cells), from an eye off
// the grid lines, with a reach wider than a tile (as the exact sweep's):
// every crossing past the reach, up to the target, of every third target
// each way. The terrain is a plain below the eye with spikes on tile
// edges, tile corners and inside tiles, and voids: only crossings next to
// a spike climb above the horizontal, so each spike's own tile, sectors
// and band must hold them.
TEST(SectorBounds, BeyondBoundsEveryFarCrossing) {
  auto dem = testing::make_dem(
      401, 401, [](int, int) { return 100.0; }, 30.0);
  const int spikes[][2] = {{320, 192}, {256, 320}, {128, 30}, {330, 40}, {64, 300},
                           {200, 390}, {383, 383}, {10, 200}, {263, 63}, {199, 280}};
  for (const auto& spike : spikes) dem.elevation.at(spike[0], spike[1]) = 160.0f;
  std::mt19937 rng(9);
  std::uniform_int_distribution<int> pick(0, 400);
  for (int i = 0; i < 2000; ++i) dem.elevation.at(pick(rng), pick(rng)) = std::nanf("");
  for (const double curvature : {0.85714, 0.0}) {
    const Count n = check_every_crossing(dem, testing::eye_at(dem, 200.3, 160.7, 2.0), curvature, 100.0, 3);
    EXPECT_GT(n.far, 1000000);
    EXPECT_EQ(n.far_bounded, n.far);
  }
}

// The bound is worth having: on a flat plain below the eye every line is
// bounded below zero, while a single peak raises the bound only on its own
// lines in the sectors that look at it.
TEST(SectorBounds, FollowsTheDirectionOfAPeak) {
  auto dem = testing::make_random_terrain(81, 81, 1, 0.0, 10.0);
  for (float& z : dem.elevation.values()) z = 100.0f;
  dem.elevation.at(60, 40) = 150.0f;  // east of the eye, 20 cells
  ViewshedOptions o;
  o.curvature_coefficient = 0.0;
  auto frame = make_view_frame(dem, testing::eye_at(dem, 40, 40, 2.0), o);
  ASSERT_TRUE(frame.ok());
  const terrain::Pyramid maxima(dem.elevation, frame->window, terrain::Reduction::kMax, {}, {});
  const SectorBounds sectors(dem.elevation, maxima, *frame, 400.0, 1);
  const double north = SectorBounds::pseudo_angle(0, -1), east = SectorBounds::pseudo_angle(1, 0.01);
  for (const Axis axis : {Axis::kColumns, Axis::kRows}) {
    const SectorBounds::Lines n = sectors.lines(north, axis);
    for (int j = 0; j < n.count; ++j) EXPECT_LT(n.bound[j], 0.0f) << j;  // flat, 2 m below the eye
  }
  const SectorBounds::Lines columns = sectors.lines(east, Axis::kColumns);
  ASSERT_EQ(columns.step, 1);
  for (int j = 0; j < columns.count; ++j) {
    const int line = columns.first + j;
    if (line == 60)
      EXPECT_GT(columns.bound[j], 0.2f) << line;  // 48 m up at 200 m
    else
      EXPECT_LT(columns.bound[j], 0.0f) << line;
  }
}

TEST(SectorBounds, AtLeastMasksTheValuesAtOrAboveTheFloor) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> value(-2.0f, 2.0f);
  float v[16];
  for (int trial = 0; trial < 200; ++trial) {
    for (float& x : v) x = trial % 7 == 0 ? -std::numeric_limits<float>::infinity() : value(rng);
    const float floor = trial % 5 == 0 ? v[trial % 16] : value(rng);  // ties count as at least
    std::uint32_t expected = 0;
    for (int i = 0; i < 16; ++i) expected |= std::uint32_t(v[i] >= floor) << i;
    EXPECT_EQ(SectorBounds::at_least(v, floor), expected) << trial;
  }
}

// round_up(s) is the smallest float at least s, as std::nextafter gives it.
TEST(SectorBounds, RoundUpIsTheSmallestFloatAtLeastTheDouble) {
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> value(-3.0, 3.0);
  const auto reference = [](double s) {
    const float f = static_cast<float>(s);
    return f < s ? std::nextafter(f, std::numeric_limits<float>::infinity()) : f;
  };
  std::vector<double> cases = {0.0,
                               -0.0,
                               1e-300,
                               -1e-300,
                               1e300,
                               -1e300,
                               1.0,
                               -1.0,
                               0.1,
                               -0.1,
                               -std::numeric_limits<double>::infinity(),
                               std::numeric_limits<double>::infinity(),
                               double(std::numeric_limits<float>::max()) * (1 + 1e-12)};
  for (int i = 0; i < 100000; ++i) cases.push_back(value(rng) * std::pow(10.0, i % 13 - 6));
  for (const double s : cases) {
    const float up = SectorBounds::round_up(s);
    ASSERT_EQ(up, reference(s)) << s;
    ASSERT_GE(double(up), s) << s;
  }
}

TEST(SectorBounds, PseudoAngleIsMonotoneAroundTheCircle) {
  double last = -1;
  for (int i = 0; i < 3600; ++i) {
    const double a = 2 * M_PI * i / 3600;
    const double p = SectorBounds::pseudo_angle(std::cos(a), std::sin(a));
    EXPECT_GE(p, 0.0);
    EXPECT_LT(p, 4.0);
    EXPECT_GT(p, last) << i;
    last = p;
  }
  EXPECT_DOUBLE_EQ(SectorBounds::pseudo_angle(-1, 0), 2.0);  // half a turn: 2
}

}  // namespace
}  // namespace horizon::visibility
