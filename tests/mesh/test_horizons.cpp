// Tests for mesh/horizons.cpp: wedge membership against the angle test, the
// tree sweep against the brute force (random TINs, lattices full of ties,
// collinear and equal-projection sets, a set larger than the sweep's
// cache block), hand-built horizons, subsectors
// keeping the lowest, and invariance under scaling z.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include "horizon/mesh/horizons.hpp"
#include "horizon/mesh/tin_from_dem.hpp"
#include "test_support.hpp"

namespace horizon::mesh {
namespace {

constexpr double kPi = std::numbers::pi;

std::vector<TinVertex> tin_points(int budget, unsigned seed) {
  auto tin = tin_from_dem(testing::make_random_terrain(60, 50, seed), {static_cast<std::uint32_t>(budget), 0.0});
  EXPECT_TRUE(tin.ok());
  return tin.ok() ? tin->tin.vertices : std::vector<TinVertex>{};
}

VertexHorizons swept(const std::vector<TinVertex>& points, int s, int k) {
  auto h = compute_horizons(points, {s, k, 2});
  EXPECT_TRUE(h.ok()) << h.error().message;
  return h.ok() ? *h : VertexHorizons{};
}

VertexHorizons brute(const std::vector<TinVertex>& points, int s, int k) {
  auto h = brute_force_horizons(points, {s, k, 2});
  EXPECT_TRUE(h.ok()) << h.error().message;
  return h.ok() ? *h : VertexHorizons{};
}

TEST(Wedge, MembershipIsTheAngleTest) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> coord(-100.0, 100.0);
  for (int s = 3; s <= 64; ++s) {
    int tested = 0;
    for (int trial = 0; trial < 400; ++trial) {
      const TinVertex p{coord(rng), coord(rng), 0}, q{coord(rng), coord(rng), 0};
      double angle = std::atan2(q.y - p.y, q.x - p.x);
      if (angle < 0) angle += 2 * kPi;
      const double width = 2 * kPi / s;
      const double from_edge = std::remainder(angle, width);
      if (std::fabs(from_edge) < 1e-9) continue;  // on an edge: both neighbours hold it
      const int sector = static_cast<int>(angle / width);
      for (int i = 0; i < s; ++i) EXPECT_EQ(Wedge::sector(i, s).contains(p, q), i == sector) << s << " " << i;
      ++tested;
    }
    EXPECT_GT(tested, 390);
  }
}

TEST(Wedge, EveryDirectionOnAnEdgeBelongsToANeighbour) {
  // Neighbours share the edge's normal (the same doubles), one needing
  // B <= B(p) and the other A >= A(p) of the same value: rounding may give
  // an edge direction to one of them or both, never to neither.
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> coord(-1000.0, 1000.0), dist(0.001, 500.0);
  for (int s : {3, 4, 7, 8, 16, 64})
    for (int e = 0; e < s; ++e) {
      const double angle = 2 * kPi * e / s;
      for (int trial = 0; trial < 50; ++trial) {
        const TinVertex p{coord(rng), coord(rng), 0};
        const double d = dist(rng);
        const TinVertex q{p.x + d * std::cos(angle), p.y + d * std::sin(angle), 0};
        EXPECT_TRUE(Wedge::sector(e, s).contains(p, q) || Wedge::sector((e + s - 1) % s, s).contains(p, q))
            << s << " " << e;
      }
    }
  const Wedge w0 = Wedge::sector(0, 4);
  const TinVertex p{0, 0, 0};
  EXPECT_FALSE(w0.contains(p, p));
  EXPECT_NEAR(w0.t(TinVertex{1, 1, 0}), std::sqrt(2.0), 1e-12);  // the centre faces 45 degrees
}

TEST(Horizons, SweepEqualsBruteForceOnRandomTins) {
  for (unsigned seed : {1u, 2u}) {
    const std::vector<TinVertex> points = tin_points(350, seed);
    for (auto [s, k] : {std::pair(3, 1), std::pair(8, 1), std::pair(8, 4), std::pair(16, 4), std::pair(7, 3)}) {
      const VertexHorizons a = swept(points, s, k), b = brute(points, s, k);
      EXPECT_EQ(a.horizon, b.horizon) << "seed " << seed << ", " << s << "/" << k;
      std::size_t found = 0;
      for (std::uint32_t h : a.horizon) found += h != kNoHorizon;
      EXPECT_GT(found, a.horizon.size() / 2);  // most vertices have most horizons
    }
  }
}

TEST(Horizons, SweepEqualsBruteForceOnALatticeFullOfTies) {
  // Whole-metre lattice: for s = 4 and 8 many points share A, B or T, and
  // heights in whole metres make many slopes equal.
  std::vector<TinVertex> points;
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> z(0, 6);
  for (int r = 0; r < 18; ++r)
    for (int c = 0; c < 18; ++c) points.push_back({c * 10.0, r * 10.0, static_cast<double>(z(rng))});
  for (auto [s, k] : {std::pair(4, 1), std::pair(8, 1), std::pair(4, 2), std::pair(8, 2), std::pair(16, 1)})
    EXPECT_EQ(swept(points, s, k).horizon, brute(points, s, k).horizon) << s << "/" << k;
}

TEST(Horizons, SweepEqualsBruteForceOnCollinearAndEqualProjectionSets) {
  std::vector<TinVertex> line;  // one line, heights rising and falling
  for (int i = 0; i < 60; ++i) line.push_back({3.0 * i, 6.0 * i, std::fabs(std::sin(i * 0.7)) * 20});
  // Rows across sector 0's centre direction of s = 4 (45 degrees): along
  // x + y = const every point has the same T, and pairs share their z.
  std::vector<TinVertex> rows;
  for (int d = 0; d < 12; ++d)
    for (int i = -5; i <= 5; ++i) rows.push_back({d * 7.0 + i, d * 7.0 - i, static_cast<double>((d * 3) % 5 + (i & 1))});
  for (const auto* set : {&line, &rows})
    for (auto [s, k] : {std::pair(4, 1), std::pair(3, 1), std::pair(8, 2)})
      EXPECT_EQ(swept(*set, s, k).horizon, brute(*set, s, k).horizon) << s << "/" << k;
}

TEST(Horizons, SweepEqualsBruteForceAboveTheSweepsCacheBlock) {
  // More points than a cache block of the sweep (4096 leaves), so its
  // levels run both block by block and over the whole array.
  std::vector<TinVertex> points;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> jitter(-0.3, 0.3), z(0.0, 50.0);
  for (int r = 0; r < 70; ++r)
    for (int c = 0; c < 70; ++c) points.push_back({c + jitter(rng), r + jitter(rng), z(rng) + 0.5 * r});
  ASSERT_GT(points.size(), 4096u);
  for (auto [s, k] : {std::pair(4, 1), std::pair(3, 1)})
    EXPECT_EQ(swept(points, s, k).horizon, brute(points, s, k).horizon) << s << "/" << k;
}

TEST(Horizons, AHandBuiltHorizon) {
  // p at the origin; in sector 0 of 8 ([0, 45] degrees) three points near
  // 10 degrees at 5, 10 and 20 m rising 1, 5 and 8 m: slopes 0.2, 0.5, 0.4
  // along the ray, so the one at 10 m is the horizon; one at 30 degrees,
  // 40 m off, rising 10 m (0.25) is not.
  auto at = [](double degrees, double d, double z) {
    return TinVertex{d * std::cos(degrees * kPi / 180), d * std::sin(degrees * kPi / 180), z};
  };
  const std::vector<TinVertex> points = {{0, 0, 0}, at(10, 5, 1), at(10, 10, 5), at(10, 20, 8), at(30, 40, 10)};
  const VertexHorizons h = swept(points, 8, 1);
  EXPECT_EQ(h.at(0, 0), 2u);
  for (int i = 1; i < 8; ++i) EXPECT_EQ(h.at(0, i), kNoHorizon) << i;  // nothing else around p
  // From the point 5 m out, the one at 10 m (4 m up in 5 m) beats the one
  // at 20 m (7 m up in 15 m) and the one at 30 degrees.
  EXPECT_EQ(h.at(1, 0), 2u);
  // The far point sees p and the points 5 and 10 m out in sector 4 (180-225
  // degrees; the one 20 m out lies at 228), all below it: the least steep
  // descent wins, the point 10 m out (5 m down over about 30 m).
  EXPECT_EQ(h.at(4, 4), 2u);
  EXPECT_EQ(h.horizon, brute(points, 8, 1).horizon);
}

TEST(Horizons, ASectorKeepsItsLowestSubsectorHorizon) {
  auto at = [](double degrees, double d, double z) {
    return TinVertex{d * std::cos(degrees * kPi / 180), d * std::sin(degrees * kPi / 180), z};
  };
  // Sector 0 of 4 holds 0-90 degrees; with k = 2 its halves are 0-45 and 45-90.
  const std::vector<TinVertex> points = {{0, 0, 0}, at(20, 10, 10), at(70, 10, 2)};
  EXPECT_EQ(swept(points, 4, 1).at(0, 0), 1u);  // the steeper of the two in the sector's plane
  EXPECT_EQ(swept(points, 4, 2).at(0, 0), 2u);  // the lower of the halves' horizons
  // A half with no vertex leaves the sector with no horizon.
  const std::vector<TinVertex> one_half = {{0, 0, 0}, at(20, 10, 10)};
  EXPECT_EQ(swept(one_half, 4, 1).at(0, 0), 1u);
  EXPECT_EQ(swept(one_half, 4, 2).at(0, 0), kNoHorizon);
}

TEST(Horizons, ScalingHeightsChangesNothing) {
  std::vector<TinVertex> points = tin_points(500, 9);
  const VertexHorizons before = swept(points, 16, 4);
  for (TinVertex& v : points) v.z *= 3.0;  // exact for float-born heights
  EXPECT_EQ(swept(points, 16, 4).horizon, before.horizon);
}

TEST(Horizons, RefusesOptionsOutOfRangeAndStopsWhenCancelled) {
  const std::vector<TinVertex> points = tin_points(50, 1);
  for (auto [s, k, field] : {std::tuple(2, 1, "sectors"), std::tuple(300, 1, "sectors"), std::tuple(8, 0, "subsectors"),
                             std::tuple(64, 32, "subsectors")}) {
    auto h = compute_horizons(points, {s, k, 1});
    ASSERT_FALSE(h.ok());
    EXPECT_EQ(h.error().field, field);
  }
  CancelToken cancel;
  cancel.cancel();
  RunControl control;
  control.cancel = &cancel;
  auto h = compute_horizons(points, {8, 1, 1}, &control);
  ASSERT_FALSE(h.ok());
  EXPECT_EQ(h.error().code, ErrorCode::kCancelled);
}

}  // namespace
}  // namespace horizon::mesh
