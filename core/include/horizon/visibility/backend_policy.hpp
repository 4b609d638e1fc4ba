// horizon/visibility/backend_policy.hpp — when the fast algorithm runs on the GPU, and which GL variant.
//
//   visibility::BackendPolicy policy;                       // the daemon owns one
//   auto measured = visibility::calibrate(*pool, policy, {.threads = 0});
//   auto vs = visibility::compute_viewshed(dem, eye, options, control, pool.get(), &policy);
//
// Engine policy, apart from the GPU contexts (gpu/context_pool.hpp lends
// contexts and knows nothing of viewsheds). Backend::kAuto sends a request to
// the GPU only when the policy prefers it: never on a software rasteriser
// (llvmpipe is 9-23x slower than the CPU sweep, docs/benchmarks.md), on a
// hardware GPU from the window size at which the GPU was measured faster
// than the CPU (the crossover), and never before a measurement. A request
// that names no GL variant (ViewshedOptions::gpu absent) runs the policy's
// preferred one: the fastest measured, fragment with log-step until then.
// compute_viewshed() without a policy behaves as with an unmeasured one.
//
// calibrate() finds both on this machine: it times the fast viewshed on the
// CPU and on the pool's GPU over synthetic terrain of growing size (128^2 ..
// 2048^2 cells, eye at the centre, the default knobs; median of 3 after a
// warm-up) and sets the crossover to the smallest size at which the GPU was
// faster there and at every larger size. At the largest size it first times
// every GL variant (fragment / compute x log-step / one-step) and makes the
// fastest the preferred one (the CPU is timed against it). A software
// rasteriser is not timed. horizond runs this at start: about a second on a
// hardware GPU.
//
// Thread-safe: requests read the policy while it may be set.
#pragma once

#include <cstdint>
#include <mutex>
#include <vector>

#include "horizon/common/error.hpp"
#include "horizon/gpu/context_pool.hpp"
#include "horizon/visibility/options.hpp"

namespace horizon::visibility {

class BackendPolicy {
 public:
  // Backend::kAuto: true when a request of `cells` window cells should run
  // on `device`: never a software one; a hardware one from the crossover on.
  bool prefers_gpu(const gpu::DeviceInfo& device, std::uint64_t cells) const;
  // The smallest window (cells) from which the GPU is preferred; UINT64_MAX
  // (the default) when never.
  std::uint64_t crossover_cells() const;
  void set_crossover_cells(std::uint64_t cells);
  // The GL variant of requests that name none.
  GpuOptions preferred_variant() const;
  void set_preferred_variant(const GpuOptions& variant);

 private:
  mutable std::mutex mutex_;
  std::uint64_t crossover_cells_ = UINT64_MAX;
  GpuOptions preferred_;
};

struct CalibrationPoint {
  std::uint64_t cells = 0;
  double cpu_seconds = 0, gpu_seconds = 0;  // medians
};

struct VariantTime {
  GpuOptions variant;
  double seconds = 0;  // median, at the largest size timed
};

struct Calibration {
  std::vector<CalibrationPoint> points;  // empty for a software rasteriser
  std::vector<VariantTime> variants;     // likewise
  GpuOptions preferred;                  // the fastest variant, set on the policy
  // Set on the policy: the smallest timed size from which the GPU stayed
  // faster; UINT64_MAX when it never was (auto then always uses the CPU).
  std::uint64_t crossover_cells = UINT64_MAX;
};

struct CalibrationOptions {
  unsigned threads = 0;        // the CPU sweep's threads, as requests will use them (0 = all cores)
  int max_side = 2048;         // largest terrain side timed (sides 128, 256, ... up to it)
  bool time_software = false;  // time a software rasteriser too (tests; auto still never picks it)
};

// Measures `pool`'s device against the CPU and sets `policy` from it.
Result<Calibration> calibrate(gpu::ContextPool& pool, BackendPolicy& policy, const CalibrationOptions& options = {});

}  // namespace horizon::visibility
