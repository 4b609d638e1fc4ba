// horizon/gpu/calibrate.hpp — where the GPU path overtakes the CPU sweep, measured.
//
// Backend::kAuto sends a request to the GPU only when the pool says so
// (ContextPool::prefers_gpu), which on a hardware device is from a window
// size on. calibrate() finds that size on this machine: it times the fast
// viewshed on the CPU and on the pool's GPU over synthetic terrain of
// growing size (128^2 .. 2048^2 cells, eye at the centre, the default knobs;
// median of 3 after a warm-up) and sets the crossover to the smallest size at
// which the GPU was faster there and at every larger size. At the largest
// size it also times every GL variant (fragment / compute x log-step /
// one-step) and makes the fastest the pool's preferred variant, used by
// requests that name none. A software rasteriser is not timed (auto never
// picks it). horizond runs this at start: about a second on a hardware GPU.
#pragma once

#include <cstdint>
#include <vector>

#include "horizon/common/error.hpp"
#include "horizon/gpu/context_pool.hpp"

namespace horizon::gpu {

struct CalibrationPoint {
  std::uint64_t cells = 0;
  double cpu_seconds = 0, gpu_seconds = 0;  // medians
};

struct VariantTime {
  visibility::GpuOptions variant;
  double seconds = 0;  // median, at the largest size timed
};

struct Calibration {
  std::vector<CalibrationPoint> points;  // empty for a software rasteriser
  std::vector<VariantTime> variants;     // likewise
  visibility::GpuOptions preferred;      // the fastest variant, set on the pool
  // Set on the pool: the smallest timed size from which the GPU stayed
  // faster; UINT64_MAX when it never was (auto then always uses the CPU).
  std::uint64_t crossover_cells = UINT64_MAX;
};

struct CalibrationOptions {
  unsigned threads = 0;     // the CPU sweep's threads, as requests will use them (0 = all cores)
  int max_side = 2048;      // largest terrain side timed (sides 128, 256, ... up to it)
  bool time_software = false;  // time a software rasteriser too (tests; auto still never picks it)
};

Result<Calibration> calibrate(ContextPool& pool, const CalibrationOptions& options = {});

}  // namespace horizon::gpu
