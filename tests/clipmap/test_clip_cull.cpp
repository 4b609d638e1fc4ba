// Culling over a clip-map against R3 on the full-resolution terrain: the
// conservative mode never reports hidden a box R3 sees, with the levels
// complete and with the finest level left behind (fallbacks); the fast mode
// agrees with R3 on most boxes; only the rays the boxes need are traced;
// ring edges follow the level-selection rule and the plan finds a
// distance's ring as a binary search would; the CPU's fused trace and box
// tests answer as the whole table of horizons does.
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "clipmap/clip_trace.hpp"
#include "clipmap_world.hpp"
#include "horizon/clipmap/clip_cull.hpp"
#include "horizon/visibility/r3.hpp"
#include "horizon/visibility/view_frame.hpp"
#include "horizon/visibility/viewshed.hpp"

namespace horizon::clipmap {
namespace {

using testing::ClipWorld;
using testing::kHeight;
using testing::kWidth;
using testing::small_shape;
using visibility::BoxFootprint;
using visibility::Visibility;

struct Scene {
  visibility::ViewFrame frame;
  ClipEye eye;
  std::vector<BoxFootprint> boxes;
  std::vector<bool> r3_visible;
  std::size_t r3_hidden = 0;
};

// 1500 boxes of 1-4 cells scattered over the terrain, 0-40 m tall on the
// ground, seen from 12 m above (col, row); R3's answer for each.
Scene make_scene(const ClipWorld& world, double col, double row) {
  Scene s;
  const terrain::HeightView z(world.dem.elevation);
  const double ground = world.bilinear(0, col, row);
  visibility::ViewshedOptions options;
  options.max_distance = std::numeric_limits<double>::infinity();
  geodesy::GridPoint observer;
  observer.col = col;
  observer.row = row;
  observer.elevation = ground + 12.0;
  observer.x = world.dem.georef.transform.origin_x + (col + 0.5) * 30.0;
  observer.y = world.dem.georef.transform.origin_y - (row + 0.5) * 30.0;
  auto frame = visibility::make_view_frame(world.dem, observer, options);
  EXPECT_TRUE(frame.ok()) << frame.error().message;
  s.frame = *frame;
  s.eye = {col, row, observer.elevation, s.frame.metres_per_col, s.frame.metres_per_row, s.frame.curvature};
  std::mt19937 rng(21);
  std::uniform_int_distribution<int> cx(0, kWidth - 5), cy(0, kHeight - 5), side(1, 4);
  std::uniform_real_distribution<double> tall(0.0, 40.0);
  while (s.boxes.size() < 1500) {
    BoxFootprint b;
    b.cells.col0 = cx(rng);
    b.cells.row0 = cy(rng);
    b.cells.col1 = b.cells.col0 + side(rng);
    b.cells.row1 = b.cells.row0 + side(rng);
    if (b.cells.contains(static_cast<int>(std::lround(col)), static_cast<int>(std::lround(row)))) continue;
    float least_ground = std::numeric_limits<float>::infinity(), least_ohf = least_ground;
    for (int r = b.cells.row0; r < b.cells.row1; ++r)
      for (int c = b.cells.col0; c < b.cells.col1; ++c) {
        least_ground = std::min(least_ground, z.at(c, r));
        least_ohf = std::min(least_ohf, visibility::r3_ohf_at(z, s.frame, c, r));
      }
    b.z_min = least_ground;
    b.z_max = least_ground + tall(rng);
    s.boxes.push_back(b);
    const bool seen = b.z_max + visibility::kTieTolerance >= least_ohf;
    s.r3_visible.push_back(seen);
    s.r3_hidden += !seen;
  }
  return s;
}

struct Agreement {
  std::size_t false_hidden = 0, false_visible = 0, hidden = 0;
};
Agreement compare(const Scene& s, const ClipCullResult& got) {
  Agreement a;
  for (std::size_t i = 0; i < s.boxes.size(); ++i) {
    const bool seen = got.boxes[i].state == Visibility::kSeen;
    a.hidden += !seen;
    a.false_hidden += s.r3_visible[i] && !seen;
    a.false_visible += !s.r3_visible[i] && seen;
  }
  return a;
}

TEST(ClipCull, RingEdgesWidenWithTheLateralSpacingOfTheRays) {
  // 1024 rays: neighbouring rays are one 30 m cell apart at 30 / (2π / 1024) = 4889 m.
  ClipmapShape shape;
  shape.levels = 4;
  shape.level_size = 1024;  // level 0 reaches 448 cells: the rays' spacing decides
  shape.subtile = 64;
  const std::vector<double> edges = ring_edges(40000.0, 30.0, 1024, shape);
  ASSERT_GE(edges.back(), 40000.0);
  const double one_cell = 30.0 * 1024 / (2 * std::numbers::pi);
  for (std::size_t j = 0; j + 1 < edges.size(); ++j) {
    const double width = edges[j + 1] - edges[j];
    const double rho = std::max(edges[j] / one_cell, 1.0);
    const double want = 30.0 * std::min(std::exp2(std::floor(std::log2(rho))), 8.0);
    ASSERT_DOUBLE_EQ(width, want) << "ring " << j << " at " << edges[j] << " m";
  }
  EXPECT_DOUBLE_EQ(edges[1] - edges[0], 30.0);
  EXPECT_DOUBLE_EQ(edges.back() - edges[edges.size() - 2], 240.0);  // level 3, the coarsest
}

TEST(ClipCull, ConservativeNeverReportsHiddenABoxR3SeesEvenWhenLevelsLag) {
  ClipWorld world(small_shape(terrain::Reduction::kMin));
  auto map = world.map(small_shape(terrain::Reduction::kMin));
  ClipmapUpdater updater = world.updater(map);
  for (const auto& [col, row] : {std::pair{500.0, 350.0}, std::pair{130.0, 610.0}}) {
    const Scene scene = make_scene(world, col, row);
    ASSERT_GT(scene.r3_hidden, 200u) << "the scene must hide boxes to mean anything";
    ASSERT_TRUE(updater.update_all({.col = col, .row = row}).ok());
    for (int rays : {256, 2048}) {
      ClipmapReader view(*map);
      auto got = cull_on_clipmap(view, scene.eye, scene.boxes, {.mode = ClipMode::kConservative, .rays = rays});
      ASSERT_TRUE(got.ok()) << got.error().message;
      const Agreement a = compare(scene, *got);
      EXPECT_EQ(a.false_hidden, 0u) << "eye (" << col << ", " << row << "), " << rays << " rays";
      // Sound and still useful: most of what R3 hides is found hidden.
      EXPECT_GT(a.hidden, scene.r3_hidden / 2) << rays << " rays: " << a.hidden << " of " << scene.r3_hidden;
    }
  }
  // Levels 0 and 1 left at the far corner: the eye's surroundings come from level 2 or 3.
  world.lag_finest_levels(map, 300.0, 300.0);
  const Scene scene = make_scene(world, 300.0, 300.0);
  ClipmapReader view(*map);
  auto got = cull_on_clipmap(view, scene.eye, scene.boxes, {.mode = ClipMode::kConservative, .rays = 1024});
  ASSERT_TRUE(got.ok()) << got.error().message;
  EXPECT_GT(got->stats.fallbacks, got->stats.samples / 4) << "the finest levels are elsewhere";
  const Agreement a = compare(scene, *got);
  EXPECT_EQ(a.false_hidden, 0u);
  EXPECT_GT(a.hidden, 0u);
}

TEST(ClipCull, FastAgreesWithR3OnMostBoxes) {
  ClipWorld world;
  auto map = world.map();
  ClipmapUpdater updater = world.updater(map);
  const Scene scene = make_scene(world, 500.0, 350.0);
  ASSERT_TRUE(updater.update_all({.col = 500.0, .row = 350.0}).ok());
  ClipmapReader view(*map);
  auto got = cull_on_clipmap(view, scene.eye, scene.boxes, {.mode = ClipMode::kFast, .rays = 2048, .threads = 2});
  ASSERT_TRUE(got.ok()) << got.error().message;
  const Agreement a = compare(scene, *got);
  const double wrong = double(a.false_hidden + a.false_visible) / double(scene.boxes.size());
  EXPECT_LT(wrong, 0.08) << a.false_hidden << " false hidden, " << a.false_visible << " false visible";
  EXPECT_EQ(got->stats.fallbacks, 0u) << "every level is complete around the eye";
}

TEST(ClipCull, OnlyTheRaysTheBoxesNeedAreTracedAndOnlyAsFarAsThem) {
  ClipWorld world;
  auto map = world.map();
  ClipmapUpdater updater = world.updater(map);
  ASSERT_TRUE(updater.update_all({.col = 500.0, .row = 350.0}).ok());
  ClipEye eye{500.0, 350.0, 900.0, 30.0, 30.0, 0.0};
  // One box 100 cells due east: 3 km out, a cell wide.
  BoxFootprint east;
  east.cells = {600, 350, 601, 351};
  east.z_min = 0.0;
  east.z_max = 1000.0;
  ClipmapReader view(*map);
  auto got = cull_on_clipmap(view, eye, std::vector<BoxFootprint>{east}, {.mode = ClipMode::kFast, .rays = 1024});
  ASSERT_TRUE(got.ok()) << got.error().message;
  EXPECT_LE(got->stats.rays_traced, 2u);
  const std::size_t rings = ring_edges(3000.0, 30.0, 1024, small_shape()).size();
  EXPECT_LE(got->stats.rings, 2 * rings);
  EXPECT_EQ(got->boxes[0].state, Visibility::kSeen) << "1000 m is above this terrain";
  // Wrong reductions and ray counts are refused naming the field.
  auto wrong = cull_on_clipmap(view, eye, std::vector<BoxFootprint>{east}, {.mode = ClipMode::kConservative});
  ASSERT_FALSE(wrong.ok());
  EXPECT_EQ(wrong.error().field, "mode");
  auto rays = cull_on_clipmap(view, eye, std::vector<BoxFootprint>{east}, {.rays = 10});
  ASSERT_FALSE(rays.ok());
  EXPECT_EQ(rays.error().field, "rays");
  // The box tests are counted before any tracing: a box over the west of
  // the terrain spans about half the rays and most rings; past the limit
  // the call is refused.
  BoxFootprint everything;
  everything.cells = {0, 0, 400, kHeight};
  everything.z_min = 0.0;
  everything.z_max = 1.0;
  ClipCullOptions bounded;
  bounded.rays = 1024;
  bounded.max_box_tests = 10000;
  auto refused = cull_on_clipmap(view, eye, std::vector<BoxFootprint>{everything}, bounded);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().code, ErrorCode::kResourceExhausted);
  EXPECT_EQ(refused.error().field, "boxes");
  auto small = cull_on_clipmap(view, eye, std::vector<BoxFootprint>{east}, bounded);
  ASSERT_TRUE(small.ok()) << small.error().message;
  EXPECT_LE(small->stats.box_tests, 10000u);
}

}  // namespace
}  // namespace horizon::clipmap

namespace horizon::clipmap {
namespace {

TEST(ClipCull, ThePlansAnglesAreAtan2sWithinTheirStatedError) {
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> unit(-1.0, 1.0), decade(-3.0, 5.0);
  double worst = 0.0;
  auto check = [&](double y, double x) {
    double e = std::fabs(detail::angle_of(y, x) - std::atan2(y, x));
    if (e > std::numbers::pi) e = std::fabs(e - 2 * std::numbers::pi);  // ±π for y = -0
    worst = std::max(worst, e);
  };
  for (int i = 0; i < 200000; ++i)
    check(unit(rng) * std::pow(10.0, decade(rng)), unit(rng) * std::pow(10.0, decade(rng)));
  for (int i = 0; i <= 20000; ++i) {  // both sides of each reduction's seam, on every octant
    const double t = i / 20000.0;
    for (const auto& [y, x] : {std::pair{t, 1.0}, {1.0, t}, {t, -1.0}, {-t, -1.0}, {-1.0, t}, {-t, 1.0}}) check(y, x);
  }
  for (const auto& [y, x] : {std::pair{0.0, 1.0}, {0.0, -1.0}, {1.0, 0.0}, {-1.0, 0.0}, {1e-300, 1.0}, {1.0, 1.0}})
    check(y, x);
  EXPECT_LE(worst, detail::kAngleError);
  EXPECT_GT(worst, 0.0) << "a series, not atan2 itself";
}

TEST(ClipCull, ThePlanFindsADistancesRingAsABinarySearchWould) {
  ClipWorld world;
  ClipmapShape shape = small_shape();
  std::mt19937 rng(3);
  for (const double reach : {40.0, 9000.0, 400000.0}) {  // 400 km: wider buckets than a cell
    ClipCullScratch w;
    const ClipEye eye{500.0, 350.0, 900.0, 30.0, 30.0, 0.0};
    const detail::TracePlan plan = detail::plan_reach(eye, {.rays = 512}, shape, reach, w);
    const auto& edges = plan.edges;
    std::vector<double> probes{-1.0, 0.0, edges.back() + 1.0, 2.0 * edges.back()};
    for (double e : edges) probes.insert(probes.end(), {e, std::nextafter(e, 0.0), std::nextafter(e, 1e300)});
    std::uniform_real_distribution<double> any(0.0, edges.back() * 1.01);
    for (int i = 0; i < 5000; ++i) probes.push_back(any(rng));
    for (double d : probes) {
      ASSERT_EQ(plan.edges_upto(d), std::size_t(std::upper_bound(edges.begin(), edges.end(), d) - edges.begin()))
          << d << " m, reach " << reach;
      ASSERT_EQ(plan.edges_below(d), std::size_t(std::lower_bound(edges.begin(), edges.end(), d) - edges.begin()))
          << d << " m, reach " << reach;
    }
  }
}

// The table path (what the GL trace feeds): every column traced into the
// whole rings x rays table, then every box tested against it.
ClipCullResult by_table(const ClipmapReader& view, const ClipEye& eye, const std::vector<BoxFootprint>& boxes,
                        const ClipCullOptions& options) {
  ClipCullScratch w;
  auto plan = detail::plan_trace(eye, boxes, options, view.map().shape(), w);
  EXPECT_TRUE(plan.ok());
  detail::prepare_horizons(*plan, w);
  ClipCullResult result;
  EXPECT_TRUE(detail::trace_cpu(*plan, view, eye, options, nullptr, w).ok());
  EXPECT_TRUE(detail::test_boxes(*plan, eye, boxes, options, nullptr, w, result).ok());
  return result;
}

TEST(ClipCull, TheFusedTraceAndTestsAnswerAsTheWholeTableOfHorizons) {
  for (const terrain::Reduction reduction : {terrain::Reduction::kMean, terrain::Reduction::kMin}) {
    const ClipMode mode = reduction == terrain::Reduction::kMean ? ClipMode::kFast : ClipMode::kConservative;
    ClipWorld world(small_shape(reduction));
    auto map = world.map(small_shape(reduction));
    ClipmapUpdater updater = world.updater(map);
    ASSERT_TRUE(updater.update_all({.col = 500.0, .row = 350.0}).ok());
    Scene scene = make_scene(world, 500.0, 350.0);
    // Boxes over the seams: one holding the eye, one across azimuth 0
    // (its columns wrap through column 0), one over many blocks of columns.
    BoxFootprint eye_box{{495, 345, 505, 355}, 0.0, 2000.0}, across_zero{{540, 340, 560, 361}, 0.0, 1300.0},
        wide{{100, 600, 900, 640}, 0.0, 1200.0};
    scene.boxes.insert(scene.boxes.end(), {eye_box, across_zero, wide});
    for (int rays : {64, 100, 1000, 2048}) {  // 100 and 1000: a last block shorter than the rest
      for (unsigned threads : {1u, 2u}) {
        ClipmapReader view(*map);
        const ClipCullOptions options{.mode = mode, .rays = rays, .threads = threads};
        auto fused = cull_on_clipmap(view, scene.eye, scene.boxes, options);
        ASSERT_TRUE(fused.ok()) << fused.error().message;
        const ClipCullResult table = by_table(view, scene.eye, scene.boxes, options);
        std::size_t differ = 0;
        for (std::size_t i = 0; i < scene.boxes.size(); ++i)
          differ += fused->boxes[i].state != table.boxes[i].state ||
                    std::bit_cast<std::uint32_t>(fused->boxes[i].ohf_min) !=
                        std::bit_cast<std::uint32_t>(table.boxes[i].ohf_min);
        EXPECT_EQ(differ, 0u) << rays << " rays, " << threads << " threads";
        EXPECT_EQ(fused->visible_count, table.visible_count);
        EXPECT_GT(scene.boxes.size() - fused->visible_count, 200u) << "the scene must hide boxes to mean anything";
        EXPECT_EQ(fused->stats.rays_traced, table.stats.rays_traced);
        EXPECT_EQ(fused->stats.rings, table.stats.rings);
        EXPECT_EQ(fused->stats.samples, table.stats.samples);
        EXPECT_EQ(fused->stats.box_tests, table.stats.box_tests);
        const std::size_t n = scene.boxes.size();
        EXPECT_EQ(fused->boxes[n - 3].state, Visibility::kSeen) << "a hull holding the eye is visible";
        EXPECT_EQ(fused->boxes[n - 3].ohf_min, -std::numeric_limits<float>::infinity());
      }
    }
    // One wide box alone is more pieces than a box may have: the table path, the same answer.
    const std::vector<BoxFootprint> alone{wide};
    ClipmapReader view(*map);
    const ClipCullOptions options{.mode = mode, .rays = 2048};
    auto fused = cull_on_clipmap(view, scene.eye, alone, options);
    ASSERT_TRUE(fused.ok());
    const ClipCullResult table = by_table(view, scene.eye, alone, options);
    EXPECT_EQ(fused->boxes[0].ohf_min, table.boxes[0].ohf_min);
    EXPECT_EQ(fused->stats.box_tests, table.stats.box_tests);
    EXPECT_GT(fused->stats.rays_traced, 32u * detail::kPiecesPerBox) << "the box must meet more blocks than that";
  }
}

}  // namespace
}  // namespace horizon::clipmap
