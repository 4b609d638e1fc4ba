// horizon/common/kernels.hpp — which SIMD kernels the engine runs.
//
// The engine's vector kernels (the fast sweep's ray steps and cell
// resampling, the TIN cull's lanes) come in three forms: plain loops, AVX2
// (8 lanes) and AVX-512F (16 lanes). Each call runs the best form the CPU
// has. Every vector form gives its scalar twin's answer bit for bit, so the
// choice changes only the time.
//
// A process may cap the forms lower, e.g. `horizon viewshed --isa avx2`:
// to time the AVX2 forms on an AVX-512 machine (the CPUs users run differ),
// or to keep cores off AVX-512 where it lowers their clock. The cap is
// process-wide and may be changed at any time; calls already running finish
// with the forms they began with.
#pragma once

#include <optional>
#include <string_view>

namespace horizon {

enum class KernelSet { kScalar = 0, kAvx2 = 1, kAvx512 = 2 };

// "scalar", "avx2", "avx512".
std::string_view kernel_set_name(KernelSet set);
// The set a name spells (as kernel_set_name writes it); nullopt otherwise.
std::optional<KernelSet> parse_kernel_set(std::string_view name);

// The best set this CPU runs (scalar on a CPU without AVX2, or a build for
// another architecture).
KernelSet cpu_kernel_set();
// What the kernels run now: the CPU's best, capped.
KernelSet kernel_set();
// Caps every later kernel call at `ceiling` (kAvx512: no cap).
void limit_kernel_set(KernelSet ceiling);

}  // namespace horizon
