// Private to the engine: which SIMD instruction set the kernels run, chosen
// once at run time, shared by every module that has vector kernels (the
// radial sweep's, visibility/simd.hpp, which re-exports these names; the
// TIN cull's, mesh/cull_lanes.hpp).
//
// The engine is built for baseline x86-64 (or any other architecture,
// where HORIZON_SIMD_AVX2 is not defined and only the scalar loops exist).
// A function that uses AVX2 carries HORIZON_AVX2, one that uses AVX-512F
// HORIZON_AVX512, and is called only when kernel_isa() allows it. Every
// vector form must give its scalar twin's bits; the files holding them are
// built with -ffp-contract=off (core/CMakeLists.txt), since AVX-512
// targets carry FMA and GCC would otherwise fuse a * b + c.
#pragma once

#include <atomic>

#if defined(__x86_64__) && defined(__GNUC__)
// GCC 12's AVX-512 headers trip -W(maybe-)uninitialized on their own
// _mm512_undefined_* placeholders (GCC bug 105593, fixed in GCC 13).
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#pragma GCC diagnostic ignored "-Wuninitialized"
#include <immintrin.h>
#pragma GCC diagnostic pop
#define HORIZON_SIMD_AVX2 1
#define HORIZON_AVX2 __attribute__((target("avx2")))
#define HORIZON_AVX512 __attribute__((target("avx2,avx512f")))
#endif

namespace horizon::simd_isa {

// The instruction sets a kernel may use, in increasing order.
enum class Isa { kScalar = 0, kAvx2 = 1, kAvx512 = 2 };

// The best the CPU runs (AVX-512 means AVX-512F).
inline Isa cpu_isa() {
#ifdef HORIZON_SIMD_AVX2
  static const Isa isa = __builtin_cpu_supports("avx512f") ? Isa::kAvx512
                         : __builtin_cpu_supports("avx2")  ? Isa::kAvx2
                                                           : Isa::kScalar;
  return isa;
#else
  return Isa::kScalar;
#endif
}

// A process-wide ceiling on the kernels' instruction set, for the tests
// (every form against the scalar loop) and benchmarks (one form against
// another in the same run). Default: none.
inline std::atomic<Isa>& isa_limit() {
  static std::atomic<Isa> limit{Isa::kAvx512};
  return limit;
}

// What the kernels use: the CPU's best, capped by isa_limit().
inline Isa kernel_isa() {
  const Isa limit = isa_limit().load(std::memory_order_relaxed);
  return cpu_isa() < limit ? cpu_isa() : limit;
}

}  // namespace horizon::simd_isa
