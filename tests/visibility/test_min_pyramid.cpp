// MinPyramid: exact rectangle minima against brute force, and its cost.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include "horizon/visibility/min_pyramid.hpp"

namespace horizon::visibility {
namespace {

float brute_min(const terrain::Grid<float>& g, const terrain::Window& w) {
  float m = std::numeric_limits<float>::infinity();
  for (int r = w.row0; r < w.row1; ++r)
    for (int c = w.col0; c < w.col1; ++c) {
      const float v = g.at(c, r);
      m = std::min(m, std::isnan(v) ? -std::numeric_limits<float>::infinity() : v);
    }
  return m;
}

TEST(MinPyramid, LevelsHalveDownToOneCellRoundingUp) {
  const terrain::Grid<float> g(5, 3, 1.0f);
  const MinPyramid p(g);
  ASSERT_EQ(p.level_count(), 4);  // 5x3, 3x2, 2x1, 1x1
  EXPECT_EQ(p.level(1).width(), 3);
  EXPECT_EQ(p.level(1).height(), 2);
  EXPECT_EQ(p.level(2).width(), 2);
  EXPECT_EQ(p.level(2).height(), 1);
  EXPECT_EQ(p.level(3).width(), 1);
  EXPECT_EQ(p.level(3).height(), 1);
}

TEST(MinPyramid, HandComputedThreeByThree) {
  // 9 8 7
  // 6 5 4
  // 3 2 1
  terrain::Grid<float> g(3, 3);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) g.at(c, r) = static_cast<float>(9 - 3 * r - c);
  const MinPyramid p(g);
  EXPECT_EQ(p.level(1).at(0, 0), 5.0f);
  EXPECT_EQ(p.level(1).at(1, 0), 4.0f);  // odd edge: column 2 only
  EXPECT_EQ(p.level(1).at(0, 1), 2.0f);
  EXPECT_EQ(p.level(1).at(1, 1), 1.0f);
  EXPECT_EQ(p.min_in({0, 0, 2, 2}), 5.0f);
  EXPECT_EQ(p.min_in({0, 0, 3, 1}), 7.0f);
  EXPECT_EQ(p.min_in({1, 0, 2, 3}), 2.0f);
  EXPECT_EQ(p.min_in({0, 0, 1, 1}), 9.0f);
  EXPECT_EQ(p.min_in({0, 0, 3, 3}), 1.0f);
}

TEST(MinPyramid, NoAnswerCellsReadAsMinusInfinity) {
  terrain::Grid<float> g(4, 4, 10.0f);
  g.at(2, 3) = std::numeric_limits<float>::quiet_NaN();
  const MinPyramid p(g);
  EXPECT_EQ(p.min_in({0, 0, 4, 3}), 10.0f);
  EXPECT_EQ(p.min_in({2, 3, 3, 4}), -std::numeric_limits<float>::infinity());
  EXPECT_EQ(p.min_in({0, 0, 4, 4}), -std::numeric_limits<float>::infinity());
}

TEST(MinPyramid, EqualsBruteForceOnRandomRectangles) {
  std::mt19937 rng(1234);
  for (auto [w, h] : {std::pair{1, 1}, {1, 17}, {33, 1}, {64, 64}, {100, 37}, {257, 129}}) {
    terrain::Grid<float> g(w, h);
    std::uniform_real_distribution<float> value(-50.0f, 3000.0f);
    for (float& v : g.values()) v = value(rng);
    for (int k = 0; k < 5; ++k) g.values()[rng() % g.size()] = std::numeric_limits<float>::quiet_NaN();
    const MinPyramid p(g);
    for (int q = 0; q < 400; ++q) {
      const int c0 = static_cast<int>(rng() % w), r0 = static_cast<int>(rng() % h);
      const int c1 = c0 + 1 + static_cast<int>(rng() % (w - c0)), r1 = r0 + 1 + static_cast<int>(rng() % (h - r0));
      const terrain::Window win{c0, r0, c1, r1};
      ASSERT_EQ(p.min_in(win), brute_min(g, win)) << w << "x" << h << " window " << c0 << "," << r0 << " " << c1
                                                  << "," << r1;
    }
  }
}

TEST(MinPyramid, RebuildReusesSizeAndTracksNewValues) {
  terrain::Grid<float> g(20, 20, 5.0f);
  MinPyramid p(g);
  g.at(7, 9) = -3.0f;
  p.build(g);
  EXPECT_EQ(p.min_in({0, 0, 20, 20}), -3.0f);
  EXPECT_EQ(p.min_in({8, 0, 20, 20}), 5.0f);
}

// The point of the pyramid: a box test reads few cells, not its footprint.
TEST(MinPyramid, SmoothFieldQueriesReadFarFewerCellsThanTheirArea) {
  const int n = 1024;
  terrain::Grid<float> g(n, n);
  for (int r = 0; r < n; ++r)
    for (int c = 0; c < n; ++c) g.at(c, r) = static_cast<float>(std::hypot(c - 300.3, r - 700.7));
  const MinPyramid p(g);
  std::mt19937 rng(7);
  std::uint64_t reads = 0, area = 0;
  for (int q = 0; q < 1000; ++q) {
    const int size = 16 + static_cast<int>(rng() % 200);
    const int c0 = static_cast<int>(rng() % (n - size)), r0 = static_cast<int>(rng() % (n - size));
    const terrain::Window win{c0, r0, c0 + size, r0 + size};
    ASSERT_EQ(p.min_in(win, &reads), brute_min(g, win));
    area += win.cell_count();
  }
  EXPECT_LT(reads * 100, area);  // under 1 % of the cells a footprint scan would read
  EXPECT_LT(reads / 1000, 200u);  // and a bounded number per query
}

}  // namespace
}  // namespace horizon::visibility
