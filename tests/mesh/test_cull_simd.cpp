// Tests for the cull's vector form (mesh/cull_lanes.cpp, cull.hpp): for
// every instruction set this CPU runs, each cull answers exactly as the
// scalar twin does (the visible leaves in order, every count), in both
// modes, with and without a view, from cameras inside and outside the
// mesh, high and low, at group centres and on group circles, and with
// view edges tangent to groups; a mesh loaded from the cache has the
// same columns as the prepared one; and a hierarchy the vector form cannot
// rank is culled by the scalar twin whatever the cap.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include "common/simd_isa.hpp"  // core/src: the kernels' instruction-set cap
#include "horizon/mesh/cull.hpp"
#include "horizon/mesh/prepared_cache.hpp"
#include "horizon/mesh/prepared_mesh.hpp"
#include "horizon/mesh/tin_from_dem.hpp"
#include "horizon/terrain/dem_reader.hpp"
#include "mesh/prepared_parts.hpp"  // core/src: set_group_columns
#include "andes_tin.hpp"
#include "test_support.hpp"

namespace horizon::mesh {
namespace {

using simd_isa::Isa;

using testing_tins::andes_tin;

PreparedMesh prepare(int sectors, int subsectors) {
  PrepareOptions o;
  o.horizons = {sectors, subsectors, 0};
  o.crystals.seeds = 60;
  o.crystals.min_group_size = 30;
  o.crystals.max_groups = 200;
  auto mesh = prepare_mesh(andes_tin(), o);
  EXPECT_TRUE(mesh.ok()) << mesh.error().message;
  return std::move(*mesh);
}

// Restores the default cap however the test ends.
struct IsaCap {
  explicit IsaCap(Isa isa) { simd_isa::isa_limit() = isa; }
  ~IsaCap() { simd_isa::isa_limit() = Isa::kAvx512; }
};

std::vector<Isa> vector_isas() {
  std::vector<Isa> out;
  for (Isa isa : {Isa::kAvx2, Isa::kAvx512})
    if (simd_isa::cpu_isa() >= isa) out.push_back(isa);
  return out;
}

// Cameras of every kind the issue names, from a fixed seed.
std::vector<TinVertex> cameras(const PreparedMesh& mesh, std::size_t count) {
  double x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300, z0 = 1e300, z1 = -1e300;
  for (const TinVertex& v : mesh.tin.vertices) {
    x0 = std::min(x0, v.x), x1 = std::max(x1, v.x);
    y0 = std::min(y0, v.y), y1 = std::max(y1, v.y);
    z0 = std::min(z0, v.z), z1 = std::max(z1, v.z);
  }
  const double wx = x1 - x0, wy = y1 - y0;
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::uniform_int_distribution<std::size_t> vertex(0, mesh.tin.vertices.size() - 1);
  std::uniform_int_distribution<std::size_t> group(0, mesh.groups.size() - 1);
  std::vector<TinVertex> out;
  while (out.size() < count) {
    switch (out.size() % 6) {
      case 0: {  // just above a vertex
        TinVertex v = mesh.tin.vertices[vertex(rng)];
        v.z += 2.0;
        out.push_back(v);
        break;
      }
      case 1:  // anywhere over the mesh or past its edges, low to high
        out.push_back({x0 - 0.5 * wx + 2 * wx * unit(rng), y0 - 0.5 * wy + 2 * wy * unit(rng),
                       z0 - 50 + (z1 - z0 + 3000) * unit(rng)});
        break;
      case 2: {  // on a group's circle
        const Circle& c = mesh.groups[group(rng)].circle;
        const double a = 2 * std::numbers::pi * unit(rng);
        out.push_back({c.x + c.radius * std::cos(a), c.y + c.radius * std::sin(a), z0 + (z1 - z0) * unit(rng)});
        break;
      }
      case 3: {  // exactly east of a circle's centre by its radius, or at the centre
        const Circle& c = mesh.groups[group(rng)].circle;
        out.push_back({unit(rng) < 0.5 ? c.x + c.radius : c.x, c.y, z0 + (z1 - z0 + 500) * unit(rng)});
        break;
      }
      case 4: {  // far outside, high
        const double a = 2 * std::numbers::pi * unit(rng);
        out.push_back({x0 + wx / 2 + 3 * wx * std::cos(a), y0 + wy / 2 + 3 * wy * std::sin(a), z1 + 1000 * unit(rng)});
        break;
      }
      default: {  // at a vertex exactly, or just below the terrain
        TinVertex v = mesh.tin.vertices[vertex(rng)];
        if (unit(rng) < 0.5) v.z -= 1.0;
        out.push_back(v);
        break;
      }
    }
  }
  return out;
}

// Views for a camera: none, random ones, wide and narrow ones, and ones
// whose edge grazes a group's circle (the lanes' unsure band).
std::vector<CullQuery> queries(const PreparedMesh& mesh, const TinVertex& camera, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> degrees(-400.0, 400.0), width(0.0, 360.0), unit(0.0, 1.0);
  std::uniform_int_distribution<std::size_t> group(0, mesh.groups.size() - 1);
  std::vector<CullQuery> out;
  out.push_back({camera, {}, {}});
  const double from = degrees(rng);
  out.push_back({camera, from, from + width(rng)});
  out.push_back({camera, from, from + 1.0});
  out.push_back({camera, from, from + 300.0});
  out.push_back({camera, from, from - 10.0});  // 350° wide, clockwise
  out.push_back({camera, from, from});         // all around
  const Circle& c = mesh.groups[group(rng)].circle;
  const double dx = c.x - camera.x, dy = c.y - camera.y, d = std::hypot(dx, dy);
  if (d > c.radius) {
    const double centre = std::atan2(dy, dx), half = std::asin(c.radius / d);
    for (double edge : {centre + half, centre - half}) {
      const double azimuth = 90.0 - edge * 180.0 / std::numbers::pi;  // clockwise from north
      out.push_back({camera, azimuth, azimuth + 20.0 + 300.0 * unit(rng)});
      out.push_back({camera, azimuth - 20.0 - 300.0 * unit(rng), azimuth});
    }
  }
  return out;
}

std::string describe(const CullQuery& q) {
  std::string s = "camera (" + std::to_string(q.camera.x) + ", " + std::to_string(q.camera.y) + ", " +
                  std::to_string(q.camera.z) + ")";
  if (q.azimuth_from) s += " view " + std::to_string(*q.azimuth_from) + ".." + std::to_string(*q.azimuth_to);
  return s + (q.mode == CullMode::kConservative ? " conservative" : " approximate");
}

// Runs every query in both modes, scalar and then each vector form, and
// counts what the scalar culled so that the comparison cannot be empty.
struct Totals {
  std::uint64_t culls = 0, region_culled = 0, frustum_culled = 0, visible = 0;
};

void expect_forms_agree(const PreparedMesh& mesh, std::size_t camera_count, Totals& totals) {
  std::mt19937_64 rng(11);
  for (const TinVertex& camera : cameras(mesh, camera_count)) {
    for (CullQuery q : queries(mesh, camera, rng)) {
      for (CullMode mode : {CullMode::kApproximate, CullMode::kConservative}) {
        q.mode = mode;
        CullAnswer scalar;
        {
          IsaCap cap(Isa::kScalar);
          auto a = cull(mesh, q);
          ASSERT_TRUE(a.ok()) << a.error().message;
          scalar = std::move(*a);
        }
        ++totals.culls;
        totals.region_culled += scalar.groups_culled - scalar.frustum_culled;
        totals.frustum_culled += scalar.frustum_culled;
        totals.visible += scalar.visible_groups.size();
        for (Isa isa : vector_isas()) {
          IsaCap cap(isa);
          auto v = cull(mesh, q);
          ASSERT_TRUE(v.ok()) << v.error().message;
          const std::string where = describe(q) + (isa == Isa::kAvx2 ? " AVX2" : " AVX-512");
          ASSERT_EQ(v->visible_groups, scalar.visible_groups) << where;
          ASSERT_EQ(v->groups_tested, scalar.groups_tested) << where;
          ASSERT_EQ(v->groups_culled, scalar.groups_culled) << where;
          ASSERT_EQ(v->frustum_culled, scalar.frustum_culled) << where;
          ASSERT_EQ(v->triangles_culled, scalar.triangles_culled) << where;
          ASSERT_EQ(v->triangles_visible, scalar.triangles_visible) << where;
        }
      }
    }
  }
}

TEST(CullSimd, EveryFormAnswersAsTheScalarTwin) {
  if (vector_isas().empty()) GTEST_SKIP() << "this CPU runs the scalar cull only";
  for (auto [s, k] : {std::pair{16, 4}, std::pair{8, 2}, std::pair{32, 2}, std::pair{12, 3}, std::pair{7, 2}}) {
    SCOPED_TRACE(std::to_string(s) + "/" + std::to_string(k));
    const PreparedMesh mesh = prepare(s, k);
    ASSERT_TRUE(mesh.columns.usable);
    ASSERT_GT(mesh.top_level.size(), 5u);
    Totals t;
    expect_forms_agree(mesh, 240, t);
    // The comparison covered culls of every kind.
    EXPECT_GT(t.region_culled, t.culls / 4);
    EXPECT_GT(t.frustum_culled, t.culls);
    EXPECT_GT(t.visible, t.culls);
  }
}

TEST(CullSimd, TheColumnsFollowTheGroups) {
  const PreparedMesh mesh = prepare(16, 4);
  const GroupColumns& c = mesh.columns;
  ASSERT_EQ(c.x.size(), mesh.groups.size());
  for (std::size_t g = 0; g < mesh.groups.size(); ++g) {
    EXPECT_EQ(c.x[g], mesh.groups[g].circle.x);
    EXPECT_EQ(c.y[g], mesh.groups[g].circle.y);
    EXPECT_EQ(c.radius[g], mesh.groups[g].circle.radius);
  }
  // Every leaf is reached once, in triangle order.
  ASSERT_EQ(c.leaf_order.size(), mesh.stats.leaf_groups);
  for (std::size_t i = 0; i < c.leaf_order.size(); ++i) {
    EXPECT_EQ(c.leaf_rank[c.leaf_order[i]], i);
    if (i > 0) {
      EXPECT_EQ(mesh.groups[c.leaf_order[i]].first_triangle,
                mesh.groups[c.leaf_order[i - 1]].first_triangle + mesh.groups[c.leaf_order[i - 1]].triangle_count);
    }
  }
}

TEST(CullSimd, ALoadedMeshHasThePreparedColumns) {
  testing::TempDir dir;
  PrepareOptions o;
  o.crystals.seeds = 40;
  o.crystals.max_groups = 100;
  CacheUse first, second;
  auto a = prepare_cached(andes_tin(), o, dir.file("cache"), &first);
  ASSERT_TRUE(a.ok()) << a.error().message;
  auto b = prepare_cached(andes_tin(), o, dir.file("cache"), &second);
  ASSERT_TRUE(b.ok()) << b.error().message;
  ASSERT_TRUE(second.hit);
  EXPECT_TRUE(b->columns.usable);
  EXPECT_EQ(a->columns.x, b->columns.x);
  EXPECT_EQ(a->columns.y, b->columns.y);
  EXPECT_EQ(a->columns.radius, b->columns.radius);
  EXPECT_EQ(a->columns.leaf_order, b->columns.leaf_order);
  EXPECT_EQ(a->columns.leaf_rank, b->columns.leaf_rank);
  Totals t;
  if (!vector_isas().empty()) expect_forms_agree(*b, 30, t);
}

// A hierarchy that reaches a group twice (a damaged cache could name a
// child as a root too) cannot be ranked: the columns say so and every
// form answers as the scalar twin, the group counted each time it is
// reached.
TEST(CullSimd, AGroupReachedTwiceKeepsTheCullScalar) {
  PreparedMesh mesh = prepare(16, 4);
  ASSERT_TRUE(mesh.columns.usable);
  const MeshGroup& root = mesh.groups[mesh.top_level.front()];
  ASSERT_FALSE(root.leaf());
  mesh.top_level.push_back(static_cast<std::uint32_t>(root.children[0]));
  set_group_columns(mesh);
  EXPECT_FALSE(mesh.columns.usable);
  const TinVertex camera{mesh.groups[0].circle.x, mesh.groups[0].circle.y, 1e5};  // high: nothing hidden
  CullAnswer scalar;
  {
    IsaCap cap(Isa::kScalar);
    scalar = std::move(*cull(mesh, {camera, {}, {}}));
  }
  EXPECT_GT(scalar.groups_tested, static_cast<std::uint32_t>(mesh.groups.size()));  // some twice
  for (Isa isa : vector_isas()) {
    IsaCap cap(isa);
    auto v = cull(mesh, {camera, {}, {}});
    ASSERT_TRUE(v.ok());
    EXPECT_EQ(v->visible_groups, scalar.visible_groups);
    EXPECT_EQ(v->groups_tested, scalar.groups_tested);
  }
}

}  // namespace
}  // namespace horizon::mesh
