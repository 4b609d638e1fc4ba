// Tests for mesh/crystals.cpp, mesh/prepared_mesh.cpp and mesh/cull.cpp on
// TINs of a bundled DEM (the Ecuadorian Andes, UTM 17S, 10 m): the groups
// partition the triangles into contiguous runs, the hierarchy nests
// (circles and regions), a culled parent culls its children, the same
// seed gives the same groups, scaling z changes nothing, and the
// approximate mode's culls are measured against exact lines of sight.
#include <gtest/gtest.h>

#include <algorithm>
#include <mutex>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>

#include "horizon/mesh/crystals.hpp"
#include "horizon/mesh/cull.hpp"
#include "horizon/mesh/mesh_boxes.hpp"
#include "horizon/mesh/prepared_mesh.hpp"
#include "horizon/mesh/tin_from_dem.hpp"
#include "horizon/mesh/tin_visibility.hpp"
#include "horizon/terrain/dem_reader.hpp"
#include "andes_tin.hpp"
#include "test_support.hpp"

namespace horizon::mesh {
namespace {

using testing_tins::andes_tin;

PrepareOptions small_options() {
  PrepareOptions o;
  o.horizons = {16, 4, 0};
  o.crystals.seeds = 60;
  o.crystals.min_group_size = 30;
  o.crystals.max_groups = 200;
  return o;
}

PreparedMesh prepare(const Tin& tin, const PrepareOptions& options) {
  auto mesh = prepare_mesh(tin, options);
  EXPECT_TRUE(mesh.ok()) << mesh.error().message;
  return std::move(*mesh);
}

TEST(Crystals, AVertexCannotSeePastAWallBelowItsHorizon) {
  // A 10 m lattice, flat at 0 but for a 20 m wall along x = 40.
  Tin tin;
  const int n = 8;
  for (int r = 0; r <= n; ++r)
    for (int c = 0; c <= n; ++c) tin.vertices.push_back({10.0 * c, 10.0 * r, c == 4 ? 20.0 : 0.0});
  auto at = [&](int c, int r) { return static_cast<std::uint32_t>(r * (n + 1) + c); };
  for (int r = 0; r < n; ++r)
    for (int c = 0; c < n; ++c) {
      tin.triangles.push_back({at(c, r), at(c + 1, r), at(c + 1, r + 1)});
      tin.triangles.push_back({at(c, r), at(c + 1, r + 1), at(c, r + 1)});
    }
  ASSERT_TRUE(check_height_field(tin, "wall").ok());
  auto horizons = compute_horizons(tin.vertices, {16, 1, 1});
  ASSERT_TRUE(horizons.ok());
  const std::uint32_t p = at(1, 4);  // (10, 40, 0), west of the wall
  // East-north-east, behind the wall: hidden low, seen from high up (the
  // ray from p over the crest at x = 40 rises 20 m in 30 m).
  EXPECT_TRUE(occluded_from_vertex(tin.vertices, *horizons, p, {75, 45, 0}));
  EXPECT_TRUE(occluded_from_vertex(tin.vertices, *horizons, p, {75, 45, 40}));
  EXPECT_FALSE(occluded_from_vertex(tin.vertices, *horizons, p, {75, 45, 60}));
  // In front of the wall nothing is in the way.
  EXPECT_FALSE(occluded_from_vertex(tin.vertices, *horizons, p, {30, 42, 0}));
  // West, away from the wall, a metre up: the flat lattice hides nothing
  // (at 0 m the camera is on the horizon's ray, which counts as hidden).
  EXPECT_FALSE(occluded_from_vertex(tin.vertices, *horizons, p, {0, 41, 1}));
  EXPECT_TRUE(occluded_from_vertex(tin.vertices, *horizons, p, {0, 41, 0}));
}

TEST(PrepareMesh, GroupsAreContiguousRunsThatPartitionTheTriangles) {
  const PreparedMesh mesh = prepare(andes_tin(), small_options());
  const std::size_t n = andes_tin().triangles.size();
  ASSERT_EQ(mesh.tin.triangles.size(), n);
  // source_triangle is a permutation, and each reordered triangle is its source.
  std::vector<std::uint32_t> sorted = mesh.source_triangle;
  std::sort(sorted.begin(), sorted.end());
  for (std::uint32_t i = 0; i < n; ++i) ASSERT_EQ(sorted[i], i);
  for (std::size_t i = 0; i < n; ++i)
    ASSERT_EQ(mesh.tin.triangles[i], andes_tin().triangles[mesh.source_triangle[i]]);

  ASSERT_GT(mesh.stats.leaf_groups, 5u);
  for (std::uint32_t g = 0; g < mesh.stats.leaf_groups; ++g) {
    EXPECT_TRUE(mesh.groups[g].leaf());
    EXPECT_GE(mesh.groups[g].triangle_count, 30u);
  }
  for (std::size_t g = mesh.stats.leaf_groups; g < mesh.groups.size(); ++g) {
    const MeshGroup& p = mesh.groups[g];
    ASSERT_FALSE(p.leaf());
    const MeshGroup& a = mesh.groups[static_cast<std::size_t>(p.children[0])];
    const MeshGroup& b = mesh.groups[static_cast<std::size_t>(p.children[1])];
    EXPECT_EQ(p.first_triangle, a.first_triangle);
    EXPECT_EQ(b.first_triangle, a.first_triangle + a.triangle_count);
    EXPECT_EQ(p.triangle_count, a.triangle_count + b.triangle_count);
    for (const MeshGroup* child : {&a, &b})  // the parent's circle holds the child's
      EXPECT_LE(std::hypot(child->circle.x - p.circle.x, child->circle.y - p.circle.y) + child->circle.radius,
                p.circle.radius * (1 + 1e-9));
  }
  // The roots' runs, then the always-visible run, tile the triangles.
  std::uint32_t next = 0;
  for (std::uint32_t root : mesh.top_level) {
    EXPECT_EQ(mesh.groups[root].first_triangle, next);
    next += mesh.groups[root].triangle_count;
  }
  EXPECT_EQ(next, mesh.always_visible_first);
  EXPECT_EQ(mesh.always_visible_first + mesh.always_visible_count, n);
  // Each leaf's circle holds its vertices.
  for (std::uint32_t g = 0; g < mesh.stats.leaf_groups; ++g) {
    const MeshGroup& leaf = mesh.groups[g];
    for (std::uint32_t t = leaf.first_triangle; t < leaf.first_triangle + leaf.triangle_count; ++t)
      for (std::uint32_t v : mesh.tin.triangles[t]) {
        const TinVertex& p = mesh.tin.vertices[v];
        EXPECT_LE(std::hypot(p.x - leaf.circle.x, p.y - leaf.circle.y), leaf.circle.radius);
      }
  }
}

TEST(PrepareMesh, EveryGroupIsPlacedWhateverTheMergeCutoff) {
  // A small cutoff retires parents early; a group whose last collision
  // went into a retired parent must still be a root, so the runs still
  // tile the triangles.
  for (double cutoff : {0.005, 0.02, 0.1, 1.0}) {
    PrepareOptions o = small_options();
    o.merge_cutoff = cutoff;
    const PreparedMesh mesh = prepare(andes_tin(), o);
    std::uint64_t total = mesh.always_visible_count;
    for (std::uint32_t root : mesh.top_level) total += mesh.groups[root].triangle_count;
    EXPECT_EQ(total, andes_tin().triangles.size()) << "cutoff " << cutoff;
    // Every group is a root or some parent's child, once.
    std::vector<int> owners(mesh.groups.size(), 0);
    for (std::uint32_t root : mesh.top_level) ++owners[root];
    for (const MeshGroup& g : mesh.groups)
      if (!g.leaf()) ++owners[static_cast<std::size_t>(g.children[0])], ++owners[static_cast<std::size_t>(g.children[1])];
    for (std::size_t g = 0; g < owners.size(); ++g) EXPECT_EQ(owners[g], 1) << "group " << g << " cutoff " << cutoff;
  }
}

TEST(PrepareMesh, AParentsRegionLiesInsideItsChildrens) {
  const PreparedMesh mesh = prepare(andes_tin(), small_options());
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int inside = 0;
  for (std::size_t g = mesh.stats.leaf_groups; g < mesh.groups.size(); ++g)
    for (int i = 0; i < mesh.sectors; ++i) {
      const OcclusionChain& parent = mesh.region(g, i);
      if (parent.empty()) continue;
      for (int k = 0; k < 50; ++k) {
        const double t = parent.corners().front().t + std::abs(u(rng)) * 3000;
        const double z = parent.height_at(t) + u(rng) * 20;
        if (!parent.contains(t, z)) continue;
        ++inside;
        for (std::int32_t child : mesh.groups[g].children)
          EXPECT_TRUE(mesh.region(static_cast<std::size_t>(child), i).contains(t, z)) << "group " << g << " sector " << i;
      }
    }
  EXPECT_GT(inside, 100);
}

// Cameras 2 m above the lowest, a middling and the highest vertex, and
// one 3 km above the middle of the mesh.
std::vector<TinVertex> cameras(const Tin& tin) {
  std::vector<TinVertex> by_height = tin.vertices;
  std::sort(by_height.begin(), by_height.end(), [](const TinVertex& a, const TinVertex& b) { return a.z < b.z; });
  std::vector<TinVertex> out;
  for (std::size_t at : {std::size_t{0}, by_height.size() / 3, by_height.size() / 2, by_height.size() - 1}) {
    TinVertex c = by_height[at];
    c.z += 2.0;
    out.push_back(c);
  }
  double x = 0, y = 0;
  for (const TinVertex& v : tin.vertices) x += v.x, y += v.y;
  const double n = static_cast<double>(tin.vertices.size());
  out.push_back({x / n, y / n, by_height.back().z + 3000});
  return out;
}

TEST(CullMesh, ACulledParentCullsItsChildren) {
  const PreparedMesh mesh = prepare(andes_tin(), small_options());
  std::mt19937_64 rng(9);
  std::uniform_int_distribution<std::size_t> pick(0, mesh.tin.vertices.size() - 1);
  int culled_parents = 0;
  for (int trial = 0; trial < 300; ++trial) {
    TinVertex camera = mesh.tin.vertices[pick(rng)];
    camera.z += trial % 2 ? 2.0 : 30.0;
    for (std::size_t g = mesh.stats.leaf_groups; g < mesh.groups.size(); ++g) {
      if (!group_hidden(mesh, g, camera)) continue;
      ++culled_parents;
      for (std::int32_t child : mesh.groups[g].children)
        EXPECT_TRUE(group_hidden(mesh, static_cast<std::size_t>(child), camera));
    }
  }
  EXPECT_GT(culled_parents, 0);
}

TEST(CullMesh, TheSameSeedGivesTheSameGroupsAndScalingZChangesNothing) {
  const PreparedMesh a = prepare(andes_tin(), small_options());
  const PreparedMesh b = prepare(andes_tin(), small_options());
  EXPECT_EQ(a.source_triangle, b.source_triangle);
  EXPECT_EQ(a.top_level, b.top_level);
  EXPECT_EQ(a.regions, b.regions);
  // The circles (CGAL's Min_circle_2 shuffles its points) and so the walls,
  // bit for bit.
  ASSERT_EQ(a.groups.size(), b.groups.size());
  for (std::size_t g = 0; g < a.groups.size(); ++g) {
    EXPECT_EQ(a.groups[g].circle.x, b.groups[g].circle.x) << g;
    EXPECT_EQ(a.groups[g].circle.y, b.groups[g].circle.y) << g;
    EXPECT_EQ(a.groups[g].circle.radius, b.groups[g].circle.radius) << g;
  }
  EXPECT_EQ(a.group_top, b.group_top);
  EXPECT_EQ(a.wall_begin, b.wall_begin);
  EXPECT_EQ(a.wall_radius, b.wall_radius);
  EXPECT_EQ(a.wall_slope, b.wall_slope);

  Tin tall = andes_tin();
  for (TinVertex& v : tall.vertices) v.z *= 3.0;
  const PreparedMesh c = prepare(tall, small_options());
  EXPECT_EQ(a.source_triangle, c.source_triangle);
  EXPECT_EQ(a.top_level, c.top_level);
  ASSERT_EQ(a.groups.size(), c.groups.size());
  for (const TinVertex& camera : cameras(andes_tin())) {
    for (CullMode mode : {CullMode::kApproximate, CullMode::kConservative}) {
      auto plain = cull(a, {camera, {}, {}, mode});
      auto scaled = cull(c, {{camera.x, camera.y, camera.z * 3.0}, {}, {}, mode});
      ASSERT_TRUE(plain.ok() && scaled.ok());
      EXPECT_EQ(plain->visible_groups, scaled->visible_groups);
      EXPECT_EQ(plain->triangles_culled, scaled->triangles_culled);
    }
  }

  PrepareOptions other = small_options();
  other.crystals.random_seed = 2;
  EXPECT_NE(prepare(andes_tin(), other).source_triangle, a.source_triangle);
}

TEST(CullMesh, TheFrustumCullsWhatLiesOutsideTheView) {
  const PreparedMesh mesh = prepare(andes_tin(), small_options());
  TinVertex camera = cameras(mesh.tin).back();  // high above the middle: nothing hidden by terrain
  auto all = cull(mesh, {camera, {}, {}});
  ASSERT_TRUE(all.ok());
  EXPECT_EQ(all->groups_culled, 0u);
  // Looking north-east, 60° wide.
  auto view = cull(mesh, {camera, 15.0, 75.0});
  ASSERT_TRUE(view.ok());
  EXPECT_GT(view->frustum_culled, 0u);
  EXPECT_EQ(view->frustum_culled, view->groups_culled);
  // No vertex of a frustum-culled leaf lies in the view; every visible
  // leaf has its circle at least partly in it.
  auto in_view = [&](double x, double y) {
    double azimuth = std::atan2(x - camera.x, y - camera.y) * 180 / std::numbers::pi;  // clockwise from north
    if (azimuth < 0) azimuth += 360;
    return azimuth >= 15.0 && azimuth <= 75.0;
  };
  std::vector<bool> drawn(mesh.groups.size(), false);
  for (std::uint32_t g : view->visible_groups) drawn[g] = true;
  int checked = 0;
  for (std::uint32_t g = 0; g < mesh.stats.leaf_groups; ++g) {
    bool any_in_view = false;
    const MeshGroup& leaf = mesh.groups[g];
    for (std::uint32_t t = leaf.first_triangle; t < leaf.first_triangle + leaf.triangle_count; ++t)
      for (std::uint32_t v : mesh.tin.triangles[t]) any_in_view |= in_view(mesh.tin.vertices[v].x, mesh.tin.vertices[v].y);
    if (any_in_view) {
      EXPECT_TRUE(drawn[g]) << "leaf " << g << " has a vertex in view but was culled";
    }
    checked += any_in_view ? 1 : 0;
  }
  EXPECT_GT(checked, 0);
  auto bad = cull(mesh, {camera, 15.0, {}});
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("both azimuth_from and azimuth_to"), std::string::npos);
}

// A triangle is seen when a vertex or an interior sample is.
bool triangle_seen(const TinVisibility& vis, const Tin& tin, const TinTriangle& t, const TinVertex& eye) {
  const TinVertex& a = tin.vertices[t[0]];
  const TinVertex& b = tin.vertices[t[1]];
  const TinVertex& c = tin.vertices[t[2]];
  static constexpr double kSamples[][3] = {{1, 0, 0},       {0, 1, 0},       {0, 0, 1},       {1. / 3, 1. / 3, 1. / 3},
                                           {.6, .2, .2},    {.2, .6, .2},    {.2, .2, .6},    {.45, .45, .1},
                                           {.45, .1, .45},  {.1, .45, .45}};
  for (const auto& w : kSamples) {
    const TinVertex p{w[0] * a.x + w[1] * b.x + w[2] * c.x, w[0] * a.y + w[1] * b.y + w[2] * c.y,
                      w[0] * a.z + w[1] * b.z + w[2] * c.z};
    if (vis.visible(eye, p)) return true;
  }
  return false;
}

TEST(CullMesh, ApproximateCullsAgainstExactLinesOfSight) {
  const TinVisibility vis(andes_tin());
  const std::vector<TinVertex> eyes = cameras(andes_tin());
  for (auto [s, k] : {std::pair{8, 1}, std::pair{16, 4}, std::pair{32, 2}}) {
    PrepareOptions options = small_options();
    options.horizons = {s, k, 0};
    const PreparedMesh mesh = prepare(andes_tin(), options);
    std::uint64_t culled = 0, false_hidden = 0, hidden = 0, triangles = 0;
    for (std::size_t e = 0; e < eyes.size(); ++e) {
      auto answer = cull(mesh, {eyes[e], {}, {}});
      ASSERT_TRUE(answer.ok());
      const std::vector<std::uint8_t> drawn = triangle_states(mesh, *answer);
      std::uint64_t culled_here = 0;
      for (std::size_t t = 0; t < drawn.size(); ++t) {
        const bool seen = triangle_seen(vis, mesh.tin, mesh.tin.triangles[t], eyes[e]);
        hidden += seen ? 0 : 1;
        if (drawn[t]) continue;
        ++culled_here;
        false_hidden += seen ? 1 : 0;
      }
      EXPECT_EQ(culled_here, answer->triangles_culled);
      culled += culled_here;
      triangles += drawn.size();
      if (e + 1 == eyes.size()) {
        EXPECT_EQ(culled_here, 0u) << "nothing hides anything from 3 km up";
      }
    }
    const double false_rate = culled ? static_cast<double>(false_hidden) / static_cast<double>(culled) : 0.0;
    std::printf("approximate %d/%d: culled %llu of %llu triangles (exactly hidden %llu), false-hidden %llu (%.2f %% of culled)\n",
                s, k, static_cast<unsigned long long>(culled), static_cast<unsigned long long>(triangles),
                static_cast<unsigned long long>(hidden), static_cast<unsigned long long>(false_hidden), 100 * false_rate);
    EXPECT_GT(culled, 0u) << s << "/" << k << " culled nothing from the valley";
    EXPECT_LE(culled, hidden + false_hidden);
  }
}

TEST(CullMesh, ConservativeCullsNothingThatCanBeSeen) {
  const TinVisibility vis(andes_tin());
  const PreparedMesh mesh = prepare(andes_tin(), small_options());
  std::mt19937_64 rng(17);
  std::uniform_int_distribution<std::size_t> pick(0, andes_tin().vertices.size() - 1);
  std::vector<TinVertex> eyes = cameras(andes_tin());
  for (int k = 0; k < 40; ++k) {
    TinVertex eye = andes_tin().vertices[pick(rng)];
    eye.z += k % 4 == 0 ? 50.0 : 2.0;
    eyes.push_back(eye);
  }
  std::uint64_t culled = 0, approximate_culled = 0;
  for (const TinVertex& eye : eyes) {
    auto answer = cull(mesh, {eye, {}, {}, CullMode::kConservative});
    ASSERT_TRUE(answer.ok());
    const std::vector<std::uint8_t> drawn = triangle_states(mesh, *answer);
    for (std::size_t t = 0; t < drawn.size(); ++t) {
      if (drawn[t]) continue;
      ++culled;
      ASSERT_FALSE(triangle_seen(vis, mesh.tin, mesh.tin.triangles[t], eye))
          << "triangle " << t << " culled but seen from (" << eye.x << ", " << eye.y << ", " << eye.z << ")";
    }
    approximate_culled += cull(mesh, {eye, {}, {}, CullMode::kApproximate})->triangles_culled;
  }
  std::printf("conservative 16/4: culled %llu triangle-views from %zu cameras (approximate: %llu)\n",
              static_cast<unsigned long long>(culled), eyes.size(), static_cast<unsigned long long>(approximate_culled));
}

// A crater 3 km across, as a 3 000-vertex TIN: a floor at 0 m inside
// 400 m of the centre, a plateau ring at 300 m from 500 m to 900 m, plains
// at 0 m outside 1 000 m.
Tin crater_tin() {
  const terrain::Dem dem = testing::make_dem(300, 300, [](int c, int r) {
    const double d = std::hypot(c * 10.0 - 1495, r * 10.0 - 1495);
    if (d < 400 || d > 1000) return 0.0;
    if (d < 500) return 300 * (d - 400) / 100;
    if (d > 900) return 300 * (1000 - d) / 100;
    return 300.0;
  });
  auto built = tin_from_dem(dem, {3000, 0.0});
  EXPECT_TRUE(built.ok()) << built.error().message;
  return built.ok() ? std::move(built->tin) : Tin{};
}

TEST(CullMesh, ConservativeCullsACraterFloorFromOutside) {
  const PreparedMesh mesh = prepare(crater_tin(), small_options());
  const TinVisibility vis(mesh.tin);
  double cx = 0, cy = 0;
  for (const TinVertex& v : mesh.tin.vertices) cx += v.x, cy += v.y;
  cx /= static_cast<double>(mesh.tin.vertices.size()), cy /= static_cast<double>(mesh.tin.vertices.size());
  std::uint64_t floor_culled = 0;
  for (double angle = 0; angle < 6.28; angle += 0.5) {
    const TinVertex eye{cx + 1300 * std::cos(angle), cy + 1300 * std::sin(angle), 2.0};
    auto answer = cull(mesh, {eye, {}, {}, CullMode::kConservative});
    ASSERT_TRUE(answer.ok());
    const std::vector<std::uint8_t> drawn = triangle_states(mesh, *answer);
    for (std::size_t t = 0; t < drawn.size(); ++t) {
      if (drawn[t]) continue;
      ASSERT_FALSE(triangle_seen(vis, mesh.tin, mesh.tin.triangles[t], eye)) << "triangle " << t;
      const TinVertex& a = mesh.tin.vertices[mesh.tin.triangles[t][0]];
      if (std::hypot(a.x - cx, a.y - cy) < 400) ++floor_culled;
    }
    // From 2 km up the crater floor is in view, and nothing may be culled.
    auto high = cull(mesh, {{eye.x, eye.y, 2000.0}, {}, {}, CullMode::kConservative});
    ASSERT_TRUE(high.ok());
    EXPECT_EQ(high->triangles_culled, 0u);
  }
  EXPECT_GT(floor_culled, 0u);
}

TEST(PrepareMesh, ReportsProgressAndStopsWhenCancelled) {
  std::vector<double> seen;
  std::mutex lock;
  RunControl control;
  control.progress = [&](double f) {
    std::lock_guard<std::mutex> hold(lock);
    seen.push_back(f);
  };
  ASSERT_TRUE(prepare_mesh(andes_tin(), small_options(), &control).ok());
  ASSERT_FALSE(seen.empty());
  EXPECT_DOUBLE_EQ(seen.back(), 1.0);
  EXPECT_DOUBLE_EQ(*std::max_element(seen.begin(), seen.end()), 1.0);
  EXPECT_GE(*std::min_element(seen.begin(), seen.end()), 0.0);

  CancelToken cancel;
  cancel.cancel();
  RunControl stopped;
  stopped.cancel = &cancel;
  auto r = prepare_mesh(andes_tin(), small_options(), &stopped);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kCancelled);
}

// The box's corners top and bottom, its top's centre and edge midpoints.
std::vector<TinVertex> box_samples(const MeshBox& b) {
  std::vector<TinVertex> out;
  for (double z : {b.z_min, b.z_max})
    for (double x : {b.x_min, b.x_max})
      for (double y : {b.y_min, b.y_max}) out.push_back({x, y, z});
  const double cx = (b.x_min + b.x_max) / 2, cy = (b.y_min + b.y_max) / 2;
  for (auto [x, y] : {std::pair{cx, cy}, {cx, b.y_min}, {cx, b.y_max}, {b.x_min, cy}, {b.x_max, cy}})
    out.push_back({x, y, b.z_max});
  return out;
}

TEST(MeshBoxes, HiddenBoxesAreUnseenAndCraterBoxesHideFromThePlains) {
  const PreparedMesh mesh = prepare(crater_tin(), small_options());
  const TinVisibility vis(mesh.tin);
  double cx = 0, cy = 0;
  for (const TinVertex& v : mesh.tin.vertices) cx += v.x, cy += v.y;
  cx /= static_cast<double>(mesh.tin.vertices.size()), cy /= static_cast<double>(mesh.tin.vertices.size());
  // Twenty-metre boxes: four on the crater floor, four on the plains.
  std::vector<MeshBox> boxes;
  for (double angle : {0.3, 1.9, 3.5, 5.1}) {
    for (double r : {150.0, 1250.0}) {
      const double x = cx + r * std::cos(angle), y = cy + r * std::sin(angle);
      boxes.push_back({x - 10, y - 10, x + 10, y + 10, 0.0, 20.0});
    }
  }
  auto registered = RegisteredBoxes::make(mesh, boxes);
  ASSERT_TRUE(registered.ok()) << registered.error().message;
  int floor_hidden = 0;
  for (double angle = 0; angle < 6.28; angle += 0.4) {
    const TinVertex eye{cx + 1400 * std::cos(angle), cy + 1400 * std::sin(angle), 2.0};
    for (std::size_t k = 0; k < boxes.size(); ++k) {
      if (!registered->hidden(mesh, k, eye)) continue;
      for (const TinVertex& p : box_samples(boxes[k])) ASSERT_FALSE(vis.visible(eye, p)) << "box " << k;
      floor_hidden += k % 2 == 0 ? 1 : 0;
    }
    for (std::size_t k = 0; k < boxes.size(); ++k)
      EXPECT_FALSE(registered->hidden(mesh, k, {eye.x, eye.y, 2000.0})) << "box " << k << " from 2 km up";
  }
  EXPECT_GT(floor_hidden, 0);

  // Random boxes and cameras over the Andes: whatever is reported hidden
  // is unseen at every sample.
  const PreparedMesh andes = prepare(andes_tin(), small_options());
  const TinVisibility andes_vis(andes_tin());
  std::mt19937_64 rng(31);
  std::uniform_int_distribution<std::size_t> pick(0, andes_tin().vertices.size() - 1);
  std::vector<MeshBox> random_boxes;
  for (int k = 0; k < 60; ++k) {
    const TinVertex& v = andes_tin().vertices[pick(rng)];
    random_boxes.push_back({v.x - 15, v.y - 15, v.x + 15, v.y + 15, v.z - 5, v.z + 10});
  }
  auto random_registered = RegisteredBoxes::make(andes, random_boxes);
  ASSERT_TRUE(random_registered.ok());
  for (int c = 0; c < 40; ++c) {
    TinVertex eye = andes_tin().vertices[pick(rng)];
    eye.z += 2;
    for (std::size_t k = 0; k < random_boxes.size(); ++k) {
      if (!random_registered->hidden(andes, k, eye)) continue;
      for (const TinVertex& p : box_samples(random_boxes[k])) {
        if (!andes_vis.height_at(p.x, p.y)) continue;  // a sample off the mesh
        ASSERT_FALSE(andes_vis.visible(eye, p)) << "box " << k;
      }
    }
  }

  const MeshBox bad[] = {{0, 0, 1, 1, 5, 4}};
  auto refused = RegisteredBoxes::make(mesh, bad);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.error().message.find("box 0 has a maximum below its minimum"), std::string::npos);
}

TEST(PrepareMesh, RefusesOptionsOutOfRange) {
  PrepareOptions o = small_options();
  o.crystals.seeds = 0;
  auto r = prepare_mesh(andes_tin(), o);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("seeds must be 1 to 1000000, not 0"), std::string::npos);
  o = small_options();
  o.merge_cutoff = 1.5;
  r = prepare_mesh(andes_tin(), o);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("merge_cutoff must be"), std::string::npos);
  o = small_options();
  o.horizons.sectors = 2;
  EXPECT_FALSE(prepare_mesh(andes_tin(), o).ok());
}

}  // namespace
}  // namespace horizon::mesh
