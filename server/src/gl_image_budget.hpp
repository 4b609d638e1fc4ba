// gl_image_budget.hpp — the GL contexts' images inside memory_budget_mb.
//
// On a software rasteriser (Mesa's llvmpipe) every texture and buffer a GL
// context holds is the daemon's own memory, and a context keeps its images
// between requests (gpu/context_pool.hpp). The daemon hands the pool this
// gate: before GL code allocates images it takes their bytes from the
// budget, a refusal sends that request to the CPU (its gpu_fallback says
// why), and a context's kept images (at most kKeepBytes each) stay taken
// until freed. On a hardware GPU images live in the device's memory and no
// gate is set; kKeepBytes still caps what each context keeps there.
#pragma once

#include <atomic>
#include <cstdint>

#include "horizon/gpu/context_pool.hpp"
#include "memory_budget.hpp"
#include "metrics.hpp"

namespace horizon::server {

class GlImageBudget final : public gpu::ImageMemory {
 public:
  // Images one context keeps between requests.
  static constexpr std::uint64_t kKeepBytes = 64ull << 20;

  GlImageBudget(MemoryBudget& budget, Metrics& metrics) : budget_(budget), metrics_(metrics) {}

  bool take(std::uint64_t bytes) override {
    if (!budget_.try_take(bytes)) return false;
    metrics_.set_gpu_images(taken_.fetch_add(bytes) + bytes);
    metrics_.set_memory_reserved(budget_.reserved());
    return true;
  }
  void give(std::uint64_t bytes) override {
    budget_.give(bytes);
    metrics_.set_gpu_images(taken_.fetch_sub(bytes) - bytes);
    metrics_.set_memory_reserved(budget_.reserved());
  }
  // Bytes taken now (held by contexts, and by GL code running).
  std::uint64_t taken() const { return taken_.load(); }

 private:
  MemoryBudget& budget_;
  Metrics& metrics_;
  std::atomic<std::uint64_t> taken_{0};
};

}  // namespace horizon::server
