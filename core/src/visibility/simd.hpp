// Private to the radial sweep: the AVX2 vocabulary its kernels share.
//
// The kernels must give the scalar loops' bits, so these helpers reproduce
// the scalar operations exactly, NaN and ties included: min_of(a, b) is
// std::min(a, b) (`b < a ? b : a`), max_of(a, b) is std::max(a, b)
// (`a < b ? b : a`). No helper fuses a multiply and an add. Functions using
// AVX2 carry HORIZON_AVX2 and run only when has_avx2() says so; the rest of
// the engine is built for baseline x86-64 (or any other architecture, where
// HORIZON_SIMD_AVX2 is not defined and only the scalar loops exist).
#pragma once

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#define HORIZON_SIMD_AVX2 1
#define HORIZON_AVX2 __attribute__((target("avx2")))
#endif

#include "sweep_samples.hpp"

namespace horizon::visibility::sweep::simd {

#ifdef HORIZON_SIMD_AVX2

inline bool has_avx2() {
  static const bool avx2 = __builtin_cpu_supports("avx2");
  return avx2;
}

HORIZON_AVX2 inline __m256 f8(float x) {
  return _mm256_set1_ps(x);
}
HORIZON_AVX2 inline __m256i i8(int x) {
  return _mm256_set1_epi32(x);
}
HORIZON_AVX2 inline __m256 min_of(__m256 a, __m256 b) {
  return _mm256_min_ps(b, a);
}
HORIZON_AVX2 inline __m256 max_of(__m256 a, __m256 b) {
  return _mm256_max_ps(b, a);
}
HORIZON_AVX2 inline __m256i mini_of(__m256i a, __m256i b) {
  return _mm256_min_epi32(a, b);
}
HORIZON_AVX2 inline __m256i maxi_of(__m256i a, __m256i b) {
  return _mm256_max_epi32(a, b);
}

// eye_relative(a, b, t, eye_hi, eye_lo), lane by lane.
HORIZON_AVX2 inline __m256 eye_relative8(__m256 a, __m256 b, __m256 t, __m256 eye_hi, __m256 eye_lo) {
  return _mm256_add_ps(_mm256_sub_ps(_mm256_sub_ps(a, eye_hi), eye_lo), _mm256_mul_ps(t, _mm256_sub_ps(b, a)));
}

// base[index] for the lanes of `mask` (sign bits), 0 elsewhere; the others are not read.
HORIZON_AVX2 inline __m256 gather_masked(const float* base, __m256i index, __m256 mask) {
  return _mm256_mask_i32gather_ps(_mm256_setzero_ps(), base, index, mask, 4);
}

#else

inline bool has_avx2() {
  return false;
}

#endif

}  // namespace horizon::visibility::sweep::simd
