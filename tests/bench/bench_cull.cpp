// Box culling at simulator scale (Google Benchmark): many boxes against one
// warm OHF, on one core.
//
//   build/tests/bench/bench_cull --benchmark_enable_random_interleaving=true
//
// Scene: the fixed-seed synthetic terrain of bench_viewshed (2048 x 2048
// cells of 30 m), eye 2 m up at the centre, the fast OHF over the whole DEM
// computed once (the warm OHF a simulator keeps while its camera is still,
// or reuses across box sets). Boxes: 5 to 60 m wide, 2 to 20 m tall, on the
// ground; "scattered" uniform over the DEM, "clustered" in 30 groups of
// boxes within 1.5 km of each group's centre.
//
// BM_CullBoxes/<form>/<layout>/<boxes>: form 0 scalar, 1 AVX2, 2 AVX-512
// (cull_batch with the kernels capped there; skipped when the CPU lacks it),
// 3 the min-pyramid (cull_footprints, every block already built); layout 0
// scattered, 1 clustered. The time is one call over every box; the index and
// the batch are built outside the loop (BM_CullPrepare times them).
// BM_CullStates: exact minima against states only (whole hidden groups at
// once), below.
#include <benchmark/benchmark.h>

#include <cmath>
#include <map>
#include <memory>
#include <random>
#include <vector>

#include "horizon/geodesy/observer.hpp"
#include "horizon/visibility/cull.hpp"
#include "horizon/visibility/cull_index.hpp"
#include "horizon/visibility/viewshed.hpp"
#include "simd.hpp"  // core/src/visibility: the kernels' instruction-set cap

using namespace horizon;

namespace {

constexpr int kSize = 2048;
constexpr double kCell = 30.0;

struct Scene {
  terrain::Dem dem;
  visibility::ViewshedResult ohf;
};

const Scene& scene() {
  static const std::unique_ptr<Scene> s = [] {
    auto out = std::make_unique<Scene>();
    terrain::Dem& dem = out->dem;
    dem.elevation = terrain::Grid<float>(kSize, kSize);
    std::mt19937 rng(42);
    std::uniform_real_distribution<float> u(0, 1);
    struct Hill {
      float x, y, a, r;
    };
    std::vector<Hill> hills(60);
    for (auto& h : hills)
      h = {u(rng) * kSize, u(rng) * kSize, (u(rng) - 0.3f) * 800.0f, (0.02f + 0.2f * u(rng)) * kSize};
    for (int r = 0; r < kSize; ++r)
      for (int c = 0; c < kSize; ++c) {
        float z = 1000;
        for (const auto& h : hills) z += h.a * std::exp(-((c - h.x) * (c - h.x) + (r - h.y) * (r - h.y)) / (h.r * h.r));
        dem.elevation.at(c, r) = z;
      }
    dem.georef.transform = {0, kCell, 0, -kCell};
    dem.source = "synthetic";
    geodesy::GridPoint eye;
    eye.col = eye.row = kSize / 2;
    eye.x = dem.georef.transform.x_at(eye.col);
    eye.y = dem.georef.transform.y_at(eye.row);
    eye.ground = dem.elevation.at(kSize / 2, kSize / 2);
    eye.elevation = eye.ground + 2.0;
    auto ohf = visibility::compute_viewshed(dem, eye, {});
    if (ohf.ok()) out->ohf = std::move(*ohf);
    return out;
  }();
  return *s;
}

std::vector<visibility::BoxFootprint> make_boxes(std::size_t n, bool clustered) {
  const Scene& s = scene();
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<visibility::BoxSpec> specs;
  std::vector<std::pair<double, double>> centres(30);
  for (auto& c : centres) c = {(0.1 + 0.8 * u(rng)) * kSize * kCell, (0.1 + 0.8 * u(rng)) * kSize * kCell};
  const double span = kSize * kCell - 61.0;
  for (std::size_t i = 0; i < n; ++i) {
    double x, y;
    if (clustered) {
      const auto& c = centres[i % centres.size()];
      const double a = 2 * M_PI * u(rng), d = 1500.0 * std::sqrt(u(rng));
      x = c.first + d * std::cos(a);
      y = c.second + d * std::sin(a);
    } else {
      x = u(rng) * span;
      y = u(rng) * span;
    }
    const double w = 5 + 55 * u(rng), h = 5 + 55 * u(rng);
    const int col = static_cast<int>(x / kCell), row = static_cast<int>(y / kCell);
    const double ground = s.dem.elevation.at(col, row);
    visibility::BoxSpec b;
    b.x_min = x;
    b.x_max = x + w;
    b.y_max = -y;
    b.y_min = -y - h;
    b.z_min = ground;
    b.z_max = ground + 2 + 18 * u(rng);
    specs.push_back(b);
  }
  auto footprints = visibility::resolve_boxes(s.dem, specs);
  return footprints.ok() ? std::move(*footprints) : std::vector<visibility::BoxFootprint>{};
}

void BM_CullBoxes(benchmark::State& state) {
  using visibility::sweep::simd::Isa;
  const int form = static_cast<int>(state.range(0));
  const bool clustered = state.range(1) != 0;
  const auto n = static_cast<std::size_t>(state.range(2));
  if (form < 3 && visibility::sweep::simd::cpu_isa() < static_cast<Isa>(form)) {
    state.SkipWithError("this CPU lacks that instruction set");
    return;
  }
  const Scene& s = scene();
  const std::vector<visibility::BoxFootprint> boxes = make_boxes(n, clustered);
  if (boxes.size() != n) {
    state.SkipWithError("boxes did not resolve");
    return;
  }
  std::vector<visibility::BoxVisibility> out(n);
  std::size_t visible = 0;
  std::uint64_t reads = 0;
  if (form == 3) {
    terrain::Pyramid pyramid(s.ohf.ohf, terrain::Reduction::kMin);
    pyramid.build_all(1);
    for (auto _ : state) {
      reads = 0;
      visible = visibility::cull_footprints(s.ohf, pyramid, boxes, out, &reads);
      benchmark::DoNotOptimize(out.data());
    }
  } else {
    const visibility::CullIndex index(s.ohf.ohf, s.ohf.frame.window, visibility::CullIndex::levels_for(boxes));
    const visibility::BoxBatch batch(boxes);
    visibility::sweep::simd::isa_limit() = static_cast<Isa>(form);
    for (auto _ : state) {
      visibility::BatchStats stats;
      visible = visibility::cull_batch(index, batch, out, &stats);
      reads = stats.reads;
      benchmark::DoNotOptimize(out.data());
    }
    visibility::sweep::simd::isa_limit() = Isa::kAvx512;
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * n));
  state.counters["visible"] = static_cast<double>(visible);
  state.counters["reads/box"] = static_cast<double>(reads) / static_cast<double>(n);
}
BENCHMARK(BM_CullBoxes)->ArgsProduct({{0, 1, 2, 3}, {0, 1}, {27000}})->Unit(benchmark::kMicrosecond)->UseRealTime();

// States only (CullBatchOptions::exact_minimum false) against exact
// minima, with the best kernels this CPU has: BM_CullStates/<exact>/<layout>/
// <boxes>. Hidden groups of Z-order neighbours go at once, so the clustered
// set's cost should grow slower than its box count (27 000 to 108 000 boxes
// in the same 30 clusters).
void BM_CullStates(benchmark::State& state) {
  const bool exact = state.range(0) != 0, clustered = state.range(1) != 0;
  const auto n = static_cast<std::size_t>(state.range(2));
  const Scene& s = scene();
  const std::vector<visibility::BoxFootprint> boxes = make_boxes(n, clustered);
  if (boxes.size() != n) {
    state.SkipWithError("boxes did not resolve");
    return;
  }
  const visibility::CullIndex index(s.ohf.ohf, s.ohf.frame.window, visibility::CullIndex::levels_for(boxes));
  const visibility::BoxBatch batch(boxes);
  std::vector<visibility::BoxVisibility> out(n);
  visibility::BatchStats stats;
  std::size_t visible = 0;
  for (auto _ : state) {
    stats = {};
    visible = visibility::cull_batch(index, batch, out, &stats, {.exact_minimum = exact});
    benchmark::DoNotOptimize(out.data());
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * n));
  state.counters["visible"] = static_cast<double>(visible);
  state.counters["reads/box"] = static_cast<double>(stats.reads) / static_cast<double>(n);
  state.counters["grouped"] =
      static_cast<double>(stats.groups_hidden * visibility::BoxBatch::kGroup) / static_cast<double>(n);
}
BENCHMARK(BM_CullStates)->ArgsProduct({{1, 0}, {0, 1}, {27000, 108000}})->Unit(benchmark::kMicrosecond)->UseRealTime();

// What a new box set or a new OHF costs before the calls above: the batch
// (sort and thresholds, 27 000 boxes) and the index (levels over the 4 M
// OHF cells, one thread). 0 batch, 1 index.
void BM_CullPrepare(benchmark::State& state) {
  const Scene& s = scene();
  const std::vector<visibility::BoxFootprint> boxes = make_boxes(27000, false);
  const int levels = visibility::CullIndex::levels_for(boxes);
  for (auto _ : state) {
    if (state.range(0) == 0) {
      visibility::BoxBatch batch(boxes);
      benchmark::DoNotOptimize(batch.threshold.data());
    } else {
      visibility::CullIndex index(s.ohf.ohf, s.ohf.frame.window, levels);
      benchmark::DoNotOptimize(index.level(0));
    }
  }
  state.counters["levels"] = levels;
}
BENCHMARK(BM_CullPrepare)->DenseRange(0, 1)->Unit(benchmark::kMicrosecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
