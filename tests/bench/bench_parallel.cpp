// parallel_for's fixed cost (Google Benchmark): a tiny loop on 2 threads on
// the process-wide executor, beside the same loop with its helper thread
// started and joined per call (the engine's parallel_for before the executor,
// kept here for comparison only).
//
//   build/tests/bench/bench_parallel
//
// Results and the machine they ran on go in docs/benchmarks.md.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <atomic>
#include <functional>
#include <thread>
#include <vector>

#include "horizon/common/parallel.hpp"

namespace {

// The pre-executor parallel_for (cbd77d5): the caller plus (threads - 1)
// jthreads started for this call pull indices from one atomic counter.
void spawn_for(std::size_t count, unsigned threads, const std::function<void(std::size_t)>& body) {
  if (count == 0) return;
  const std::size_t workers = std::min<std::size_t>(horizon::resolve_thread_count(threads), count);
  std::atomic<std::size_t> next{0};
  auto run = [&] {
    for (std::size_t i = next.fetch_add(1, std::memory_order_relaxed); i < count;
         i = next.fetch_add(1, std::memory_order_relaxed))
      body(i);
  };
  std::vector<std::jthread> helpers;
  helpers.reserve(workers - 1);
  for (std::size_t t = 1; t < workers; ++t) helpers.emplace_back(run);
  run();
}

// state.range(0) items, each a relaxed increment: the call's cost is all
// overhead (start or wake, hand-out, join or wait).
template <void (*For)(std::size_t, unsigned, const std::function<void(std::size_t)>&)>
void BM_TinyLoop(benchmark::State& state) {
  const auto count = static_cast<std::size_t>(state.range(0));
  std::atomic<std::size_t> sum{0};
  const std::function<void(std::size_t)> body = [&](std::size_t i) { sum.fetch_add(i, std::memory_order_relaxed); };
  For(count, 2, body);  // the executor starts on first use, not in the timing
  for (auto _ : state) For(count, 2, body);
  benchmark::DoNotOptimize(sum.load());
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()));  // calls/s
}

void executor_for(std::size_t count, unsigned threads, const std::function<void(std::size_t)>& body) {
  horizon::parallel_for(count, threads, body);
}

}  // namespace

BENCHMARK(BM_TinyLoop<executor_for>)->Name("BM_ParallelForTiny/executor")->Arg(2)->Arg(64)->UseRealTime();
BENCHMARK(BM_TinyLoop<spawn_for>)->Name("BM_ParallelForTiny/spawn")->Arg(2)->Arg(64)->UseRealTime();

BENCHMARK_MAIN();
