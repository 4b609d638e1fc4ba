// ViewFrame::farthest_distance2: the squared distance from the eye to the
// farthest cell centre of a window, by hand and against every centre.
#include <gtest/gtest.h>

#include <algorithm>

#include "horizon/visibility/view_frame.hpp"

namespace horizon::visibility {
namespace {

// The largest squared distance over every cell centre of `w`, one by one.
double brute_force(const ViewFrame& f, const terrain::Window& w) {
  double worst = 0;
  for (int r = w.row0; r < w.row1; ++r)
    for (int c = w.col0; c < w.col1; ++c) worst = std::max(worst, f.distance(c, r) * f.distance(c, r));
  return worst;
}

TEST(ViewFrame, FarthestDistanceIsAtACornerCentre) {
  ViewFrame f;
  f.observer_col = 2.5;
  f.observer_row = 1;
  f.metres_per_col = 10;
  f.metres_per_row = 20;
  // Eye inside: centres at cols 0..4 and rows 0..3; the farthest is 25 m across and 40 m down.
  const terrain::Window around{0, 0, 5, 4};
  EXPECT_DOUBLE_EQ(f.farthest_distance2(around), 25.0 * 25.0 + 40.0 * 40.0);
  // Eye outside: cols 10..11, rows 5..6; the farthest is col 11 (85 m), row 6 (100 m).
  const terrain::Window away{10, 5, 12, 7};
  EXPECT_DOUBLE_EQ(f.farthest_distance2(away), 85.0 * 85.0 + 100.0 * 100.0);
  for (const terrain::Window& w : {around, away, terrain::Window{2, 1, 3, 2}, terrain::Window{-3, -2, 9, 1}})
    EXPECT_NEAR(f.farthest_distance2(w), brute_force(f, w), 1e-9 * brute_force(f, w) + 1e-12);
}

}  // namespace
}  // namespace horizon::visibility
