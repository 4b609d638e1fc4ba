// The GL trace of a clip-map (clip_trace_gl.cpp) against the CPU trace, on
// whatever EGL device this machine has (Mesa llvmpipe in CI, so it runs in
// every test run): boxes and viewshed cells come out the same, with the
// same work counted, fallbacks included, for both modes and with levels
// lagging; only levels whose version changed are copied to the context;
// the OHF sweep and the clip-map trace keep their resources side by side
// on one context.
#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <random>
#include <vector>

#include "clipmap_world.hpp"
#include "horizon/clipmap/clip_cull.hpp"
#include "horizon/clipmap/clip_viewshed.hpp"
#include "horizon/gpu/context_pool.hpp"
#include "horizon/visibility/viewshed.hpp"

namespace horizon::clipmap {
namespace {

using testing::ClipWorld;
using testing::kHeight;
using testing::kWidth;
using testing::small_shape;
using visibility::BoxFootprint;

gpu::ContextPool& pool() {
  static auto created = gpu::ContextPool::create({.contexts = 1});
  if (!created.ok()) ADD_FAILURE() << created.error().message;
  return **created;
}

// 3000 boxes of 1-6 cells over the terrain, 0-40 m tall.
std::vector<BoxFootprint> boxes_over(const ClipWorld& world) {
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> cx(0, kWidth - 7), cy(0, kHeight - 7), side(1, 6);
  std::uniform_real_distribution<double> tall(0.0, 40.0);
  const terrain::HeightView z(world.dem.elevation);
  std::vector<BoxFootprint> boxes;
  while (boxes.size() < 3000) {
    BoxFootprint b;
    b.cells = {cx(rng), cy(rng), 0, 0};
    b.cells.col1 = b.cells.col0 + side(rng);
    b.cells.row1 = b.cells.row0 + side(rng);
    float ground = std::numeric_limits<float>::infinity();
    for (int r = b.cells.row0; r < b.cells.row1; ++r)
      for (int c = b.cells.col0; c < b.cells.col1; ++c) ground = std::min(ground, z.at(c, r));
    b.z_min = ground;
    b.z_max = ground + static_cast<float>(tall(rng));
    boxes.push_back(b);
  }
  return boxes;
}

ClipEye eye_at(const ClipWorld& world, double col, double row) {
  return {col, row, world.bilinear(0, col, row) + 15.0, 30.0, 30.0, 0.85714 / (2.0 * 6371000.0)};
}

void expect_same(const ClipCullResult& cpu, const ClipCullResult& gl, const char* what) {
  ASSERT_EQ(cpu.boxes.size(), gl.boxes.size());
  std::size_t differ = 0;
  for (std::size_t i = 0; i < cpu.boxes.size(); ++i)
    differ += cpu.boxes[i].state != gl.boxes[i].state || cpu.boxes[i].ohf_min != gl.boxes[i].ohf_min;
  EXPECT_EQ(differ, 0u) << what << ": boxes whose state or least OHF differ";
  EXPECT_EQ(cpu.visible_count, gl.visible_count) << what;
  EXPECT_EQ(cpu.stats.rays_traced, gl.stats.rays_traced) << what;
  EXPECT_EQ(cpu.stats.rings, gl.stats.rings) << what;
  EXPECT_EQ(cpu.stats.samples, gl.stats.samples) << what;
  EXPECT_EQ(cpu.stats.fallbacks, gl.stats.fallbacks) << what;
  EXPECT_EQ(cpu.stats.box_tests, gl.stats.box_tests) << what;
  EXPECT_FALSE(cpu.stats.gpu);
  EXPECT_TRUE(gl.stats.gpu);
}

// The viewshed reads the same horizons: the same cells.
void expect_same_viewshed(const ClipmapReader& view, const ClipEye& eye, ClipMode mode, gpu::Lease* lease,
                          const char* what) {
  const ClipViewshedOptions options{.mode = mode, .rays = 1024, .radius = 9000.0};
  auto cpu = viewshed_on_clipmap(view, eye, options);
  auto gl = viewshed_on_clipmap(view, eye, options, nullptr, nullptr, lease);
  ASSERT_TRUE(cpu.ok() && gl.ok()) << (cpu.ok() ? gl.error().message : cpu.error().message);
  EXPECT_EQ(cpu->visible_cells, gl->visible_cells) << what;
  EXPECT_EQ(cpu->hidden_cells, gl->hidden_cells) << what;
  EXPECT_TRUE(std::ranges::equal(cpu->mask.values(), gl->mask.values())) << what;
  EXPECT_EQ(cpu->stats.samples, gl->stats.samples) << what;
  EXPECT_EQ(cpu->stats.fallbacks, gl->stats.fallbacks) << what;
  EXPECT_TRUE(gl->stats.gpu);
}

TEST(ClipGl, TheGlTraceCullsAsTheCpuTraceInBothModesWithLevelsLagging) {
  for (const terrain::Reduction reduction : {terrain::Reduction::kMean, terrain::Reduction::kMin}) {
    const ClipMode mode = reduction == terrain::Reduction::kMean ? ClipMode::kFast : ClipMode::kConservative;
    ClipWorld world(small_shape(reduction));
    auto map = world.map(small_shape(reduction));
    const std::vector<BoxFootprint> boxes = boxes_over(world);
    auto lease = pool().borrow();
    ASSERT_TRUE(lease.ok()) << lease.error().message;
    ClipmapUpdater updater = world.updater(map);
    ASSERT_TRUE(updater.update_all({.col = 500.0, .row = 350.0}).ok());
    for (int rays : {256, 1024, 16384}) {  // 16384: two dispatches of 8192 columns
      ClipmapReader view(*map);
      const ClipEye eye = eye_at(world, 500.0, 350.0);
      const ClipCullOptions options{.mode = mode, .rays = rays};
      auto cpu = cull_on_clipmap(view, eye, boxes, options);
      auto gl = cull_on_clipmap(view, eye, boxes, options, nullptr, nullptr, &*lease);
      ASSERT_TRUE(cpu.ok() && gl.ok()) << (cpu.ok() ? gl.error().message : cpu.error().message);
      ASSERT_GT(cpu->boxes.size() - cpu->visible_count, 300u) << "the scene must hide boxes to mean anything";
      expect_same(*cpu, *gl, mode_name(mode));
      if (rays != 1024) continue;
      expect_same_viewshed(view, eye, mode, &*lease, mode_name(mode));
      auto hidden = viewshed_on_clipmap(view, eye, {.mode = mode, .rays = 1024, .radius = 9000.0});
      ASSERT_TRUE(hidden.ok());
      EXPECT_GT(hidden->hidden_cells, 1000u) << "the viewshed must hide cells to mean anything";
    }
    // The finest levels left behind at the far corner: the eye's terrain comes from levels 2 and 3.
    world.lag_finest_levels(map, 300.0, 300.0);
    ClipmapReader view(*map);
    const ClipEye eye = eye_at(world, 300.0, 300.0);
    const ClipCullOptions options{.mode = mode, .rays = 1024};
    auto cpu = cull_on_clipmap(view, eye, boxes, options);
    auto gl = cull_on_clipmap(view, eye, boxes, options, nullptr, nullptr, &*lease);
    ASSERT_TRUE(cpu.ok() && gl.ok());
    ASSERT_GT(cpu->stats.fallbacks, cpu->stats.samples / 4) << "the finest levels are elsewhere";
    expect_same(*cpu, *gl, "lagging levels");

    expect_same_viewshed(view, eye, mode, &*lease, "lagging levels");
  }
}

TEST(ClipGl, OnlyLevelsWhoseVersionChangedAreCopiedToTheContext) {
  ClipWorld world;
  const ClipmapShape shape = small_shape();
  auto map = world.map(shape);
  const std::vector<BoxFootprint> boxes = boxes_over(world);
  auto lease = pool().borrow();
  ASSERT_TRUE(lease.ok());
  ClipmapUpdater updater = world.updater(map);
  ASSERT_TRUE(updater.update_all({.col = 400.0, .row = 300.0}).ok());
  const std::uint64_t n = static_cast<std::uint64_t>(shape.level_size), tiles = n / shape.subtile;
  const std::uint64_t level_bytes = n * n * sizeof(float) + tiles * tiles;
  auto uploaded = [&](const Clipmap& m, double col, double row) {
    ClipmapReader view(m);
    auto got = cull_on_clipmap(view, eye_at(world, col, row), boxes, {.rays = 512}, nullptr, nullptr, &*lease);
    EXPECT_TRUE(got.ok()) << got.error().message;
    return got.ok() ? got->stats.bytes_uploaded : 0;
  };
  EXPECT_EQ(uploaded(*map, 400.0, 300.0), shape.levels * level_bytes) << "first trace: every level";
  EXPECT_EQ(uploaded(*map, 400.0, 300.0), 0u) << "nothing published since";
  // Level 0 follows a move of two sub-tiles, the other levels stay.
  UpdaterOptions finest;
  finest.every = {1, 1000, 1000, 1000};
  ClipmapUpdater one = world.updater(map, finest);
  ASSERT_TRUE(one.update({.col = 400.0, .row = 300.0}).ok());  // every level already in place: nothing published
  EXPECT_EQ(uploaded(*map, 400.0, 300.0), 0u);
  ASSERT_TRUE(one.update({.col = 432.0, .row = 300.0}).ok());
  EXPECT_EQ(uploaded(*map, 432.0, 300.0), level_bytes) << "only level 0 was published";
  // Another clip-map on the same context: all of it.
  auto other = world.map(shape);
  ClipmapUpdater other_updater = world.updater(other);
  ASSERT_TRUE(other_updater.update_all({.col = 400.0, .row = 300.0}).ok());
  EXPECT_EQ(uploaded(*other, 400.0, 300.0), shape.levels * level_bytes);
}

TEST(ClipGl, TheOhfSweepAndTheClipTraceKeepTheirResourcesOnOneContext) {
  ClipWorld world;
  auto map = world.map();
  ClipmapUpdater updater = world.updater(map);
  ASSERT_TRUE(updater.update_all({.col = 500.0, .row = 350.0}).ok());
  const std::vector<BoxFootprint> boxes = boxes_over(world);
  geodesy::GridPoint eye;
  eye.col = 500.0;
  eye.row = 350.0;
  eye.x = world.dem.georef.transform.x_at(eye.col);
  eye.y = world.dem.georef.transform.y_at(eye.row);
  eye.elevation = world.bilinear(0, 500.0, 350.0) + 15.0;
  visibility::ViewshedOptions vo;
  vo.backend = visibility::Backend::kGpu;
  vo.max_distance = 6000.0;
  auto sweep = [&] {
    auto r = visibility::compute_viewshed(world.dem, eye, vo, nullptr, &pool());  // borrows the one context
    EXPECT_TRUE(r.ok()) << r.error().message;
    if (r.ok()) {
      EXPECT_EQ(r->stats.backend, "gpu") << r->stats.gpu_fallback;
    }
    return r.ok() ? std::vector<float>(r->ohf.values().begin(), r->ohf.values().end()) : std::vector<float>{};
  };
  auto trace = [&] {
    auto lease = pool().borrow();
    EXPECT_TRUE(lease.ok());
    ClipmapReader view(*map);
    auto got = cull_on_clipmap(view, eye_at(world, 500.0, 350.0), boxes, {.rays = 512}, nullptr, nullptr, &*lease);
    EXPECT_TRUE(got.ok()) << got.error().message;
    EXPECT_EQ(lease->resource_kinds(), 2u) << "both algorithms' resources on the context";
    return got.ok() ? got->stats.bytes_uploaded : 0;
  };
  const std::vector<float> first = sweep();
  EXPECT_GT(trace(), 0u) << "the clip-map's first trace on this context copies its levels";
  const std::vector<float> second = sweep();
  EXPECT_EQ(trace(), 0u) << "the sweep between did not take the trace's copy away";
  ASSERT_FALSE(first.empty());
  EXPECT_TRUE(std::ranges::equal(first, second, [](float a, float b) { return a == b || (a != a && b != b); }));
}

}  // namespace
}  // namespace horizon::clipmap
