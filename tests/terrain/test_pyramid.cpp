// Pyramid: min / max / mean levels and rectangle queries against brute force,
// the block-wise lazy build, and the min query's cost (culling's min-pyramid).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <thread>
#include <tuple>
#include <vector>

#include "horizon/terrain/pyramid.hpp"

namespace horizon::terrain {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

float brute_min(const Grid<float>& g, const Window& w) {
  float m = kInf;
  for (int r = w.row0; r < w.row1; ++r)
    for (int c = w.col0; c < w.col1; ++c) {
      const float v = g.at(c, r);
      m = std::min(m, std::isnan(v) ? -kInf : v);
    }
  return m;
}

float brute_max(const Grid<float>& g, const Window& w) {
  float m = -kInf;
  for (int r = w.row0; r < w.row1; ++r)
    for (int c = w.col0; c < w.col1; ++c)
      if (g.at(c, r) > m) m = g.at(c, r);
  return m;
}

// Mean of the valid cells and how many there are.
std::pair<double, std::uint32_t> brute_mean(const Grid<float>& g, const Window& w) {
  double sum = 0;
  std::uint32_t n = 0;
  for (int r = w.row0; r < w.row1; ++r)
    for (int c = w.col0; c < w.col1; ++c)
      if (!std::isnan(g.at(c, r))) {
        sum += g.at(c, r);
        ++n;
      }
  return {n ? sum / n : std::nan(""), n};
}

Grid<float> random_grid(int w, int h, std::mt19937& rng, int voids) {
  Grid<float> g(w, h);
  std::uniform_real_distribution<float> value(-50.0f, 3000.0f);
  for (float& v : g.values()) v = value(rng);
  for (int k = 0; k < voids; ++k) g.values()[rng() % g.size()] = kNaN;
  return g;
}

Window random_window(int w, int h, std::mt19937& rng) {
  const int c0 = static_cast<int>(rng() % w), r0 = static_cast<int>(rng() % h);
  const int c1 = c0 + 1 + static_cast<int>(rng() % (w - c0)), r1 = r0 + 1 + static_cast<int>(rng() % (h - r0));
  return {c0, r0, c1, r1};
}

// Level-0 cells under cell (i, j) of level l, clipped to the raster.
Window cell_cells(const Pyramid& p, int l, int i, int j) {
  const int s = p.cell_side(l);
  return {i * s, j * s, std::min((i + 1) * s, p.width()), std::min((j + 1) * s, p.height())};
}

// ---- Culling's min-pyramid (2x2 levels up to one cell): the assertions it
// ---- held as visibility::MinPyramid, unchanged.

TEST(PyramidMin, LevelsHalveDownToOneCellRoundingUp) {
  const Grid<float> g(5, 3, 1.0f);
  const Pyramid p(g, Reduction::kMin);
  ASSERT_EQ(p.level_count(), 4);  // 5x3, 3x2, 2x1, 1x1
  EXPECT_EQ(p.level_width(1), 3);
  EXPECT_EQ(p.level_height(1), 2);
  EXPECT_EQ(p.level_width(2), 2);
  EXPECT_EQ(p.level_height(2), 1);
  EXPECT_EQ(p.level_width(3), 1);
  EXPECT_EQ(p.level_height(3), 1);
}

TEST(PyramidMin, HandComputedThreeByThree) {
  // 9 8 7
  // 6 5 4
  // 3 2 1
  Grid<float> g(3, 3);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) g.at(c, r) = static_cast<float>(9 - 3 * r - c);
  const Pyramid p(g, Reduction::kMin);
  EXPECT_EQ(p.value(1, 0, 0), 5.0f);
  EXPECT_EQ(p.value(1, 1, 0), 4.0f);  // odd edge: column 2 only
  EXPECT_EQ(p.value(1, 0, 1), 2.0f);
  EXPECT_EQ(p.value(1, 1, 1), 1.0f);
  EXPECT_EQ(p.min_in({0, 0, 2, 2}), 5.0f);
  EXPECT_EQ(p.min_in({0, 0, 3, 1}), 7.0f);
  EXPECT_EQ(p.min_in({1, 0, 2, 3}), 2.0f);
  EXPECT_EQ(p.min_in({0, 0, 1, 1}), 9.0f);
  EXPECT_EQ(p.min_in({0, 0, 3, 3}), 1.0f);
}

TEST(PyramidMin, NoAnswerCellsReadAsMinusInfinity) {
  Grid<float> g(4, 4, 10.0f);
  g.at(2, 3) = kNaN;
  const Pyramid p(g, Reduction::kMin);
  EXPECT_EQ(p.min_in({0, 0, 4, 3}), 10.0f);
  EXPECT_EQ(p.min_in({2, 3, 3, 4}), -kInf);
  EXPECT_EQ(p.min_in({0, 0, 4, 4}), -kInf);
}

TEST(PyramidMin, EqualsBruteForceOnRandomRectangles) {
  std::mt19937 rng(1234);
  for (auto [w, h] : {std::pair{1, 1}, {1, 17}, {33, 1}, {64, 64}, {100, 37}, {257, 129}}) {
    const Grid<float> g = random_grid(w, h, rng, 5);
    const Pyramid p(g, Reduction::kMin);
    for (int q = 0; q < 400; ++q) {
      const Window win = random_window(w, h, rng);
      ASSERT_EQ(p.min_in(win), brute_min(g, win))
          << w << "x" << h << " window " << win.col0 << "," << win.row0 << " " << win.col1 << "," << win.row1;
    }
  }
}

TEST(PyramidMin, RebuildReusesSizeAndTracksNewValues) {
  Grid<float> g(20, 20, 5.0f);
  Pyramid p(g, Reduction::kMin);
  EXPECT_EQ(p.min_in({0, 0, 20, 20}), 5.0f);
  g.at(7, 9) = -3.0f;
  p.invalidate();
  EXPECT_EQ(p.min_in({0, 0, 20, 20}), -3.0f);
  EXPECT_EQ(p.min_in({8, 0, 20, 20}), 5.0f);
}

// The point of the pyramid: a box test reads few cells, not its footprint.
TEST(PyramidMin, SmoothFieldQueriesReadFarFewerCellsThanTheirArea) {
  const int n = 1024;
  Grid<float> g(n, n);
  for (int r = 0; r < n; ++r)
    for (int c = 0; c < n; ++c) g.at(c, r) = static_cast<float>(std::hypot(c - 300.3, r - 700.7));
  const Pyramid p(g, Reduction::kMin);
  std::mt19937 rng(7);
  std::uint64_t reads = 0, area = 0;
  for (int q = 0; q < 1000; ++q) {
    const int size = 16 + static_cast<int>(rng() % 200);
    const int c0 = static_cast<int>(rng() % (n - size)), r0 = static_cast<int>(rng() % (n - size));
    const Window win{c0, r0, c0 + size, r0 + size};
    ASSERT_EQ(p.min_in(win, &reads), brute_min(g, win));
    area += win.cell_count();
  }
  EXPECT_LT(reads * 100, area);   // under 1 % of the cells a footprint scan would read
  EXPECT_LT(reads / 1000, 200u);  // and a bounded number per query
}

// ---- Every reduction, shape and block size against brute force.

struct Case {
  int factor, levels, block_cells;
};
const Case kCases[] = {
    {2, PyramidShape::kToOneCell, 512},
    {2, PyramidShape::kToOneCell, 4},
    {2, 3, 8},
    {4, PyramidShape::kToOneCell, 16},
    {8, 3, 1024},
    {8, 3, 8},
    {8, 2, 64},
};

TEST(Pyramid, LevelsEqualBruteForceReductions) {
  std::mt19937 rng(99);
  for (auto [w, h] : {std::pair{1, 1}, {7, 3}, {45, 71}, {130, 33}}) {
    const Grid<float> g = random_grid(w, h, rng, w * h / 6);
    for (const Case& k : kCases) {
      const PyramidShape shape{k.factor, k.levels};
      const PyramidOptions options{.block_cells = k.block_cells};
      const Pyramid pmin(g, Reduction::kMin, shape, options), pmax(g, Reduction::kMax, shape, options),
          pmean(g, Reduction::kMean, shape, options);
      for (int l = 0; l < pmin.level_count(); ++l) {
        ASSERT_EQ(pmin.level_width(l), (w + pmin.cell_side(l) - 1) / pmin.cell_side(l));
        ASSERT_EQ(pmin.level_height(l), (h + pmin.cell_side(l) - 1) / pmin.cell_side(l));
        for (int j = 0; j < pmin.level_height(l); ++j)
          for (int i = 0; i < pmin.level_width(l); ++i) {
            const Window cells = cell_cells(pmin, l, i, j);
            ASSERT_EQ(pmin.value(l, i, j), brute_min(g, cells)) << "factor " << k.factor << " level " << l;
            ASSERT_EQ(pmax.value(l, i, j), brute_max(g, cells)) << "factor " << k.factor << " level " << l;
            const auto [mean, n] = brute_mean(g, cells);
            ASSERT_EQ(pmean.count(l, i, j), n);
            if (n == 0)
              EXPECT_TRUE(std::isnan(pmean.value(l, i, j)));
            else
              ASSERT_NEAR(pmean.value(l, i, j), mean, 1e-5 * (1 + std::abs(mean)));
          }
      }
    }
  }
}

TEST(Pyramid, QueriesEqualBruteForceOnRandomWindows) {
  std::mt19937 rng(4321);
  for (auto [w, h] : {std::pair{1, 9}, {23, 1}, {97, 61}, {300, 171}}) {
    const Grid<float> g = random_grid(w, h, rng, 1 + w * h / 50);
    for (const Case& k : kCases) {
      const PyramidShape shape{k.factor, k.levels};
      const PyramidOptions options{.block_cells = k.block_cells};
      const Pyramid pmin(g, Reduction::kMin, shape, options), pmax(g, Reduction::kMax, shape, options),
          pmean(g, Reduction::kMean, shape, options);
      for (int q = 0; q < 150; ++q) {
        const Window win = random_window(w, h, rng);
        ASSERT_EQ(pmin.min_in(win), brute_min(g, win)) << "factor " << k.factor << " blocks " << k.block_cells;
        ASSERT_EQ(pmax.max_in(win), brute_max(g, win)) << "factor " << k.factor << " blocks " << k.block_cells;
        const auto [mean, n] = brute_mean(g, win);
        if (n == 0)
          EXPECT_TRUE(std::isnan(pmean.mean_in(win)));
        else
          ASSERT_NEAR(pmean.mean_in(win), mean, 1e-5 * (1 + std::abs(mean)));
      }
    }
  }
}

TEST(Pyramid, AllVoidWindowsFollowEachPolicy) {
  Grid<float> g(6, 6, 2.0f);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) g.at(c, r) = kNaN;
  const Pyramid pmin(g, Reduction::kMin), pmax(g, Reduction::kMax), pmean(g, Reduction::kMean);
  EXPECT_EQ(pmin.min_in({0, 0, 3, 3}), -kInf);
  EXPECT_EQ(pmax.max_in({0, 0, 3, 3}), -kInf);  // voids never win; none but voids: -inf
  EXPECT_EQ(pmax.max_in({0, 0, 4, 3}), 2.0f);
  EXPECT_TRUE(std::isnan(pmean.mean_in({0, 0, 3, 3})));
  EXPECT_EQ(pmean.mean_in({0, 0, 6, 6}), 2.0f);
  EXPECT_EQ(pmean.count(pmean.level_count() - 1, 0, 0), 27u);
}

// A view that fills its voids gives every reduction the fill height, at
// every level, and leaves the grid itself untouched.
TEST(Pyramid, AFilledViewReducesItsFillHeight) {
  Grid<float> g(6, 6, 2.0f);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) g.at(c, r) = kNaN;
  const HeightView filled = HeightView(g).with_void_fill(5.0f);
  const PyramidShape shape{2, PyramidShape::kToOneCell};
  const PyramidOptions options{.block_cells = 2};  // levels above the block stored whole, too
  const Pyramid pmin(filled, Reduction::kMin, shape, options), pmax(filled, Reduction::kMax, shape, options),
      pmean(filled, Reduction::kMean, shape, options);
  EXPECT_EQ(pmin.min_in({0, 0, 3, 3}), 5.0f);
  EXPECT_EQ(pmin.min_in({0, 0, 6, 6}), 2.0f);
  EXPECT_EQ(pmax.max_in({0, 0, 6, 6}), 5.0f);
  EXPECT_EQ(pmax.max_in({3, 3, 6, 6}), 2.0f);
  EXPECT_EQ(pmean.mean_in({0, 0, 6, 6}), (9 * 5.0f + 27 * 2.0f) / 36);
  EXPECT_EQ(pmean.count(pmean.level_count() - 1, 0, 0), 36u);
  EXPECT_TRUE(std::isnan(g.at(0, 0)));
}

// A pyramid over a window of a larger grid answers in the window's own cells.
TEST(Pyramid, WindowOfASourceEqualsItsCopy) {
  std::mt19937 rng(5);
  const Grid<float> big = random_grid(200, 150, rng, 300);
  const Window sub{37, 21, 180, 140};
  Grid<float> copy(sub.width(), sub.height());
  for (int r = 0; r < sub.height(); ++r)
    for (int c = 0; c < sub.width(); ++c) copy.at(c, r) = big.at(sub.col0 + c, sub.row0 + r);
  const PyramidOptions options{.block_cells = 32};
  const Pyramid p(big, sub, Reduction::kMax, {8, 2}, options);
  EXPECT_EQ(p.width(), sub.width());
  EXPECT_EQ(p.height(), sub.height());
  for (int q = 0; q < 300; ++q) {
    const Window win = random_window(copy.width(), copy.height(), rng);
    ASSERT_EQ(p.max_in(win), brute_max(copy, win));
  }
}

// ---- Lazy, block-wise build.

TEST(Pyramid, QueriesBuildOnlyTheBlocksUnderTheCellsTheyRead) {
  const int n = 1000;  // 4 x 4 blocks of 256, the last ones cut to 232
  Grid<float> g(n, n);
  for (int r = 0; r < n; ++r)
    for (int c = 0; c < n; ++c) g.at(c, r) = static_cast<float>((c * 7 + r * 13) % 101);
  const Pyramid p(g, Reduction::kMin, {}, {.block_cells = 256});
  ASSERT_EQ(p.block_count(), 16u);
  EXPECT_EQ(p.blocks_built(), 0u);
  const std::size_t upper = p.bytes();  // levels above the blocks (512, 1024 cells): 4 + 1 cells
  EXPECT_EQ(upper, 5 * sizeof(float));
  // Inside block (1, 1).
  const Window a{300, 300, 310, 310};
  EXPECT_EQ(p.min_in(a), brute_min(g, a));
  EXPECT_EQ(p.blocks_built(), 1u);
  const std::size_t one_block = p.bytes() - upper;
  EXPECT_GT(one_block, 0u);
  // Again, and elsewhere in the same block: nothing new.
  EXPECT_EQ(p.min_in({260, 400, 270, 500}), brute_min(g, {260, 400, 270, 500}));
  EXPECT_EQ(p.blocks_built(), 1u);
  // Across the corner of blocks (2, 2), (3, 2), (2, 3), (3, 3).
  const Window b{760, 760, 780, 780};
  EXPECT_EQ(p.min_in(b), brute_min(g, b));
  EXPECT_EQ(p.blocks_built(), 5u);
  // Level-0 reads only (a single cell): no block at all.
  EXPECT_EQ(p.value(0, 10, 10), g.at(10, 10));
  EXPECT_EQ(p.blocks_built(), 5u);
  // Everything.
  EXPECT_EQ(p.min_in({0, 0, n, n}), brute_min(g, {0, 0, n, n}));
  EXPECT_EQ(p.blocks_built(), 16u);
  EXPECT_GT(p.bytes(), 12 * one_block);  // the edge blocks are cut short
}

TEST(Pyramid, BuildAllBuildsEveryBlockOnceAndAnswersAlike) {
  std::mt19937 rng(17);
  const Grid<float> g = random_grid(333, 218, rng, 100);
  Pyramid lazy(g, Reduction::kMax, {8, 3}, {.block_cells = 64, .spans = true});
  Pyramid eager(g, Reduction::kMax, {8, 3}, {.block_cells = 64, .spans = true});
  eager.build_all(3);
  EXPECT_EQ(eager.blocks_built(), eager.block_count());
  EXPECT_EQ(eager.block_count(), 6u * 4u);
  eager.build_all(2);  // built already: nothing again
  EXPECT_EQ(eager.blocks_built(), eager.block_count());
  for (int q = 0; q < 300; ++q) {
    const Window win = random_window(g.width(), g.height(), rng);
    ASSERT_EQ(lazy.max_in(win), eager.max_in(win));
  }
}

// cover_built answers the reduction of the level-l cells that cover a range
// of level-0 cells: with spans and without, within blocks and across them.
TEST(Pyramid, CoverEqualsTheReductionOfTheCoveringCells) {
  std::mt19937 rng(23);
  const Grid<float> g = random_grid(1100, 700, rng, 2000);
  for (bool spans : {false, true})
    for (Reduction red : {Reduction::kMax, Reduction::kMin}) {
      Pyramid p(g, red, {8, 3}, {.block_cells = 1024, .spans = spans});
      p.build_all(2);
      for (int q = 0; q < 3000; ++q) {
        const int l = 1 + static_cast<int>(rng() % 3);
        const int span = 1 + static_cast<int>(rng() % (3 * p.cell_side(l)));
        // Ranges may reach past the raster on any side: cover_built clamps.
        const int c_lo = static_cast<int>(rng() % 1150) - 20, r_lo = static_cast<int>(rng() % 750) - 20;
        const int c_hi = std::max(c_lo + span, 0), r_hi = std::max(r_lo + span, 0);
        if (std::max(c_lo, 0) >= 1100 || std::max(r_lo, 0) >= 700) continue;
        const int s = p.cell_side(l);
        const int i0 = std::max(c_lo, 0) / s, i1 = std::min(c_hi, 1099) / s;
        const int j0 = std::max(r_lo, 0) / s, j1 = std::min(r_hi, 699) / s;
        float expect = red == Reduction::kMax ? -kInf : kInf;
        for (int j = j0; j <= j1; ++j)
          for (int i = i0; i <= i1; ++i)
            expect = red == Reduction::kMax ? std::max(expect, p.value(l, i, j)) : std::min(expect, p.value(l, i, j));
        ASSERT_EQ(p.cover_built(l, c_lo, c_hi, r_lo, r_hi), expect) << "level " << l << " spans " << spans;
      }
    }
}

// build_all's flat levels follow the source after invalidate(), spans too.
TEST(Pyramid, CoverAfterInvalidateSeesTheNewSource) {
  Grid<float> g(700, 300, 1.0f);
  Pyramid p(g, Reduction::kMax, {8, 3}, {.block_cells = 512, .spans = true});
  p.build_all(2);
  ASSERT_EQ(p.block_levels(), 3);
  const std::size_t built = p.bytes();
  EXPECT_EQ(p.cover_built(1, 506, 514, 10, 20), 1.0f);
  g.at(516, 17) = 5.0f;  // level-1 cell (64, 2), in the block east of cell (63, 2)
  p.invalidate();
  p.build_all(2);
  EXPECT_EQ(p.bytes(), built);
  EXPECT_EQ(p.cover_built(1, 506, 514, 10, 20), 5.0f);  // the quad of (63, 1), across blocks
  EXPECT_EQ(p.cover_built(1, 504, 511, 16, 23), 1.0f);  // cell (63, 2) alone
  EXPECT_EQ(p.cover_built(3, 0, 699, 0, 299), 5.0f);    // all of level 3: the east span of (0, 0)
}

TEST(Pyramid, ConcurrentFirstQueriesAgreeWithBruteForce) {
  std::mt19937 seed_rng(31);
  const Grid<float> g = random_grid(700, 500, seed_rng, 400);
  const Pyramid p(g, Reduction::kMin, {}, {.block_cells = 64});
  std::vector<int> wrong(6, 0);
  std::vector<std::thread> threads;
  for (int t = 0; t < 6; ++t)
    threads.emplace_back([&, t] {
      std::mt19937 rng(100 + t);
      for (int q = 0; q < 200; ++q) {
        const Window win = random_window(g.width(), g.height(), rng);
        wrong[static_cast<std::size_t>(t)] += p.min_in(win) != brute_min(g, win);
      }
    });
  for (std::thread& t : threads) t.join();
  for (int t = 0; t < 6; ++t) EXPECT_EQ(wrong[static_cast<std::size_t>(t)], 0) << "thread " << t;
  EXPECT_LE(p.blocks_built(), p.block_count());
}

TEST(Pyramid, EmptyWindowMakesAnEmptyPyramid) {
  const Grid<float> g(4, 4, 1.0f);
  const Pyramid p(g, Window{2, 2, 2, 4}, Reduction::kMin);
  EXPECT_EQ(p.width(), 0);
  EXPECT_EQ(p.level_count(), 0);
  EXPECT_EQ(p.block_count(), 0u);
}

}  // namespace
}  // namespace horizon::terrain
