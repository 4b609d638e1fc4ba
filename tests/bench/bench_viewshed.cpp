// Viewshed benchmarks (Google Benchmark), reporting cells/s.
//
//   build/tests/bench/bench_viewshed                       # synthetic terrain, fixed seed
//   HORIZON_BENCH_DEM=path.tif build/tests/bench/bench_viewshed --benchmark_filter=Dem
//
// The synthetic terrain is a fixed-seed sum of hills so runs are comparable
// across machines; the Dem benchmarks time the algorithm alone (no I/O) on a
// real file with the observer at its centre, 2 m up. Results and the machine
// they ran on go in docs/benchmarks.md.
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <map>
#include <memory>
#include <random>
#include <string>

#include "horizon/common/huge_pages.hpp"
#include "horizon/common/large_allocator.hpp"
#include "horizon/geodesy/observer.hpp"
#include "horizon/gpu/context_pool.hpp"
#include "horizon/terrain/dem_reader.hpp"
#include "horizon/visibility/r3.hpp"
#include "horizon/visibility/radial_sweep.hpp"
#include "horizon/visibility/viewshed.hpp"
#include "simd.hpp"  // core/src/visibility: the sweep kernels' instruction-set cap

using namespace horizon;

namespace {

terrain::Dem synthetic(int size) {
  terrain::Dem dem;
  dem.elevation = terrain::Grid<float>(size, size);
  std::mt19937 rng(42);
  std::uniform_real_distribution<float> u(0, 1);
  struct Hill {
    float x, y, a, r;
  };
  std::vector<Hill> hills(60);
  for (auto& h : hills) h = {u(rng) * size, u(rng) * size, (u(rng) - 0.3f) * 800.0f, (0.02f + 0.2f * u(rng)) * size};
  for (int r = 0; r < size; ++r)
    for (int c = 0; c < size; ++c) {
      float z = 1000;
      for (const auto& h : hills) z += h.a * std::exp(-((c - h.x) * (c - h.x) + (r - h.y) * (r - h.y)) / (h.r * h.r));
      dem.elevation.at(c, r) = z;
    }
  dem.georef.transform = {0, 30, 0, -30};
  dem.source = "synthetic";
  return dem;
}

geodesy::GridPoint centre_eye(const terrain::Dem& dem) {
  geodesy::GridPoint p;
  p.col = dem.width() / 2;
  p.row = dem.height() / 2;
  p.x = dem.georef.transform.x_at(p.col);  // the metric scale is taken here
  p.y = dem.georef.transform.y_at(p.row);
  p.ground = dem.elevation.at(static_cast<int>(p.col), static_cast<int>(p.row));
  p.elevation = p.ground + 2.0;
  return p;
}

// The fast OHF of `dem` from its centre in steady state, as a daemon worker
// runs it: the output and the east and west sectors' transposed lines
// (radial_ohf's column_buffer) in buffers kept between calls
// (BM_VisibleRaster compares the lines copied and read in place).
void run_radial(benchmark::State& state, const terrain::Dem& dem, double spacing, double max_distance) {
  visibility::ViewshedOptions o;
  o.radial.ray_spacing = spacing;
  o.max_distance = max_distance;
  auto frame = visibility::make_view_frame(dem, centre_eye(dem), o);
  if (!frame.ok()) {
    state.SkipWithError(frame.error().message.c_str());
    return;
  }
  terrain::Grid<float> ohf;
  terrain::Grid<float> columns;  // the east and west sectors' lines, kept as a daemon worker keeps it
  visibility::WorkStats stats;
  for (auto _ : state) {
    stats = {};
    const Status status = visibility::radial_ohf(dem.elevation, *frame, o.radial, 0, nullptr, ohf, stats,
                                                 visibility::RadialBound::kNone, &columns);
    if (!status.ok()) {
      state.SkipWithError(status.error().message.c_str());
      return;
    }
    benchmark::DoNotOptimize(ohf.data());
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * stats.cells_evaluated));
  state.counters["cells"] = static_cast<double>(stats.cells_evaluated);
  state.counters["samples/cell"] = double(stats.terrain_samples) / double(std::max<uint64_t>(1, stats.cells_evaluated));
}

void BM_RadialSynthetic(benchmark::State& state) {
  static std::map<int, std::unique_ptr<terrain::Dem>> cache;
  const int size = static_cast<int>(state.range(0));
  auto& dem = cache[size];
  if (!dem) dem = std::make_unique<terrain::Dem>(synthetic(size));
  run_radial(state, *dem, state.range(1) / 100.0, std::numeric_limits<double>::infinity());
}
BENCHMARK(BM_RadialSynthetic)
    ->ArgsProduct({{1024, 2048, 3500}, {100, 50, 25}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

void BM_R3Synthetic(benchmark::State& state) {
  const auto dem = synthetic(static_cast<int>(state.range(0)));
  visibility::ViewshedOptions o;
  auto frame = visibility::make_view_frame(dem, centre_eye(dem), o);
  if (!frame.ok()) {
    state.SkipWithError(frame.error().message.c_str());
    return;
  }
  terrain::Grid<float> ohf;
  visibility::WorkStats stats;
  for (auto _ : state) {
    const Status status = visibility::r3_ohf(dem.elevation, *frame, 0, nullptr, ohf, stats);
    if (!status.ok()) {
      state.SkipWithError(status.error().message.c_str());
      return;
    }
    benchmark::DoNotOptimize(ohf.data());
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * stats.cells_evaluated));
}
BENCHMARK(BM_R3Synthetic)->Arg(512)->Arg(1024)->Unit(benchmark::kMillisecond)->UseRealTime();

// The DEM named by $HORIZON_BENCH_DEM, read once; null (and the state
// skipped with the reason) when it is unset or unreadable.
const terrain::Dem* bench_dem(benchmark::State& state) {
  static std::unique_ptr<terrain::Dem> dem;
  const char* path = std::getenv("HORIZON_BENCH_DEM");
  if (!path) {
    state.SkipWithError("set HORIZON_BENCH_DEM to a DEM file");
    return nullptr;
  }
  if (!dem) {
    auto read = terrain::read_dem(path);
    if (!read.ok()) {
      state.SkipWithError(read.error().message.c_str());
      return nullptr;
    }
    dem = std::make_unique<terrain::Dem>(std::move(read).value());
  }
  return dem.get();
}

// A real DEM from $HORIZON_BENCH_DEM: whole DEM, and max distance = 10 % of its width.
void BM_RadialDem(benchmark::State& state) {
  const terrain::Dem* dem = bench_dem(state);
  if (!dem) return;
  const double width_m = dem->width() * std::abs(dem->georef.transform.pixel_width);
  run_radial(state, *dem, state.range(0) / 100.0,
             state.range(1) ? 0.1 * width_m : std::numeric_limits<double>::infinity());
}
BENCHMARK(BM_RadialDem)->ArgsProduct({{100, 50, 25}, {0, 1}})->Unit(benchmark::kMillisecond)->UseRealTime();

// Caps the sweep's kernels at instruction set `isa` (0 scalar, 1 AVX2, 2
// AVX-512) while it lives; ok() is false, and the benchmark skipped, when
// the CPU lacks it.
class KernelCap {
 public:
  KernelCap(benchmark::State& state, std::int64_t isa) {
    using visibility::sweep::simd::Isa;
    if (visibility::sweep::simd::cpu_isa() < static_cast<Isa>(isa)) {
      state.SkipWithError("this CPU lacks that instruction set");
      return;
    }
    visibility::sweep::simd::isa_limit() = static_cast<Isa>(isa);
    ok_ = true;
  }
  ~KernelCap() { visibility::sweep::simd::isa_limit() = visibility::sweep::simd::Isa::kAvx512; }
  KernelCap(const KernelCap&) = delete;
  KernelCap& operator=(const KernelCap&) = delete;
  bool ok() const { return ok_; }

 private:
  bool ok_ = false;
};

// BM_RadialDem's default (ray spacing 1, whole DEM) with the sweep's kernels
// capped at one instruction set: 0 scalar, 1 AVX2, 2 AVX-512 (skipped when
// the CPU lacks it). Run with --benchmark_enable_random_interleaving=true to
// compare the forms in one run on a noisy machine.
void BM_RadialKernels(benchmark::State& state) {
  const KernelCap cap(state, state.range(0));
  const terrain::Dem* dem = cap.ok() ? bench_dem(state) : nullptr;
  if (!dem) return;
  run_radial(state, *dem, 1.0, std::numeric_limits<double>::infinity());
}
BENCHMARK(BM_RadialKernels)->DenseRange(0, 2)->Unit(benchmark::kMillisecond)->UseRealTime();

// The visible raster of BM_RadialKernels' viewshed (target on the ground),
// kernels capped at range(0) (1 AVX2, 2 AVX-512) by one of two roads:
// range(1) 0: the OHF (radial_ohf into a kept grid), then visibility_mask
// over it and the terrain; 1: radial_mask, the sweep coding each cell into
// a kept byte grid (ViewshedOptions::mask_only, the CLI's and the daemon's
// visible rasters). The elevations are a copy of the DEM's, on 4 KiB pages
// with the output (range(2) 0: the allocator asks for no huge pages while
// the benchmark runs) or, as a daemon worker's kept buffers are, backed by
// huge pages with the output (1: back_with_huge_pages). range(3) 1: the
// east and west sectors read a transposed copy of the window, made each
// call into a kept buffer as a daemon worker's (radial_ohf's
// column_buffer); 0: they read the elevations in place, as a one-off run
// (the CLI) does.
void BM_VisibleRaster(benchmark::State& state) {
  const KernelCap cap(state, state.range(0));
  const terrain::Dem* dem = cap.ok() ? bench_dem(state) : nullptr;
  if (!dem) return;
  const bool in_sweep = state.range(1) != 0, huge = state.range(2) != 0, copied = state.range(3) != 0;
  // On the 4 KiB road the copy and the outputs below ask for no huge pages.
  struct SmallPagesWhile {
    const bool allowed = huge_pages_allowed();
    explicit SmallPagesWhile(bool small) { allow_huge_pages(allowed && !small); }
    ~SmallPagesWhile() { allow_huge_pages(allowed); }
  } small_pages(!huge);
  state.SetLabel(std::string(in_sweep ? "radial_mask" : "radial_ohf + visibility_mask") +
                 (huge ? ", huge pages" : ", 4 KiB pages") + (copied ? ", columns copied" : ", columns in place"));
  const terrain::Grid<float> elevation = dem->elevation;
  if (huge && !back_with_huge_pages(elevation.data(), elevation.capacity() * sizeof(float))) {
    state.SkipWithError("no huge pages here (MADV_COLLAPSE: Linux 6.1+)");
    return;
  }
  visibility::ViewshedOptions o;
  auto frame = visibility::make_view_frame(*dem, centre_eye(*dem), o);
  if (!frame.ok()) {
    state.SkipWithError(frame.error().message.c_str());
    return;
  }
  visibility::ViewshedResult result;
  result.frame = *frame;
  result.terrain = elevation;
  terrain::Grid<std::uint8_t> mask;
  terrain::Grid<float> columns;  // the east and west sectors' lines, kept as a daemon worker keeps it
  terrain::Grid<float>* const column_buffer = copied ? &columns : nullptr;
  visibility::AnswerCounts counts;
  visibility::WorkStats stats;
  bool backed = false;
  for (auto _ : state) {
    Status status;
    if (in_sweep) {
      status =
          visibility::radial_mask(elevation, *frame, o.radial, 0.0, 0, nullptr, mask, counts, stats, column_buffer);
    } else {
      status = visibility::radial_ohf(elevation, *frame, o.radial, 0, nullptr, result.ohf, stats,
                                      visibility::RadialBound::kNone, column_buffer);
      mask = visibility::visibility_mask(result, 0.0, 0, &counts);
    }
    if (!status.ok()) {
      state.SkipWithError(status.error().message.c_str());
      break;
    }
    if (huge && !backed) {  // the kept outputs too, once they exist
      state.PauseTiming();
      back_with_huge_pages(mask.data(), mask.capacity());
      if (!columns.empty()) back_with_huge_pages(columns.data(), columns.capacity() * sizeof(float));
      if (!result.ohf.empty()) back_with_huge_pages(result.ohf.data(), result.ohf.capacity() * sizeof(float));
      backed = true;
      state.ResumeTiming();
    }
    benchmark::DoNotOptimize(mask.data());
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * stats.cells_evaluated));
  state.counters["visible"] = static_cast<double>(counts.visible);
}
BENCHMARK(BM_VisibleRaster)
    ->ArgsProduct({{1, 2}, {0, 1}, {0, 1}, {0, 1}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// Each algorithm mode through compute_viewshed on $HORIZON_BENCH_DEM, whole
// DEM: 0 fast, 1 conservative, 2 exact, 3 r3 (the last two are slow: run them
// with --benchmark_min_time small, or filter them out).
void BM_AlgorithmDem(benchmark::State& state) {
  const terrain::Dem* dem = bench_dem(state);
  if (!dem) return;
  constexpr visibility::Algorithm kAlgorithms[] = {visibility::Algorithm::kRadial, visibility::Algorithm::kConservative,
                                                   visibility::Algorithm::kExact, visibility::Algorithm::kR3};
  visibility::ViewshedOptions o;
  o.algorithm = kAlgorithms[state.range(0)];
  state.SetLabel(std::string(visibility::algorithm_name(o.algorithm)));
  visibility::WorkStats stats;
  for (auto _ : state) {
    auto result = visibility::compute_viewshed(*dem, centre_eye(*dem), o);
    if (!result.ok()) {
      state.SkipWithError(result.error().message.c_str());
      return;
    }
    stats = result->stats;
    benchmark::DoNotOptimize(result->ohf.data());
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * stats.cells_evaluated));
  state.counters["samples/cell"] = double(stats.terrain_samples) / double(std::max<uint64_t>(1, stats.cells_evaluated));
}
BENCHMARK(BM_AlgorithmDem)->DenseRange(0, 3)->Unit(benchmark::kMillisecond)->UseRealTime();

// The fast OHF on the GL path (visibility/radial_sweep_gl.hpp) on $HORIZON_BENCH_DEM, whole
// DEM, eye at the centre: (method 0 fragment / 1 compute) x (log-step 1 / 0).
// "device ms" is the passes alone (GL timestamps); the time also covers the
// upload, the read-back and the OHF's multiply on the CPU. One-step fragment
// propagation draws once per step: slow on large DEMs without a real GPU.
void BM_GpuDem(benchmark::State& state) {
  const terrain::Dem* dem = bench_dem(state);
  if (!dem) return;
  static auto pool = gpu::ContextPool::create({.contexts = 1});
  if (!pool.ok()) {
    state.SkipWithError(pool.error().message.c_str());
    return;
  }
  visibility::ViewshedOptions o;
  o.backend = visibility::Backend::kGpu;
  o.gpu = visibility::GpuOptions{state.range(0) ? visibility::GpuMethod::kCompute : visibility::GpuMethod::kFragment,
                                 state.range(1) != 0};
  state.SetLabel((*pool)->device().renderer + ", " + visibility::gpu_variant_name(*o.gpu));
  visibility::WorkStats stats;
  double device = 0;
  for (auto _ : state) {
    auto result = visibility::compute_viewshed(*dem, centre_eye(*dem), o, nullptr, pool->get());
    if (!result.ok() || result->stats.backend != "gpu") {
      state.SkipWithError(result.ok() ? result->stats.gpu_fallback.c_str() : result.error().message.c_str());
      return;
    }
    stats = result->stats;
    device += stats.device_seconds;
    benchmark::DoNotOptimize(result->ohf.data());
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * stats.cells_evaluated));
  state.counters["device ms"] = 1e3 * device / double(std::max<benchmark::IterationCount>(1, state.iterations()));
}
BENCHMARK(BM_GpuDem)->ArgsProduct({{0, 1}, {1, 0}})->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
