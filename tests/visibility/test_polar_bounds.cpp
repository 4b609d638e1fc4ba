// PolarBounds (core/src/visibility/polar_bounds.hpp), the ring-and-direction
// bounds the exact sweep skips near-eye stretches with: every R3 crossing of
// every sight line, at a distance in ring k, has a slope at most the ring's
// bound in the line's direction. Checked crossing by crossing, through R3's
// own enumeration (crossings.hpp), for eyes on a cell centre, on a grid
// line, off the grid lines and in a corner, over terrain with voids, with
// and without curvature.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "crossings.hpp"
#include "horizon/visibility/view_frame.hpp"
#include "polar_bounds.hpp"
#include "test_support.hpp"
#include "visibility_test_util.hpp"

namespace horizon::visibility {
namespace {

using detail::PolarBounds;

struct Count {
  long crossings = 0, bounded = 0;
};

// Every crossing of the sight lines from the eye to each cell of `dem`
// that lies in a ring, against that ring's bound in the line's direction
// (no tolerance: the bound must hold as computed). Returns how many
// crossings were checked and how many held.
Count check_every_crossing(const terrain::Dem& dem, const geodesy::GridPoint& eye, double curvature) {
  ViewshedOptions o;
  o.curvature_coefficient = curvature;
  auto frame = make_view_frame(dem, eye, o);
  EXPECT_TRUE(frame.ok()) << frame.error().message;
  const ViewFrame& f = *frame;
  const double cell = std::max(f.metres_per_col, f.metres_per_row);
  const PolarBounds polar(dem.elevation, f, 40 * cell, 2);
  EXPECT_GE(polar.outer(polar.rings() - 1), 40 * cell);
  Count n;
  for (int row = 0; row < dem.elevation.height(); ++row)
    for (int col = 0; col < dem.elevation.width(); ++col) {
      const double total = f.distance(col, row);
      if (total == 0) continue;
      const double angle = PolarBounds::pseudo_angle(col - f.observer_col, row - f.observer_row);
      detail::for_each_crossing(dem.elevation, f.observer_col, f.observer_row, col, row,
                                [&](double t, double, double, double terrain) {
                                  const double s = detail::r3_slope(f, total, t, terrain);
                                  if (std::isnan(s)) return;  // a void: never a maximum
                                  const double d = t * total;
                                  for (int k = 0; k < polar.rings(); ++k) {
                                    if (d < polar.inner(k) || d > polar.outer(k)) continue;
                                    ++n.crossings;
                                    const float b = polar.bound(k, angle);
                                    if (s <= b) {
                                      ++n.bounded;
                                    } else {
                                      ADD_FAILURE() << "target (" << col << ", " << row << ") crossing at t " << t
                                                    << ", d " << d << " m: slope " << s << " above ring " << k
                                                    << "'s bound " << b;
                                    }
                                  }
                                });
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

TEST(PolarBounds, BoundEveryCrossingForEyesOnAndOffTheGridLines) {
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
        const Count n = check_every_crossing(dem, testing::eye_at(dem, spot[0], spot[1], height), curvature);
        EXPECT_GT(n.crossings, 10000) << spot[0] << "," << spot[1];
        EXPECT_EQ(n.bounded, n.crossings);
      }
}

// The bound is worth having: on a flat plain below the eye every near ring
// is bounded below zero, while a single peak raises the bound only in the
// directions it covers.
TEST(PolarBounds, FollowsTheDirectionOfAPeak) {
  auto dem = testing::make_random_terrain(81, 81, 1, 0.0, 10.0);
  for (float& z : dem.elevation.values()) z = 100.0f;
  dem.elevation.at(60, 40) = 150.0f;  // east of the eye, 20 cells
  ViewshedOptions o;
  o.curvature_coefficient = 0.0;
  auto frame = make_view_frame(dem, testing::eye_at(dem, 40, 40, 2.0), o);
  ASSERT_TRUE(frame.ok());
  const PolarBounds polar(dem.elevation, *frame, 400.0, 1);
  const double east = PolarBounds::pseudo_angle(1, 0), north = PolarBounds::pseudo_angle(0, -1);
  for (int k = 0; k < polar.rings(); ++k) {
    EXPECT_LT(polar.bound(k, north), 0.0f) << "ring " << k;  // flat, 2 m below the eye
    const bool holds_peak = polar.inner(k) <= 210.0 && polar.outer(k) >= 190.0;
    if (holds_peak) EXPECT_GT(polar.bound(k, east), 0.2f) << "ring " << k;  // 48 m up at about 200 m
    else EXPECT_LT(polar.bound(k, east), 0.0f) << "ring " << k;
  }
}

// beyond(k, a) lets a sight line stop at ring k: it must be at least the
// bound of ring k and of every ring outside it in that direction. It reads
// ring k's coarser directions, so it may be higher, but mostly it is that
// highest bound exactly, and on the outermost ring it is the ring's own.
TEST(PolarBounds, BeyondBoundsTheRingAndThoseOutsideIt) {
  const auto dem = holey(91, 3);
  auto frame = make_view_frame(dem, testing::eye_at(dem, 40.3, 45.2, 2.0), ViewshedOptions{});
  ASSERT_TRUE(frame.ok()) << frame.error().message;
  const PolarBounds polar(dem.elevation, *frame, 45 * frame->metres_per_col, 2);
  ASSERT_GE(polar.rings(), 4);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> angle(0.0, 4.0);
  int checked = 0, equal = 0;
  for (int i = 0; i < 20000; ++i) {
    const double a = angle(rng);
    const int last = polar.rings() - 1;
    ASSERT_EQ(polar.beyond(last, a), polar.bound(last, a)) << "angle " << a;
    for (int k = 0; k < last; ++k) {
      float highest = -std::numeric_limits<float>::infinity();
      for (int j = k; j <= last; ++j) highest = std::max(highest, polar.bound(j, a));
      ASSERT_GE(polar.beyond(k, a), highest) << "angle " << a << ", ring " << k;
      ++checked;
      equal += polar.beyond(k, a) == highest;
    }
  }
  EXPECT_GT(equal, checked / 2);
}

TEST(PolarBounds, PseudoAngleIsMonotoneAroundTheCircle) {
  double last = -1;
  for (int i = 0; i < 3600; ++i) {
    const double a = 2 * M_PI * i / 3600;
    const double p = PolarBounds::pseudo_angle(std::cos(a), std::sin(a));
    EXPECT_GE(p, 0.0);
    EXPECT_LT(p, 4.0);
    EXPECT_GT(p, last) << i;
    last = p;
  }
  EXPECT_DOUBLE_EQ(PolarBounds::pseudo_angle(-1, 0), 2.0);  // half a turn: 2
}

}  // namespace
}  // namespace horizon::visibility
