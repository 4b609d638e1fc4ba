// server_env.hpp — what every RPC handler reaches: the configuration, the
// datasets and their block cache, the meshes, the worker pool, the memory budget, the
// metrics and the GPU contexts. Owned by the Daemon; outlives every call.
#pragma once

#include <atomic>
#include <cstdint>
#include <filesystem>

#include "allocator.hpp"
#include "config.hpp"
#include "datasets.hpp"
#include "deadline_watch.hpp"
#include "horizon/gpu/context_pool.hpp"
#include "horizon/terrain/block_cache.hpp"
#include "horizon/visibility/backend_policy.hpp"
#include "memory_budget.hpp"
#include "meshes.hpp"
#include "metrics.hpp"
#include "worker_pool.hpp"

namespace horizon::server {

struct ServerEnv {
  const Config& config;  // limits, threads and deadlines are fixed at start; SIGHUP reloads datasets only
  DatasetRegistry& datasets;
  WorkerPool& pool;
  MemoryBudget& memory;
  Metrics& metrics;
  terrain::BlockCache& cache;  // decoded blocks of every dataset, shared by every request
  MeshRegistry& meshes;        // the prepared TIN meshes (config "meshes"), swapped with the datasets
  // Set once at start, before the first call; null when config gpu.contexts is
  // 0 or no EGL display could be had (every request then runs on the CPU).
  gpu::ContextPool* gpu = nullptr;
  // When requests run there (backend auto) and with which GL variant,
  // measured at start (visibility/backend_policy.hpp); set with `gpu`.
  const visibility::BackendPolicy* backend = nullptr;
  // The daemon's private directory inside config.scratch_dir (scratch_dir.hpp),
  // made at start before the first call.
  std::filesystem::path scratch{};
  std::atomic<std::uint32_t> pending{0};  // admitted and not finished
  std::atomic<bool> draining{false};      // shutting down: new calls are refused
  // Our calls whose reactors gRPC still holds (CallScope's lifetime, which
  // ends after gRPC's OnDone: the answer is sent), admitted or not.
  std::atomic<std::uint32_t> live_calls{0};
  // The budget's bytes held for the workers' kept buffers (worker_memory.hpp).
  std::atomic<std::uint64_t> kept_bytes{0};
  // Told when live_calls falls to 0 (allocator.hpp); null in tests without one.
  HeapTrimmer* trimmer = nullptr;
  // Ends calls whose default deadline passes (deadline_watch.hpp); null in tests without one.
  DeadlineWatch* deadlines = nullptr;
};

}  // namespace horizon::server
