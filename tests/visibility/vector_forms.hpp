// Test helper for the radial sweep's kernels (core/src/visibility/simd.hpp):
// runs a check once per vector form this CPU has, with the kernels capped at
// that form, so that AVX2 is tested on an AVX-512 machine too.
#pragma once

#include <gtest/gtest.h>

#include <string>

#include "simd.hpp"

namespace horizon::visibility::sweep {

inline const char* isa_name(simd::Isa isa) {
  switch (isa) {
    case simd::Isa::kAvx512:
      return "AVX-512";
    case simd::Isa::kAvx2:
      return "AVX2";
    default:
      return "scalar";
  }
}

// Calls check() under each vector form the CPU runs (AVX2, AVX-512); returns
// how many ran. The cap is lifted again afterwards, even when check() fails.
template <class Check>
int for_each_vector_form(Check check) {
  struct Restore {
    ~Restore() { simd::isa_limit() = simd::Isa::kAvx512; }
  } restore;
  int ran = 0;
  for (const simd::Isa isa : {simd::Isa::kAvx2, simd::Isa::kAvx512}) {
    if (simd::cpu_isa() < isa) continue;
    simd::isa_limit() = isa;
    SCOPED_TRACE(std::string("kernels capped at ") + isa_name(isa));
    check();
    ++ran;
    if (::testing::Test::HasFatalFailure()) break;
  }
  return ran;
}

}  // namespace horizon::visibility::sweep
