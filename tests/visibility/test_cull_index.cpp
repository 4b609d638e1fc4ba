// The full-resolution min-pyramid and the batch box test (cull_index.hpp):
// hand-computed levels, brute-force minima over every rectangle shape, and
// every kernel form against cull_footprints on the same boxes.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include "horizon/visibility/cull_index.hpp"
#include "vector_forms.hpp"
#include "visibility_test_util.hpp"

namespace horizon::visibility {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();
const float kNaN = std::numeric_limits<float>::quiet_NaN();

// Least of the cells, voids as -inf: what every form must answer.
float brute_min(const terrain::Grid<float>& g, int c0, int r0, int c1, int r1) {
  float m = kInf;
  for (int r = r0; r < r1; ++r)
    for (int c = c0; c < c1; ++c) m = std::min(m, std::isnan(g.at(c, r)) ? -kInf : g.at(c, r));
  return m;
}

terrain::Grid<float> random_ohf(int w, int h, unsigned seed, double void_fraction) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> z(-50.0f, 3000.0f);
  std::uniform_real_distribution<double> u(0, 1);
  terrain::Grid<float> g(w, h);
  for (int r = 0; r < h; ++r)
    for (int c = 0; c < w; ++c) g.at(c, r) = u(rng) < void_fraction ? kNaN : z(rng);
  return g;
}

BoxFootprint footprint(int c0, int r0, int c1, int r1, double z_max) {
  BoxFootprint f;
  f.cells = {c0, r0, c1, r1};
  f.z_max = z_max;
  f.z_min = z_max - 1.0;
  f.col_min = c0;
  f.col_max = c1 - 1;
  f.row_min = r0;
  f.row_max = r1 - 1;
  return f;
}

TEST(CullIndex, LevelsHoldTheMinimumOfTheSquareEachCellLeads) {
  // 5 x 3 cells, values = 10 c + r, one void at (3, 1).
  terrain::Grid<float> g(5, 3);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 5; ++c) g.at(c, r) = static_cast<float>(100 - 10 * c - r);
  g.at(3, 1) = kNaN;
  const CullIndex index(g, {0, 0, 5, 3}, 3);
  ASSERT_EQ(index.levels(), 3);
  EXPECT_EQ(index.level(0)[0], 100.0f);
  EXPECT_EQ(index.level(0)[5 + 3], -kInf);  // the void
  // Level 1 at (0, 0): min of (0,0) 100, (1,0) 90, (0,1) 99, (1,1) 89.
  EXPECT_EQ(index.level(1)[0], 89.0f);
  // Level 1 at (4, 2) hangs over both edges: just the cell itself (100 - 40 - 2).
  EXPECT_EQ(index.level(1)[2 * 5 + 4], 58.0f);
  // Level 1 at (2, 0) meets the void at (3, 1).
  EXPECT_EQ(index.level(1)[2], -kInf);
  // Level 2 at (0, 1): 4 x 4 from there, clipped to columns 0..3, rows 1..2: holds the void.
  EXPECT_EQ(index.level(2)[5], -kInf);
  // Level 2 at (4, 0): column 4, rows 0..2: least is 100 - 40 - 2.
  EXPECT_EQ(index.level(2)[4], 58.0f);
  // The void keeps a second set of levels, voids as +inf.
  ASSERT_TRUE(index.has_voids());
  EXPECT_EQ(index.bytes(), CullIndex::index_bytes(5, 3, 3, true));
  EXPECT_EQ(index.known_min_in(2, 0, 4, 2), 70.0f);  // (2,0) 80, (3,0) 70, (2,1) 79, (3,1) void
  EXPECT_EQ(index.known_min_in(3, 1, 4, 2), kInf);   // the void alone
  EXPECT_EQ(index.min_in(2, 0, 4, 2), -kInf);
  // Without voids, one set.
  g.at(3, 1) = 1.0f;
  const CullIndex whole(g, {0, 0, 5, 3}, 3);
  EXPECT_FALSE(whole.has_voids());
  EXPECT_EQ(whole.bytes(), CullIndex::index_bytes(5, 3, 3));
}

TEST(CullIndex, MinInIsExactForEveryRectangleShape) {
  const terrain::Grid<float> g = random_ohf(41, 37, 7, 0.01);
  for (int levels = 1; levels <= CullIndex::kMaxLevels; ++levels) {
    const CullIndex index(g, {0, 0, 41, 37}, levels);
    for (int c0 = 0; c0 < 41; c0 += 3)
      for (int r0 = 0; r0 < 37; r0 += 4)
        for (int c1 = c0 + 1; c1 <= 41; c1 += 2)
          for (int r1 = r0 + 1; r1 <= 37; r1 += 3) {
            std::uint64_t reads = 0;
            const float got = index.min_in(c0, r0, c1, r1, &reads);
            ASSERT_EQ(got, brute_min(g, c0, r0, c1, r1))
                << "levels " << levels << " rectangle [" << c0 << "," << c1 << ")x[" << r0 << "," << r1 << ")";
            ASSERT_GE(reads, 1u);
            ASSERT_LE(reads, static_cast<std::uint64_t>((c1 - c0) * (r1 - r0)));
          }
  }
}

TEST(CullIndex, FourReadsForBoxesWithinAnOctave) {
  const terrain::Grid<float> g = random_ohf(64, 64, 3, 0.0);
  const CullIndex index(g, {0, 0, 64, 64}, CullIndex::kMaxLevels);
  std::uint64_t reads = 0;
  index.min_in(3, 5, 3 + 13, 5 + 9, &reads);  // 13 x 9: squares of 8, 2 x 2 of them
  EXPECT_EQ(reads, 4u);
  reads = 0;
  index.min_in(0, 0, 40, 40, &reads);  // 40 x 40 with 16-cell squares at most: 3 x 3
  EXPECT_EQ(reads, 9u);
  reads = 0;
  index.min_in(0, 0, 1, 10, &reads);  // a 1 x 10 column: ten single cells
  EXPECT_EQ(reads, 10u);
}

TEST(CullIndex, LevelsForTakesTheLargestSquareAnyBoxNeeds) {
  EXPECT_EQ(CullIndex::levels_for({}), 1);
  const std::vector<BoxFootprint> small = {footprint(0, 0, 1, 1, 0), footprint(0, 0, 3, 2, 0)};
  EXPECT_EQ(CullIndex::levels_for(small), 2);  // min side 2: squares of 2
  const std::vector<BoxFootprint> big = {footprint(0, 0, 100, 90, 0)};
  EXPECT_EQ(CullIndex::levels_for(big), CullIndex::kMaxLevels);
}

// The same boxes through cull_footprints (the min-pyramid) and cull_batch.
struct Scene {
  terrain::Grid<float> ohf;
  terrain::Window window;
  std::vector<BoxFootprint> boxes;
};

Scene random_scene(unsigned seed) {
  Scene s;
  s.window = {20, 30, 20 + 97, 30 + 83};  // the OHF's window in DEM cells
  s.ohf = random_ohf(97, 83, seed, 0.001);
  std::mt19937 rng(seed + 1);
  std::uniform_int_distribution<int> col(10, 110), row(20, 105), side(1, 24), thin(1, 3);
  std::uniform_real_distribution<double> u(0, 1);
  for (int i = 0; i < 3000; ++i) {
    const int c0 = col(rng), r0 = row(rng);
    int w = side(rng), h = side(rng);
    if (i % 7 == 0) w = thin(rng);  // elongated: more than four reads
    if (i % 11 == 0) h = 40 + side(rng);
    BoxFootprint f = footprint(c0, r0, c0 + w, r0 + h, 0.0);
    if (i % 97 == 0) {
      f = BoxFootprint{};  // off the map
      f.on_map = false;
      s.boxes.push_back(f);
      continue;
    }
    // Around the true minimum, so that both answers occur, ties included.
    const bool inside = c0 >= 20 && r0 >= 30 && c0 + w <= 117 && r0 + h <= 113;
    const float m = inside ? brute_min(s.ohf, c0 - 20, r0 - 30, c0 + w - 20, r0 + h - 30) : 1000.0f;
    if (std::isinf(m)) {
      // Over a void: just below or at the least known value, undetermined or visible.
      float known = kInf;
      for (int r = r0 - 30; r < r0 + h - 30; ++r)
        for (int c = c0 - 20; c < c0 + w - 20; ++c)
          if (!std::isnan(s.ohf.at(c, r))) known = std::min(known, s.ohf.at(c, r));
      f.z_max = std::isinf(known) ? 0.0 : static_cast<double>(known) - kTieTolerance - (i % 2 ? 1.0 : 0.0);
    } else if (i % 5 == 0)
      f.z_max = static_cast<double>(m) - kTieTolerance;  // a tie: visible
    else if (i % 5 == 1)
      f.z_max = std::nextafter(static_cast<double>(m) - kTieTolerance, -1e300);  // just short: hidden
    else
      f.z_max = static_cast<double>(m) + (u(rng) - 0.5) * 20.0;
    s.boxes.push_back(f);
  }
  return s;
}

std::vector<BoxVisibility> with_pyramid(const Scene& s) {
  ViewshedResult r;
  r.ohf = s.ohf;
  r.frame.window = s.window;
  const terrain::Pyramid pyramid(r.ohf, terrain::Reduction::kMin);
  std::vector<BoxVisibility> out(s.boxes.size());
  cull_footprints(r, pyramid, s.boxes, out);
  return out;
}

void expect_same(const std::vector<BoxVisibility>& want, const std::vector<BoxVisibility>& got) {
  ASSERT_EQ(want.size(), got.size());
  for (std::size_t i = 0; i < want.size(); ++i) {
    ASSERT_EQ(want[i].state, got[i].state) << "box " << i;
    ASSERT_EQ(want[i].ohf_min, got[i].ohf_min) << "box " << i;
  }
}

TEST(CullIndex, BatchAgreesWithThePyramidBoxForBox) {
  for (unsigned seed : {1u, 2u, 3u}) {
    const Scene s = random_scene(seed);
    const std::vector<BoxVisibility> want = with_pyramid(s);
    const CullIndex index(s.ohf, s.window, CullIndex::levels_for(s.boxes));
    const BoxBatch batch(s.boxes);
    std::vector<BoxVisibility> got(s.boxes.size());
    BatchStats stats;
    const std::size_t visible = cull_batch(index, batch, got, &stats);
    expect_same(want, got);
    EXPECT_EQ(visible, static_cast<std::size_t>(std::count_if(
                           want.begin(), want.end(), [](const BoxVisibility& b) { return may_be_seen(b.state); })));
    // Off-map boxes, and boxes over voids that the known cells could not decide, occurred.
    const auto count = [&](Visibility v) {
      return std::count_if(want.begin(), want.end(), [&](const BoxVisibility& b) { return b.state == v; });
    };
    EXPECT_EQ(count(Visibility::kOutOfRange), 31);
    EXPECT_GT(count(Visibility::kUndetermined), 0);
    EXPECT_TRUE(index.has_voids());
    // Both outcomes, ties and off-window boxes all occurred.
    EXPECT_GT(visible, 300u);
    EXPECT_LT(visible, s.boxes.size() - 300u);
    EXPECT_GT(stats.outside, 100u);
    EXPECT_GT(stats.vector_boxes, 500u);
    EXPECT_LT(stats.vector_boxes + stats.outside, s.boxes.size());  // some took the long way
  }
}

TEST(CullIndex, EveryKernelFormGivesTheScalarBits) {
  const Scene s = random_scene(9);
  const CullIndex index(s.ohf, s.window, CullIndex::levels_for(s.boxes));
  const BoxBatch batch(s.boxes);
  // Scalar first, then each vector form this CPU has.
  std::vector<BoxVisibility> scalar(s.boxes.size());
  BatchStats scalar_stats;
  {
    struct Restore {
      ~Restore() { sweep::simd::isa_limit() = sweep::simd::Isa::kAvx512; }
    } restore;
    sweep::simd::isa_limit() = sweep::simd::Isa::kScalar;
    cull_batch(index, batch, scalar, &scalar_stats);
  }
  sweep::for_each_vector_form([&] {
    std::vector<BoxVisibility> got(s.boxes.size());
    BatchStats stats;
    cull_batch(index, batch, got, &stats);
    for (std::size_t i = 0; i < got.size(); ++i) {
      ASSERT_EQ(got[i].state, scalar[i].state) << "box " << i;
      ASSERT_EQ(std::bit_cast<std::uint32_t>(got[i].ohf_min), std::bit_cast<std::uint32_t>(scalar[i].ohf_min))
          << "box " << i;
    }
    EXPECT_EQ(stats.reads, scalar_stats.reads);
    EXPECT_EQ(stats.vector_boxes, scalar_stats.vector_boxes);
    EXPECT_EQ(stats.outside, scalar_stats.outside);
  });
}

TEST(CullIndex, AnswersComeBackInTheCallersOrder) {
  const Scene s = random_scene(4);
  const CullIndex index(s.ohf, s.window, CullIndex::levels_for(s.boxes));
  std::vector<BoxFootprint> reversed(s.boxes.rbegin(), s.boxes.rend());
  std::vector<BoxVisibility> a(s.boxes.size()), b(s.boxes.size());
  cull_batch(index, BoxBatch(s.boxes), a);
  cull_batch(index, BoxBatch(reversed), b);
  for (std::size_t i = 0; i < a.size(); ++i) {
    ASSERT_EQ(a[i].state, b[a.size() - 1 - i].state);
    ASSERT_EQ(a[i].ohf_min, b[a.size() - 1 - i].ohf_min);
  }
  // The batch is sorted along the Z-order curve, not in the caller's order.
  const BoxBatch batch(s.boxes);
  EXPECT_FALSE(std::is_sorted(batch.order.begin(), batch.order.end()));
}

TEST(CullIndex, TheThresholdIsTheTieRuleInFloat) {
  // One cell of OHF 100: z_max = 100 - tol is visible (a tie), one double
  // below it is hidden, exactly as cull_footprints decides.
  terrain::Grid<float> g(1, 1);
  g.at(0, 0) = 100.0f;
  const CullIndex index(g, {0, 0, 1, 1}, 1);
  const double tie = 100.0 - kTieTolerance;
  const std::vector<BoxFootprint> boxes = {footprint(0, 0, 1, 1, tie), footprint(0, 0, 1, 1, std::nextafter(tie, 0.0))};
  std::vector<BoxVisibility> out(2);
  EXPECT_EQ(cull_batch(index, BoxBatch(boxes), out), 1u);
  EXPECT_EQ(out[0].state, Visibility::kSeen);
  EXPECT_EQ(out[1].state, Visibility::kOccluded);
  expect_same(with_pyramid({g, {0, 0, 1, 1}, boxes}), out);
}

TEST(CullIndex, AgreesWithRunCullOnARealOhf) {
  const terrain::Dem dem = horizon::testing::grid_dem(
      180, 160, [](int c, int r) { return 300.0 * std::sin(c * 0.11) * std::cos(r * 0.07) + 2.0 * (c % 7); });
  const auto eye = horizon::testing::eye_at(dem, 90, 80, 5.0);
  std::mt19937 rng(5);
  const auto& t = dem.georef.transform;
  const double x0 = t.x_at(0), x1 = t.x_at(179), y0 = t.y_at(159), y1 = t.y_at(0);
  std::uniform_real_distribution<double> x(x0, x1), y(y0, y1), side(1, 80), z(-200, 400);
  std::vector<BoxSpec> boxes;
  for (int i = 0; i < 2000; ++i) {
    BoxSpec b;
    b.x_min = x(rng);
    b.y_min = y(rng);
    b.x_max = std::min(b.x_min + side(rng), x1);
    b.y_max = std::min(b.y_min + side(rng), y1);
    b.z_min = z(rng);
    b.z_max = b.z_min + 30.0;
    boxes.push_back(b);
  }
  CullOptions options;
  options.viewshed.algorithm = Algorithm::kR3;
  auto plan = plan_cull(dem, eye, boxes, options);
  ASSERT_TRUE(plan.ok()) << plan.error().message;
  auto run = run_cull(dem, eye, *plan);
  ASSERT_TRUE(run.ok()) << run.error().message;
  // The same OHF again, kept warm this time.
  auto ohf = compute_viewshed(dem, eye, plan->viewshed);
  ASSERT_TRUE(ohf.ok());
  const CullIndex index(ohf->ohf, ohf->frame.window, CullIndex::levels_for(plan->footprints));
  std::vector<BoxVisibility> got(boxes.size());
  EXPECT_EQ(cull_batch(index, BoxBatch(plan->footprints), got), run->visible_count);
  expect_same(run->boxes, got);
  EXPECT_GT(run->visible_count, 100u);
  EXPECT_LT(run->visible_count, 1900u);
}

TEST(CullIndex, BlockMinIsTheLeastOverTheCoveringBlocks) {
  const terrain::Grid<float> g = random_ohf(37, 29, 12, 0.01);
  const CullIndex index(g, {0, 0, 37, 29}, 2);
  constexpr int b = CullIndex::kBlock;
  for (const auto& [c0, r0, c1, r1] : {std::array{0, 0, 1, 1}, std::array{3, 5, 20, 9}, std::array{7, 7, 9, 9},
                                       std::array{30, 20, 37, 29}, std::array{0, 0, 37, 29}}) {
    const int bc1 = std::min(37, ((c1 - 1) / b + 1) * b), br1 = std::min(29, ((r1 - 1) / b + 1) * b);
    std::uint64_t reads = 0;
    EXPECT_EQ(index.block_min_over(c0, r0, c1, r1, &reads), brute_min(g, c0 / b * b, r0 / b * b, bc1, br1))
        << c0 << "," << r0 << " .. " << c1 << "," << r1;
    EXPECT_EQ(reads, static_cast<std::uint64_t>(((c1 - 1) / b - c0 / b + 1) * ((r1 - 1) / b - r0 / b + 1)));
  }
}

// Clusters of small boxes over a high OHF (mostly hidden, a few tall enough
// to be seen) and over a low one (seen), and the random scene's boxes.
Scene clustered_scene() {
  Scene s;
  s.window = {0, 0, 256, 128};
  s.ohf = terrain::Grid<float>(256, 128);
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> noise(0.0f, 100.0f);
  for (int r = 0; r < 128; ++r)
    for (int c = 0; c < 256; ++c) s.ohf.at(c, r) = (c < 128 ? 1000.0f : 0.0f) + noise(rng);
  std::uniform_real_distribution<double> u(0, 1);
  const int centres[][2] = {{40, 40}, {90, 90}, {170, 40}, {220, 90}};
  for (int i = 0; i < 4000; ++i) {
    const auto& c = centres[i % 4];
    const int c0 = c[0] + static_cast<int>(20 * (u(rng) - 0.5)), r0 = c[1] + static_cast<int>(20 * (u(rng) - 0.5));
    const int w = 1 + static_cast<int>(3 * u(rng)), h = 1 + static_cast<int>(3 * u(rng));
    const double z = c[0] < 128 ? (u(rng) < 0.02 ? 1050 + 100 * u(rng) : 900 * u(rng)) : 200 * u(rng);
    s.boxes.push_back(footprint(c0, r0, c0 + w, r0 + h, z));
  }
  return s;
}

TEST(CullIndex, GroupsAnswerHiddenClustersAtOnceWithTheExactStates) {
  for (const Scene& s : {clustered_scene(), random_scene(5)}) {
    const std::vector<BoxVisibility> want = with_pyramid(s);
    const CullIndex index(s.ohf, s.window, CullIndex::levels_for(s.boxes));
    const BoxBatch batch(s.boxes);
    std::vector<BoxVisibility> exact(s.boxes.size());
    BatchStats exact_stats;
    cull_batch(index, batch, exact, &exact_stats);
    EXPECT_EQ(exact_stats.groups_tried, 0u);  // exact minima: never grouped
    const auto check = [&] {
      std::vector<BoxVisibility> got(s.boxes.size());
      BatchStats stats;
      cull_batch(index, batch, got, &stats, {.exact_minimum = false});
      std::size_t bounded = 0;
      for (std::size_t i = 0; i < got.size(); ++i) {
        ASSERT_EQ(got[i].state, want[i].state) << "box " << i;
        if (got[i].ohf_min != want[i].ohf_min) {
          // A group's bound: at most the box's own least, still above its z_max.
          ASSERT_EQ(got[i].state, Visibility::kOccluded) << "box " << i;
          ASSERT_LT(got[i].ohf_min, want[i].ohf_min) << "box " << i;
          ASSERT_GT(static_cast<double>(got[i].ohf_min), s.boxes[i].z_max + kTieTolerance) << "box " << i;
          ++bounded;
        }
      }
      EXPECT_LE(stats.groups_hidden, stats.groups_tried);
      EXPECT_LE(bounded, stats.groups_hidden * BoxBatch::kGroup);
      if (s.boxes.size() == 4000) {
        // The hidden clusters went by whole groups, for fewer reads.
        EXPECT_GT(stats.groups_hidden, 30u);
        EXPECT_LT(stats.reads, exact_stats.reads * 3 / 4);
      }
    };
    {
      struct Restore {
        ~Restore() { sweep::simd::isa_limit() = sweep::simd::Isa::kAvx512; }
      } restore;
      sweep::simd::isa_limit() = sweep::simd::Isa::kScalar;
      SCOPED_TRACE("scalar");
      check();
    }
    sweep::for_each_vector_form(check);
  }
}

TEST(CullIndex, WideGroupsAreNeverTried) {
  // Boxes scattered over a large OHF: sixteen Z-order neighbours span more
  // than kGroupSpan cells, so the batch keeps no group to try.
  const terrain::Grid<float> g = random_ohf(1024, 1024, 8, 0.0);
  std::mt19937 rng(9);
  std::uniform_int_distribution<int> at(0, 1020);
  std::vector<BoxFootprint> boxes;
  for (int i = 0; i < 256; ++i) {
    const int c = at(rng), r = at(rng);
    boxes.push_back(footprint(c, r, c + 2, r + 2, -100.0));
  }
  const BoxBatch batch(boxes);
  EXPECT_TRUE(batch.group_first.empty());
  const CullIndex index(g, {0, 0, 1024, 1024}, 2);
  std::vector<BoxVisibility> out(boxes.size());
  BatchStats stats;
  EXPECT_EQ(cull_batch(index, batch, out, &stats, {.exact_minimum = false}), 0u);
  EXPECT_EQ(stats.groups_tried, 0u);
}

}  // namespace
}  // namespace horizon::visibility
