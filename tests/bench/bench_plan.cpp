// What planning and reading through a source cost a request (Google Benchmark).
//
//   HORIZON_BENCH_DEM=dem.tif [HORIZON_BENCH_TILES=folder] build/tests/bench/bench_plan
//
// A 10 km fast viewshed at the DEM's centre, 2 m up, one engine thread (as
// the daemon runs it), three ways:
//   Resident    compute_viewshed on the whole DEM held in memory (the engine
//               alone: no plan, no read);
//   PlannedWarm plan_viewshed + run_viewshed through a warm block cache, with
//               a workspace kept between runs (as each daemon worker keeps one);
//   TilesWarm   the same on HORIZON_BENCH_TILES (the DEM cut into tiles).
// and the pieces of a planned run: Plan (planning alone), ReadWarm (the
// window's blocks assembled from a warm cache). Results in docs/benchmarks.md.
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <memory>
#include <string>

#include "horizon/terrain/block_cache.hpp"
#include "horizon/terrain/dem_reader.hpp"
#include "horizon/terrain/source.hpp"
#include "horizon/visibility/plan.hpp"
#include "horizon/visibility/viewshed.hpp"

using namespace horizon;

namespace {

constexpr double kReach = 10000.0;

const char* env(const char* name) {
  const char* v = std::getenv(name);
  return v && *v ? v : nullptr;
}

struct Fixture {
  std::shared_ptr<const terrain::ElevationSource> source;
  terrain::BlockCache cache{[] {
    terrain::BlockCache::Options o;
    o.budget_bytes = 1ull << 30;
    return o;
  }()};
  visibility::ViewshedQuery query;
  visibility::Workspace workspace;
};

// The source at `path` with its centre's 10 km query, its cache warmed by one run.
std::unique_ptr<Fixture> open_fixture(const char* path) {
  auto f = std::make_unique<Fixture>();
  auto source = terrain::ElevationSource::open(path);
  if (!source.ok()) return nullptr;
  f->source = *source;
  const terrain::DemHeader& h = f->source->header();
  f->query.observer.x = h.georef.transform.x_at(h.width / 2);
  f->query.observer.y = h.georef.transform.y_at(h.height / 2);
  f->query.observer.height = 2.0;
  f->query.options.max_distance = kReach;
  f->query.options.threads = 1;
  f->query.options.backend = visibility::Backend::kCpu;
  auto plan = visibility::plan_viewshed(*f->source, f->query);
  if (!plan.ok() || !visibility::run_viewshed(*plan, *f->source, &f->cache).ok()) return nullptr;
  return f;
}

Fixture* dem_fixture() {
  static std::unique_ptr<Fixture> f = env("HORIZON_BENCH_DEM") ? open_fixture(env("HORIZON_BENCH_DEM")) : nullptr;
  return f.get();
}

Fixture* tiles_fixture() {
  static std::unique_ptr<Fixture> f = env("HORIZON_BENCH_TILES") ? open_fixture(env("HORIZON_BENCH_TILES")) : nullptr;
  return f.get();
}

void BM_Resident(benchmark::State& state) {
  Fixture* f = dem_fixture();
  if (!f) return state.SkipWithError("set HORIZON_BENCH_DEM to a DEM");
  static auto dem = terrain::read_dem(env("HORIZON_BENCH_DEM"));
  auto observer = geodesy::resolve_point(*dem, f->query.observer, "observer");
  std::uint64_t cells = 0;
  for (auto _ : state) {
    auto vs = visibility::compute_viewshed(*dem, *observer, f->query.options);
    cells = vs->stats.window_cells;
    benchmark::DoNotOptimize(vs->ohf.data());
  }
  state.counters["cells/s"] =
      benchmark::Counter(static_cast<double>(cells), benchmark::Counter::kIsIterationInvariantRate);
}

void planned(benchmark::State& state, Fixture* f) {
  if (!f) return state.SkipWithError("set HORIZON_BENCH_DEM / HORIZON_BENCH_TILES");
  std::uint64_t cells = 0;
  for (auto _ : state) {
    auto plan = visibility::plan_viewshed(*f->source, f->query);
    auto run = visibility::run_viewshed(*plan, *f->source, &f->cache, nullptr, nullptr, nullptr, &f->workspace);
    cells = run->result.stats.window_cells;
    benchmark::DoNotOptimize(run->result.ohf.data());
  }
  state.counters["cells/s"] =
      benchmark::Counter(static_cast<double>(cells), benchmark::Counter::kIsIterationInvariantRate);
}

void BM_PlannedWarm(benchmark::State& state) {
  planned(state, dem_fixture());
}
void BM_TilesWarm(benchmark::State& state) {
  planned(state, tiles_fixture());
}

void BM_Plan(benchmark::State& state) {
  Fixture* f = dem_fixture();
  if (!f) return state.SkipWithError("set HORIZON_BENCH_DEM to a DEM");
  for (auto _ : state) benchmark::DoNotOptimize(visibility::plan_viewshed(*f->source, f->query));
}

void BM_ReadWarm(benchmark::State& state) {
  Fixture* f = dem_fixture();
  if (!f) return state.SkipWithError("set HORIZON_BENCH_DEM to a DEM");
  auto plan = visibility::plan_viewshed(*f->source, f->query);
  for (auto _ : state) {
    auto dem = f->source->read(plan->read.read, &f->cache);
    benchmark::DoNotOptimize(dem->elevation.data());
  }
  state.counters["cells/s"] =
      benchmark::Counter(static_cast<double>(plan->cost.read_cells), benchmark::Counter::kIsIterationInvariantRate);
}

}  // namespace

BENCHMARK(BM_Resident)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_PlannedWarm)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_TilesWarm)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Plan)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_ReadWarm)->Unit(benchmark::kMillisecond);
BENCHMARK_MAIN();
