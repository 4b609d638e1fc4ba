// The public face of common/simd_isa.hpp (see horizon/common/kernels.hpp).
#include "horizon/common/kernels.hpp"

#include "simd_isa.hpp"

namespace horizon {
namespace {

static_assert(static_cast<int>(KernelSet::kScalar) == static_cast<int>(simd_isa::Isa::kScalar));
static_assert(static_cast<int>(KernelSet::kAvx2) == static_cast<int>(simd_isa::Isa::kAvx2));
static_assert(static_cast<int>(KernelSet::kAvx512) == static_cast<int>(simd_isa::Isa::kAvx512));

constexpr std::string_view kNames[] = {"scalar", "avx2", "avx512"};

}  // namespace

std::string_view kernel_set_name(KernelSet set) {
  return kNames[static_cast<int>(set)];
}

std::optional<KernelSet> parse_kernel_set(std::string_view name) {
  for (int i = 0; i < 3; ++i)
    if (name == kNames[i]) return static_cast<KernelSet>(i);
  return std::nullopt;
}

KernelSet cpu_kernel_set() {
  return static_cast<KernelSet>(simd_isa::cpu_isa());
}

KernelSet kernel_set() {
  return static_cast<KernelSet>(simd_isa::kernel_isa());
}

void limit_kernel_set(KernelSet ceiling) {
  simd_isa::isa_limit().store(static_cast<simd_isa::Isa>(ceiling), std::memory_order_relaxed);
}

}  // namespace horizon
