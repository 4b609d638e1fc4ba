// The GL form of the fast algorithm (visibility/radial_sweep_gl.hpp) on whatever EGL device
// this machine has: Mesa llvmpipe in CI, so the GPU code runs in every test
// run. Each GPU result is held against the CPU sweep at the same knobs and,
// on the bundled DEMs, against R3 with the bar of issue #2.
#include <gtest/gtest.h>

#include <algorithm>
#include <barrier>
#include <cmath>
#include <mutex>
#include <thread>
#include <utility>
#include <vector>

#include "horizon/gpu/context_pool.hpp"
#include "horizon/terrain/dem_reader.hpp"
#include "horizon/visibility/agreement.hpp"
#include "horizon/visibility/backend_policy.hpp"
#include "horizon/visibility/radial_sweep_gl.hpp"
#include "horizon/visibility/viewshed.hpp"
#include "observer_picks.hpp"
#include "test_support.hpp"

namespace horizon {
namespace {

using visibility::Backend;
using visibility::ViewshedOptions;
using visibility::ViewshedResult;

// One pool for the whole binary (display init is the slow part).
gpu::ContextPool& pool() {
  static auto created = gpu::ContextPool::create({.contexts = 8});
  if (!created.ok()) ADD_FAILURE() << created.error().message;
  return **created;
}

geodesy::GridPoint eye_at(const terrain::Dem& dem, double col, double row, double height = 2.0) {
  geodesy::PointSpec spec;
  spec.x = dem.georef.transform.x_at(col);
  spec.y = dem.georef.transform.y_at(row);
  spec.height = height;
  auto eye = geodesy::resolve_point(dem, spec, "observer");
  EXPECT_TRUE(eye.ok()) << eye.error().message;
  return *eye;
}

ViewshedResult run(const terrain::Dem& dem, const geodesy::GridPoint& eye, ViewshedOptions o, Backend backend) {
  o.backend = backend;
  auto r = visibility::compute_viewshed(dem, eye, o, nullptr, &pool());
  EXPECT_TRUE(r.ok()) << r.error().message;
  return std::move(*r);
}

// How far a GPU OHF is from the CPU one: both answer the same cells; the OHF
// agrees within 1 cm on at least 99.9 % of them; the viewshed IoU >= 99.9 %.
struct GpuVsCpu {
  std::uint64_t cells = 0, within_1cm = 0, answer_mismatch = 0;
  double max_error = 0.0, iou = 1.0;
};

GpuVsCpu compare(const ViewshedResult& gpu_result, const ViewshedResult& cpu_result, double target_height) {
  GpuVsCpu out;
  const auto g = gpu_result.ohf.values(), c = cpu_result.ohf.values();
  for (std::size_t i = 0; i < g.size(); ++i) {
    if (std::isnan(g[i]) != std::isnan(c[i])) {
      ++out.answer_mismatch;
      continue;
    }
    if (std::isnan(g[i])) continue;
    ++out.cells;
    const float floor_z = gpu_result.terrain.values()[i];
    const double e = (std::isinf(g[i]) || std::isinf(c[i]))
                         ? (g[i] == c[i] ? 0.0 : std::abs(std::max(g[i], floor_z) - std::max(c[i], floor_z)))
                         : std::abs(double(g[i]) - double(c[i]));
    if (e <= 0.01) ++out.within_1cm;
    out.max_error = std::max(out.max_error, e);
  }
  out.iou = visibility::compare_viewsheds(gpu_result, cpu_result, target_height).iou;
  return out;
}

void expect_agreement(const GpuVsCpu& a, const std::string& what) {
  EXPECT_EQ(a.answer_mismatch, 0u) << what;
  ASSERT_GT(a.cells, 0u) << what;
  EXPECT_GE(double(a.within_1cm) / double(a.cells), 0.999) << what << ": max error " << a.max_error << " m";
  EXPECT_GE(a.iou, 0.999) << what;
}

TEST(GpuPool, OpensAHeadlessDisplayAndReportsTheDevice) {
  const gpu::DeviceInfo& d = pool().device();
  EXPECT_FALSE(d.renderer.empty());
  EXPECT_TRUE(d.platform == "device" || d.platform == "surfaceless") << d.platform;
  EXPECT_GE(d.max_texture_size, 4096);
  EXPECT_EQ(pool().size(), 8);
  // auto never picks a software rasteriser: the CPU sweep is faster there.
  if (d.software) {
    EXPECT_FALSE(visibility::BackendPolicy().prefers_gpu(d, 1ull << 40));
  }
}

// Both headless platforms: the device one (the default) and Mesa's
// surfaceless fallback, each computing the same OHF as the CPU.
TEST(GpuPool, BothHeadlessPlatformsWork) {
  const auto dem = testing::make_random_terrain(80, 70, 8, 150.0);
  const auto eye = eye_at(dem, 40.4, 30.7);
  const auto c = run(dem, eye, {}, Backend::kCpu);
  for (auto [platform, name] :
       {std::pair{gpu::EglPlatform::kDevice, "device"}, std::pair{gpu::EglPlatform::kSurfaceless, "surfaceless"}}) {
    auto p = gpu::ContextPool::create({.contexts = 1, .platform = platform});
    if (!p.ok()) {
      ADD_FAILURE() << name << ": " << p.error().message;
      continue;
    }
    EXPECT_EQ((*p)->device().platform, name);
    ViewshedOptions o;
    o.backend = Backend::kGpu;
    auto g = visibility::compute_viewshed(dem, eye, o, nullptr, p->get());
    ASSERT_TRUE(g.ok());
    EXPECT_EQ(g->stats.backend, "gpu") << name << ": " << g->stats.gpu_fallback;
    expect_agreement(compare(*g, c, 0.0), name);
  }
}

TEST(GpuPool, RejectsABadContextCount) {
  auto p = gpu::ContextPool::create({.contexts = 0});
  ASSERT_FALSE(p.ok());
  EXPECT_EQ(p.error().field, "gpu.contexts");
}

// Every method and blend on rough synthetic terrain with an off-centre,
// off-grid eye, curvature on, against the CPU at the same knobs.
TEST(GpuOhf, AgreesWithTheCpuSweepForEveryMethodAndBlend) {
  const auto dem = testing::make_random_terrain(181, 157, 7, 300.0);
  const auto eye = eye_at(dem, 61.3, 97.7, 5.0);
  for (auto blend : {visibility::RayBlend::kResample, visibility::RayBlend::kLinear, visibility::RayBlend::kMin})
    for (auto method : {visibility::GpuMethod::kFragment, visibility::GpuMethod::kCompute})
      for (bool log_step : {true, false}) {
        ViewshedOptions o;
        o.radial.blend = blend;
        o.gpu = visibility::GpuOptions{method, log_step};
        const auto g = run(dem, eye, o, Backend::kGpu);
        const auto c = run(dem, eye, o, Backend::kCpu);
        EXPECT_EQ(g.stats.backend, "gpu") << g.stats.gpu_fallback;
        EXPECT_EQ(c.stats.backend, "cpu");
        EXPECT_EQ(g.stats.cells_evaluated, c.stats.cells_evaluated);
        expect_agreement(compare(g, c, 0.0), std::string(visibility::gpu_method_name(method)) +
                                                 (log_step ? " log-step" : " one-step") + " blend " +
                                                 std::to_string(static_cast<int>(blend)));
      }
}

// Max distance, a target height, an eye exactly on a cell centre, ray
// spacing 0.5, and the 8 km precision case (the eye-relative split).
TEST(GpuOhf, AgreesWithTheCpuSweepOnEdgeCases) {
  struct Case {
    const char* name;
    double base, col, row, height, max_distance, target, spacing;
  };
  const Case cases[] = {{"max distance", 0.0, 80.4, 70.2, 2.0, 1500.0, 0.0, 1.0},
                        {"cell centre eye", 0.0, 40.0, 40.0, 2.0, INFINITY, 1.5, 1.0},
                        {"spacing 0.5", 0.0, 100.5, 10.5, 2.0, INFINITY, 0.0, 0.5},
                        {"at 8 km", 8000.0, 90.7, 77.1, 1.7, INFINITY, 0.0, 1.0},
                        {"corner eye", 0.0, 0.2, 0.3, 10.0, INFINITY, 0.0, 1.0}};
  for (const Case& k : cases) {
    auto dem = testing::make_random_terrain(160, 140, 11, 250.0);
    for (float& v : dem.elevation.values()) v += static_cast<float>(k.base);
    const auto eye = eye_at(dem, k.col, k.row, k.height);
    ViewshedOptions o;
    o.max_distance = k.max_distance;
    o.target_height = k.target;
    o.radial.ray_spacing = k.spacing;
    const auto g = run(dem, eye, o, Backend::kGpu);
    const auto c = run(dem, eye, o, Backend::kCpu);
    EXPECT_EQ(g.stats.backend, "gpu") << k.name << ": " << g.stats.gpu_fallback;
    expect_agreement(compare(g, c, k.target), k.name);
  }
}

// Voids are transparent and unanswered on both paths (the Everest crop has SRTM voids).
TEST(GpuOhf, TreatsVoidsAsTheCpuDoes) {
  auto dem = terrain::read_dem(testing::bundled_dem("everest_summit_voids_srtm3_300x300.tif"));
  ASSERT_TRUE(dem.ok()) << dem.error().message;
  std::size_t voids = 0;
  for (float v : dem->elevation.values()) voids += std::isnan(v);
  ASSERT_GT(voids, 0u);
  for (const auto& pick : accuracy::pick_observers(*dem)) {
    const auto eye = eye_at(*dem, pick.col, pick.row);
    const auto g = run(*dem, eye, {}, Backend::kGpu);
    const auto c = run(*dem, eye, {}, Backend::kCpu);
    expect_agreement(compare(g, c, 0.0), pick.kind);
  }
}

// The accuracy bar of the CPU path, held by the GPU path against R3 on every
// bundled DEM (pooled over the four observers, as test_accuracy_bundled).
TEST(GpuOhf, MeetsTheAccuracyBarAgainstR3OnTheBundledDems) {
  for (const char* name :
       {"ecuador_andes_utm17s_10m_383x415.tif", "everest_summit_voids_srtm3_300x300.tif",
        "olinda_coast_utm25s_111x111.tif", "rainier_summit_srtm3_400x400.tif", "zion_canyon_srtm3_465x457.tif"}) {
    auto dem = terrain::read_dem(testing::bundled_dem(name));
    ASSERT_TRUE(dem.ok()) << dem.error().message;
    std::uint64_t both = 0, missed = 0, extra = 0, ref_visible = 0;
    for (const auto& pick : accuracy::pick_observers(*dem)) {
      const auto eye = eye_at(*dem, pick.col, pick.row);
      ViewshedOptions o;
      o.algorithm = visibility::Algorithm::kR3;
      const auto exact = run(*dem, eye, o, Backend::kCpu);
      o.algorithm = visibility::Algorithm::kRadial;
      const auto g = run(*dem, eye, o, Backend::kGpu);
      ASSERT_EQ(g.stats.backend, "gpu");
      const auto a = visibility::compare_viewsheds(g, exact, 0.0);
      both += a.both_visible;
      missed += a.missed_visible;
      extra += a.extra_visible;
      ref_visible += a.reference_visible;
    }
    ASSERT_GT(ref_visible, 0u);
    EXPECT_GE(double(both) / double(both + missed + extra), 0.99) << name;
    EXPECT_LE(double(missed) / double(ref_visible), 0.005) << name;
  }
}

// 8 requests at once on 8 contexts, each with its own observer, each equal
// to its own CPU result: no state leaks between contexts.
TEST(GpuOhf, ParallelRequestsOnDifferentContextsDoNotCrossTalk) {
  const auto dem = testing::make_random_terrain(150, 150, 3, 200.0);
  std::vector<geodesy::GridPoint> eyes;
  for (int i = 0; i < 8; ++i) eyes.push_back(eye_at(dem, 10.5 + 16.0 * i, 140.2 - 15.0 * i, 1.0 + i));
  std::vector<ViewshedResult> gpu_results(8), cpu_results(8);
  for (int i = 0; i < 8; ++i) cpu_results[i] = run(dem, eyes[i], {}, Backend::kCpu);
  std::vector<std::thread> threads;
  for (int i = 0; i < 8; ++i)
    threads.emplace_back([&, i] {
      ViewshedOptions o;
      o.gpu = visibility::GpuOptions{i % 2 ? visibility::GpuMethod::kCompute : visibility::GpuMethod::kFragment, true};
      for (int repeat = 0; repeat < 3; ++repeat) gpu_results[i] = run(dem, eyes[i], o, Backend::kGpu);
    });
  for (auto& t : threads) t.join();
  for (int i = 0; i < 8; ++i) {
    EXPECT_EQ(gpu_results[i].stats.backend, "gpu") << i;
    expect_agreement(compare(gpu_results[i], cpu_results[i], 0.0), "request " + std::to_string(i));
  }
}

// A request past the device's texture limit is answered by the CPU, and says so.
TEST(GpuOhf, FallsBackToTheCpuPastTheDeviceLimits) {
  const int limit = pool().device().max_texture_size;
  // A strip as long as the limit, eye at one end: its ray disk needs more
  // rows than the limit allows at ray spacing 0.5.
  const auto dem = testing::make_random_terrain(limit + 8, 3, 5, 50.0);
  const auto eye = eye_at(dem, 0.0, 1.0);
  ViewshedOptions o;
  o.radial.ray_spacing = 0.5;
  const auto g = run(dem, eye, o, Backend::kGpu);
  EXPECT_EQ(g.stats.backend, "cpu");
  EXPECT_NE(g.stats.gpu_fallback.find("limit"), std::string::npos) << g.stats.gpu_fallback;
  const auto c = run(dem, eye, o, Backend::kCpu);
  const auto a = compare(g, c, 0.0);
  EXPECT_EQ(a.max_error, 0.0);
  EXPECT_EQ(a.answer_mismatch, 0u);
}

// A context that failed is destroyed and replaced; the next request on it is right.
TEST(GpuOhf, AFailedContextIsReplacedAndTheNextRequestSucceeds) {
  auto small = gpu::ContextPool::create({.contexts = 1});
  ASSERT_TRUE(small.ok()) << small.error().message;
  const auto dem = testing::make_random_terrain(90, 80, 9, 150.0);
  const auto eye = eye_at(dem, 30.2, 40.6);
  const auto c = run(dem, eye, {}, Backend::kCpu);
  {
    auto lease = (*small)->borrow();
    ASSERT_TRUE(lease.ok());
    lease->fail();
  }
  EXPECT_EQ((*small)->counters().failures, 1u);
  ViewshedOptions o;
  o.backend = Backend::kGpu;
  auto g = visibility::compute_viewshed(dem, eye, o, nullptr, small->get());
  ASSERT_TRUE(g.ok());
  EXPECT_EQ(g->stats.backend, "gpu");
  EXPECT_EQ((*small)->counters().replaced, 1u);
  expect_agreement(compare(*g, c, 0.0), "after replacement");
}

// prepare_radial_gl builds the programs on every context before any request.
TEST(GpuPool, PrepareBuildsEveryContext) {
  auto p = gpu::ContextPool::create({.contexts = 3});
  ASSERT_TRUE(p.ok()) << p.error().message;
  ASSERT_TRUE(visibility::prepare_radial_gl(**p).ok());
  // Hold all three at once: each already has its resources.
  std::vector<std::thread> threads;
  std::mutex m;
  std::barrier all(3);
  int prepared = 0;
  for (int i = 0; i < 3; ++i)
    threads.emplace_back([&] {
      auto lease = (*p)->borrow();
      {
        std::lock_guard lock(m);
        prepared += lease.ok() && lease->resource_kinds() == 1;
      }
      all.arrive_and_wait();
    });
  for (auto& t : threads) t.join();
  EXPECT_EQ(prepared, 3);
}

// Pools share the process's EGL display: closing one leaves the others working.
TEST(GpuPool, ClosingOnePoolLeavesAnotherWorking) {
  auto first = gpu::ContextPool::create({.contexts = 1});
  ASSERT_TRUE(first.ok()) << first.error().message;
  {
    auto second = gpu::ContextPool::create({.contexts = 2});
    ASSERT_TRUE(second.ok()) << second.error().message;
  }
  const auto dem = testing::make_random_terrain(70, 60, 4, 120.0);
  const auto eye = eye_at(dem, 20.5, 33.2);
  ViewshedOptions o;
  o.backend = Backend::kGpu;
  auto g = visibility::compute_viewshed(dem, eye, o, nullptr, first->get());
  ASSERT_TRUE(g.ok());
  EXPECT_EQ(g->stats.backend, "gpu") << g->stats.gpu_fallback;
  expect_agreement(compare(*g, run(dem, eye, {}, Backend::kCpu), 0.0), "after the other pool closed");
}

TEST(GpuBackend, AutoUsesTheCpuOnASoftwareRasteriser) {
  if (!pool().device().software) GTEST_SKIP() << "hardware GPU: " << pool().device().renderer;
  const auto dem = testing::make_random_terrain(64, 64, 1);
  const auto r = run(dem, eye_at(dem, 20.5, 30.5), {}, Backend::kAuto);
  EXPECT_EQ(r.stats.backend, "cpu");
  EXPECT_TRUE(r.stats.gpu_fallback.empty());
}

// The crossover is the smallest timed size from which the GPU stayed faster.
TEST(GpuCalibration, SetsTheCrossoverFromTheTimings) {
  auto own = gpu::ContextPool::create({.contexts = 1});
  ASSERT_TRUE(own.ok()) << own.error().message;
  visibility::BackendPolicy policy;
  auto c = visibility::calibrate(**own, policy, {.threads = 0, .max_side = 256, .time_software = true});
  ASSERT_TRUE(c.ok()) << c.error().message;
  ASSERT_EQ(c->points.size(), 2u);
  EXPECT_EQ(c->points[0].cells, 128u * 128u);
  EXPECT_EQ(c->points[1].cells, 256u * 256u);
  std::uint64_t expected = UINT64_MAX;
  for (auto it = c->points.rbegin(); it != c->points.rend() && it->gpu_seconds < it->cpu_seconds; ++it)
    expected = it->cells;
  for (const auto& p : c->points) EXPECT_GT(p.cpu_seconds * p.gpu_seconds, 0.0);
  EXPECT_EQ(c->crossover_cells, expected);
  EXPECT_EQ(policy.crossover_cells(), expected);
  // Every variant timed at the largest size; the fastest is the policy's default.
  ASSERT_EQ(c->variants.size(), 4u);
  const auto fastest = std::min_element(c->variants.begin(), c->variants.end(),
                                        [](const auto& a, const auto& b) { return a.seconds < b.seconds; });
  EXPECT_EQ(c->preferred.method, fastest->variant.method);
  EXPECT_EQ(c->preferred.log_step, fastest->variant.log_step);
  EXPECT_EQ(policy.preferred_variant().method, fastest->variant.method);
  EXPECT_EQ(policy.preferred_variant().log_step, fastest->variant.log_step);
  // A request naming no variant runs the preferred one.
  const auto dem = testing::make_random_terrain(60, 60, 2);
  ViewshedOptions o;
  o.backend = Backend::kGpu;
  auto r = visibility::compute_viewshed(dem, eye_at(dem, 30.5, 20.5), o, nullptr, own->get(), &policy);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r->stats.gpu_variant, visibility::gpu_variant_name(fastest->variant));
  // Without time_software a software rasteriser is not timed and never preferred.
  if ((*own)->device().software) {
    auto plain = visibility::calibrate(**own, policy);
    ASSERT_TRUE(plain.ok());
    EXPECT_TRUE(plain->points.empty());
    EXPECT_FALSE(policy.prefers_gpu((*own)->device(), UINT64_MAX - 1));
  }
}

TEST(GpuBackend, GpuWithoutAPoolIsAnsweredOnTheCpuAndSaysWhy) {
  const auto dem = testing::make_random_terrain(64, 64, 1);
  ViewshedOptions o;
  o.backend = Backend::kGpu;
  auto r = visibility::compute_viewshed(dem, eye_at(dem, 20.5, 30.5), o);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r->stats.backend, "cpu");
  EXPECT_FALSE(r->stats.gpu_fallback.empty());
}

TEST(GpuBackend, GpuIsRejectedForAlgorithmsOtherThanFast) {
  ViewshedOptions o;
  o.backend = Backend::kGpu;
  o.algorithm = visibility::Algorithm::kExact;
  const auto s = visibility::validate_options(o);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().field, "backend");
  EXPECT_EQ(visibility::parse_backend("gpu"), Backend::kGpu);
  EXPECT_EQ(visibility::parse_backend("GPU"), std::nullopt);
  EXPECT_EQ(visibility::parse_gpu_method("compute"), visibility::GpuMethod::kCompute);
}

}  // namespace
}  // namespace horizon
