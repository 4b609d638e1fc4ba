// Private to core: the SIMD vocabulary the radial sweep's kernels (and the
// clip-map's sampler, clipmap/clipmap.cpp) share.
//
// Each kernel of the sweep has a scalar loop and, on x86-64, an AVX2 form
// (eight lanes) and an AVX-512 form (sixteen lanes, mask registers), chosen
// at run time by kernel_isa() (common/simd_isa.hpp, shared with the TIN
// cull). They must give the scalar loops' bits, so these helpers
// reproduce the scalar operations exactly, NaN and ties included:
// min_of(a, b) is std::min(a, b) (`b < a ? b : a`), max_of(a, b) is
// std::max(a, b) (`a < b ? b : a`). No helper fuses a multiply and an add,
// and the kernels' files are built with -ffp-contract=off, since AVX-512
// targets carry FMA and GCC would otherwise fuse a * b + c. Functions using
// AVX2 / AVX-512 carry HORIZON_AVX2 / HORIZON_AVX512; the rest of the engine
// is built for baseline x86-64 (or any other architecture, where
// HORIZON_SIMD_AVX2 is not defined and only the scalar loops exist).
#pragma once

#include "../common/simd_isa.hpp"  // Isa, cpu_isa, isa_limit, kernel_isa, HORIZON_AVX2 / HORIZON_AVX512
#include "sweep_samples.hpp"

namespace horizon::visibility::sweep::simd {

// The instruction-set choice is the engine's (common/simd_isa.hpp): one
// ceiling for every module's kernels.
using ::horizon::simd_isa::cpu_isa;
using ::horizon::simd_isa::Isa;
using ::horizon::simd_isa::isa_limit;
using ::horizon::simd_isa::kernel_isa;

#ifdef HORIZON_SIMD_AVX2

inline bool has_avx2() {
  return kernel_isa() >= Isa::kAvx2;
}

inline bool has_avx512() {
  return kernel_isa() >= Isa::kAvx512;
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

// Sixteen consecutive heights of one line, from which each lane takes the
// one at its offset: a gather's values where every lane reads near the
// others (along rows, where v is contiguous), for two loads and permutes.
struct Run8 {
  __m256 lo, hi;
};

HORIZON_AVX2 inline Run8 load_run8(const float* first) {
  return {_mm256_loadu_ps(first), _mm256_loadu_ps(first + 8)};
}

// run[offset] lane by lane, offset in [0, 16).
HORIZON_AVX2 inline __m256 pick8(const Run8& run, __m256i offset) {
  const __m256 upper = _mm256_castsi256_ps(_mm256_cmpgt_epi32(offset, _mm256_set1_epi32(7)));
  return _mm256_blendv_ps(_mm256_permutevar8x32_ps(run.lo, offset), _mm256_permutevar8x32_ps(run.hi, offset), upper);
}

// HeightView::fill lane by lane: voids (NaN) read as `fill` (itself NaN
// when voids are transparent).
HORIZON_AVX2 inline __m256 fill_voids(__m256 v, __m256 fill) {
  return _mm256_blendv_ps(v, fill, _mm256_cmp_ps(v, v, _CMP_UNORD_Q));
}

// The AVX-512 twins of the helpers above (sixteen lanes).
HORIZON_AVX512 inline __m512 f16(float x) {
  return _mm512_set1_ps(x);
}
HORIZON_AVX512 inline __m512i i16(int x) {
  return _mm512_set1_epi32(x);
}
HORIZON_AVX512 inline __m512 min_of(__m512 a, __m512 b) {
  return _mm512_min_ps(b, a);
}
HORIZON_AVX512 inline __m512 max_of(__m512 a, __m512 b) {
  return _mm512_max_ps(b, a);
}
HORIZON_AVX512 inline __m512i mini_of(__m512i a, __m512i b) {
  return _mm512_min_epi32(a, b);
}
HORIZON_AVX512 inline __m512i maxi_of(__m512i a, __m512i b) {
  return _mm512_max_epi32(a, b);
}
HORIZON_AVX512 inline __m512 eye_relative16(__m512 a, __m512 b, __m512 t, __m512 eye_hi, __m512 eye_lo) {
  return _mm512_add_ps(_mm512_sub_ps(_mm512_sub_ps(a, eye_hi), eye_lo), _mm512_mul_ps(t, _mm512_sub_ps(b, a)));
}
// floor / ceil as _mm256_floor_ps / _mm256_ceil_ps round.
HORIZON_AVX512 inline __m512 floor16(__m512 x) {
  return _mm512_roundscale_ps(x, _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC);
}
HORIZON_AVX512 inline __m512 ceil16(__m512 x) {
  return _mm512_roundscale_ps(x, _MM_FROUND_TO_POS_INF | _MM_FROUND_NO_EXC);
}
// base[index] for the lanes of `mask`, 0 elsewhere; the others are not read.
HORIZON_AVX512 inline __m512 gather_masked(const float* base, __m512i index, __mmask16 mask) {
  return _mm512_mask_i32gather_ps(_mm512_setzero_ps(), mask, index, base, 4);
}
// Run8 for sixteen lanes: thirty-two consecutive heights, one two-register
// permute per pick (offset in [0, 32)).
struct Run16 {
  __m512 lo, hi;
};
HORIZON_AVX512 inline Run16 load_run16(const float* first) {
  return {_mm512_loadu_ps(first), _mm512_loadu_ps(first + 16)};
}
HORIZON_AVX512 inline __m512 pick16(const Run16& run, __m512i offset) {
  return _mm512_permutex2var_ps(run.lo, offset, run.hi);
}
HORIZON_AVX512 inline __m512 fill_voids(__m512 v, __m512 fill) {
  return _mm512_mask_blend_ps(_mm512_cmp_ps_mask(v, v, _CMP_UNORD_Q), v, fill);
}

#else

inline bool has_avx2() {
  return false;
}

inline bool has_avx512() {
  return false;
}

#endif

}  // namespace horizon::visibility::sweep::simd
