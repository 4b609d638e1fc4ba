// Camera silhouette traces (Google Benchmark): ms per frame of the CPU
// trace, by frame size, mode and kernel form.
//
//   build/tests/bench/bench_trace                                # synthetic 2048 x 2048 terrain, fixed seed
//   HORIZON_BENCH_DEM=everest_2048.tif build/tests/bench/bench_trace
//
// The camera stands 100 m above the ground a tenth of the way up from the
// DEM's south edge, centred east-west, looking north (yaw 10 degrees,
// pitch -5, 60 degree field of view): nearly the whole DEM ahead of it,
// the paper's setting. Results with their machine go in docs/benchmarks.md.
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdlib>
#include <memory>
#include <random>

#include "horizon/gpu/context_pool.hpp"
#include "horizon/terrain/dem_reader.hpp"
#include "horizon/trace/camera.hpp"
#include "horizon/trace/trace.hpp"
#include "horizon/visibility/view_frame.hpp"
#include "visibility/simd.hpp"  // core/src: the kernels' instruction-set cap

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

const terrain::Dem& bench_dem() {
  static std::unique_ptr<terrain::Dem> dem;
  if (!dem) {
    const char* path = std::getenv("HORIZON_BENCH_DEM");
    if (path) {
      auto read = terrain::read_dem(path);
      if (!read.ok()) {
        std::fprintf(stderr, "bench_trace: %s\n", read.error().message.c_str());
        std::exit(1);
      }
      dem = std::make_unique<terrain::Dem>(std::move(read).value());
    } else {
      dem = std::make_unique<terrain::Dem>(synthetic(2048));
    }
  }
  return *dem;
}

trace::Camera bench_camera(const terrain::Dem& dem, int width, int height) {
  trace::CameraSpec spec;
  spec.position.x = dem.georef.transform.x_at(dem.width() / 2.0 - 0.5);
  spec.position.y = dem.georef.transform.y_at(dem.height() * 0.9);
  spec.position.height = 100.0;
  spec.yaw = 10.0;
  spec.pitch = -5.0;
  spec.hfov = 60.0;
  spec.width = width;
  spec.height = height;
  auto camera = trace::resolve_camera(dem, spec);
  if (!camera.ok()) {
    std::fprintf(stderr, "bench_trace: %s\n", camera.error().message.c_str());
    std::exit(1);
  }
  return *camera;
}

// Args: width, height, column crossings (0/1), kernel form (0 scalar, 1 AVX2, 2 AVX-512).
void BM_TraceCpu(benchmark::State& state) {
  namespace simd = visibility::sweep::simd;
  const auto isa = static_cast<simd::Isa>(state.range(3));
  if (simd::cpu_isa() < isa) {
    state.SkipWithError("this CPU lacks the kernel form");
    return;
  }
  simd::isa_limit() = isa;
  const terrain::Dem& dem = bench_dem();
  const trace::Camera camera = bench_camera(dem, static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  trace::TraceOptions options;
  options.column_crossings = state.range(2) != 0;
  if (const char* t = std::getenv("HORIZON_TRACE_THREADS")) options.threads = static_cast<unsigned>(std::atoi(t));
  trace::TraceResult frame;  // reused, as a caller tracing frame after frame would
  for (auto _ : state) {
    const Status status = trace::trace_frame(terrain::HeightView(dem.elevation), camera, options, frame);
    if (!status.ok()) {
      state.SkipWithError(status.error().message.c_str());
      break;
    }
    benchmark::DoNotOptimize(frame.image.distance.data());
  }
  const trace::TraceStats& stats = frame.stats;
  simd::isa_limit() = simd::Isa::kAvx512;
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()) * static_cast<int64_t>(stats.pixels));
  state.counters["lines"] = stats.max_lines;
  state.counters["crossings"] = static_cast<double>(stats.crossings);
  state.counters["reads/px"] = stats.reads_per_pixel;
  state.counters["sky%"] = 100.0 * static_cast<double>(stats.sky_pixels) / static_cast<double>(stats.pixels);
}
BENCHMARK(BM_TraceCpu)
    ->ArgsProduct({{512}, {512}, {0, 1}, {0, 1, 2}})
    ->Args({1024, 1024, 0, 2})
    ->Args({1024, 512, 0, 2})
    ->Args({512, 1024, 0, 2})
    ->Args({1000, 1000, 0, 2})
    ->Args({1024, 1024, 1, 2})
    ->Args({1920, 1080, 0, 2})
    ->Args({1920, 1080, 1, 2})
    ->Args({1024, 1024, 0, 1})
    ->Args({1920, 1080, 0, 1})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// The GL form on the device EGL gives (llvmpipe without a GPU): the same
// frames. Args: width, height.
void BM_TraceGl(benchmark::State& state) {
  static auto pool = gpu::ContextPool::create({.contexts = 1});
  if (!pool.ok()) {
    state.SkipWithError(pool.error().message.c_str());
    return;
  }
  auto lease = (*pool)->borrow();
  if (!lease.ok()) {
    state.SkipWithError(lease.error().message.c_str());
    return;
  }
  const terrain::Dem& dem = bench_dem();
  const trace::Camera camera = bench_camera(dem, static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  trace::TraceOptions options;
  trace::TraceResult frame;
  for (auto _ : state) {
    const Status status =
        trace::trace_frame(terrain::HeightView(dem.elevation), camera, options, frame, nullptr, &*lease);
    if (!status.ok() || frame.stats.backend != "gpu") {
      state.SkipWithError(status.ok() ? frame.stats.gpu_fallback.c_str() : status.error().message.c_str());
      break;
    }
    benchmark::DoNotOptimize(frame.image.distance.data());
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()) * static_cast<int64_t>(frame.stats.pixels));
  state.SetLabel((*pool)->device().renderer);
}
BENCHMARK(BM_TraceGl)
    ->Args({512, 512})
    ->Args({1024, 1024})
    ->Args({1920, 1080})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
