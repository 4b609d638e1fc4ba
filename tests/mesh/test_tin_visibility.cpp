// Tests for mesh/tin_visibility.cpp: heights on a plane, a wall that hides
// by hand, and the grid walk against a scan of every edge on a TIN of a
// bundled DEM.
#include <gtest/gtest.h>

#include <random>

#include "horizon/mesh/tin_from_dem.hpp"
#include "horizon/mesh/tin_visibility.hpp"
#include "horizon/terrain/dem_reader.hpp"
#include "test_support.hpp"

namespace horizon::mesh {
namespace {

// An n×n lattice of 10 m squares, two triangles each, z = f(x, y).
template <class F>
Tin lattice(int n, F f) {
  Tin tin;
  for (int r = 0; r <= n; ++r)
    for (int c = 0; c <= n; ++c) tin.vertices.push_back({10.0 * c, 10.0 * r, f(10.0 * c, 10.0 * r)});
  auto at = [&](int c, int r) { return static_cast<std::uint32_t>(r * (n + 1) + c); };
  for (int r = 0; r < n; ++r)
    for (int c = 0; c < n; ++c) {
      tin.triangles.push_back({at(c, r), at(c + 1, r), at(c + 1, r + 1)});
      tin.triangles.push_back({at(c, r), at(c + 1, r + 1), at(c, r + 1)});
    }
  EXPECT_TRUE(check_height_field(tin, "lattice").ok());
  return tin;
}

TEST(TinVisibility, HeightsOnAPlaneAndOffTheMesh) {
  const Tin tin = lattice(8, [](double x, double y) { return 100 + 0.5 * x - 0.25 * y; });
  const TinVisibility vis(tin);
  for (double x : {0.0, 3.3, 41.7, 80.0})
    for (double y : {0.0, 12.5, 79.9}) {
      const auto z = vis.height_at(x, y);
      ASSERT_TRUE(z.has_value()) << x << " " << y;
      EXPECT_NEAR(*z, 100 + 0.5 * x - 0.25 * y, 1e-9);
    }
  EXPECT_FALSE(vis.height_at(-1, 5).has_value());
  EXPECT_FALSE(vis.height_at(40, 80.5).has_value());
}

TEST(TinVisibility, AWallHidesWhatIsLowBehindIt) {
  // Flat at 0 except a 20 m wall along x = 40.
  const Tin tin = lattice(8, [](double x, double) { return x == 40.0 ? 20.0 : 0.0; });
  const TinVisibility vis(tin);
  const TinVertex eye{5, 35, 2};
  EXPECT_FALSE(vis.visible(eye, {75, 41, 0}));    // behind the wall
  EXPECT_TRUE(vis.visible(eye, {25, 41, 0}));     // in front of it
  EXPECT_TRUE(vis.visible({5, 35, 100}, {75, 41, 0}));  // over it from high up
  // The wall's crest is 20 m at x = 40; from z = 2 at x = 5 a target at
  // x = 75 must be 20 + (20 - 2) * 35/35 = 38 m high to be seen over it.
  EXPECT_FALSE(vis.visible(eye, {75, 35, 37.9}));
  EXPECT_TRUE(vis.visible(eye, {75, 35, 38.1}));
  // Along the lattice lines too (the track runs through vertices).
  EXPECT_FALSE(vis.visible({0, 40, 1}, {80, 40, 1}));
}

TEST(TinVisibility, GridWalkFindsWhatAScanOfEveryEdgeFinds) {
  auto dem = terrain::read_dem(testing::bundled_dem("ecuador_andes_utm17s_10m_383x415.tif"));
  ASSERT_TRUE(dem.ok()) << dem.error().message;
  auto built = tin_from_dem(*dem, {1500, 0.0});
  ASSERT_TRUE(built.ok()) << built.error().message;
  const Tin& tin = built->tin;
  const TinVisibility vis(tin);
  // The reference: every edge, the same crossing rule.
  std::vector<std::array<std::uint32_t, 2>> edges;
  for (const TinTriangle& t : tin.triangles)
    for (int e = 0; e < 3; ++e) edges.push_back({std::min(t[e], t[(e + 1) % 3]), std::max(t[e], t[(e + 1) % 3])});
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  auto scan = [&](const TinVertex& eye, const TinVertex& target) {
    const double dx = target.x - eye.x, dy = target.y - eye.y;
    for (const auto& e : edges) {
      const TinVertex& a = tin.vertices[e[0]];
      const TinVertex& b = tin.vertices[e[1]];
      const double ex = b.x - a.x, ey = b.y - a.y, denom = dx * ey - dy * ex;
      if (denom == 0.0) continue;
      const double t = ((a.x - eye.x) * ey - (a.y - eye.y) * ex) / denom;
      const double u = ((a.x - eye.x) * dy - (a.y - eye.y) * dx) / denom;
      if (t <= 1e-6 || t >= 1 - 1e-6 || u < 0 || u > 1) continue;
      if (a.z + u * (b.z - a.z) > eye.z + t * (target.z - eye.z) + 1e-6) return false;
    }
    return true;
  };
  std::mt19937_64 rng(3);
  std::uniform_int_distribution<std::size_t> pick(0, tin.vertices.size() - 1);
  int hidden = 0, seen = 0;
  for (int i = 0; i < 2000; ++i) {
    TinVertex eye = tin.vertices[pick(rng)];
    eye.z += i % 3 == 0 ? 200.0 : 2.0;
    const TinVertex& target = tin.vertices[pick(rng)];
    const bool expected = scan(eye, target);
    ASSERT_EQ(vis.visible(eye, target), expected) << "pair " << i;
    (expected ? seen : hidden) += 1;
  }
  EXPECT_GT(hidden, 200);  // the terrain hides a fair share: the test means something
  EXPECT_GT(seen, 200);
}

}  // namespace
}  // namespace horizon::mesh
