#include "ray_steps.hpp"

#include <algorithm>
#include <cmath>

#include "simd.hpp"

namespace horizon::visibility::sweep {

// Every value is computed for every ray and selected at the end: branch-free.
void step_cross_scalar(const LineStep& ls, int count, const float* __restrict slope, const float* __restrict inv_slope,
                       const float* __restrict curv_k, const float* __restrict prev, const float* __restrict cur,
                       const float* __restrict h, const int* __restrict arg, float* __restrict cross_slope,
                       int* __restrict cross_v, int* __restrict code) {
  const float eye_v = ls.eye_v, k_start = ls.k_start, kf = ls.kf, v_min = ls.v_min, v_max = ls.v_max, kp = ls.kp,
              eye = ls.eye, eye_lo = ls.eye_lo;
  const int zv = ls.zv;
  for (int i = 0; i < count; ++i) {
    const float m = slope[i];
    const float v_start = eye_v + m * k_start, v_end = eye_v + m * kf;
    const float up = std::floor(v_start) + 1.0f, down = std::ceil(v_start) - 1.0f;
    const float cv = m > 0.0f ? up : down;
    // Integer masks rather than && / ||, which would become branches.
    const int crosses = (int(m > 0.0f) & int(up < v_end)) | (int(m < 0.0f) & int(down > v_end));
    const int valid = crosses & int(cv >= v_min) & int(cv <= v_max);
    const float cv_clamped = std::min(std::max(cv, v_min), v_max);  // a readable line even when not valid
    const int jc = static_cast<int>(cv_clamped);
    const float kc = std::max((cv_clamped - eye_v) * inv_slope[i], 1.0e-6f);
    const float tc = kc - kp;
    const float pa = prev[jc * zv], pb = cur[jc * zv];
    const float s_cross = eye_relative(pa, pb, tc, eye, eye_lo) / kc - curv_k[i] * kc;
    const float best = std::min(s_cross, valid ? 3.0e38f : kNoHorizon);
    const int v = (jc + 1) * valid - 1;
    cross_slope[i] = best;
    cross_v[i] = v;
    code[i] = best > h[i] ? -2 - v : arg[i];
  }
}

// `x > best ? x : best` keeps best when x is NaN.
void step_line_scalar(const LineStep& ls, int count, const float* __restrict slope, const float* __restrict curv_k,
                      const float* __restrict cur, const float* __restrict cross_slope, const int* __restrict cross_v,
                      float* __restrict h, int* __restrict arg, int n) {
  const float inv_kf = 1.0f / ls.kf;
  for (int i = 0; i < count; ++i) {
    const float v = std::min(std::max(ls.eye_v + slope[i] * ls.kf, ls.v_min), ls.v_max);
    const int j0 = std::min(static_cast<int>(v), ls.j_max);
    const float t = v - static_cast<float>(j0);
    const float a = cur[j0 * ls.zv], b = cur[(j0 + 1) * ls.zv];
    const float s_line = eye_relative(a, b, t, ls.eye, ls.eye_lo) * inv_kf - curv_k[i] * ls.kf;
    float best = h[i];
    int where = arg[i];
    where = cross_slope[i] > best ? -2 - cross_v[i] : where;
    best = cross_slope[i] > best ? cross_slope[i] : best;
    where = s_line > best ? n : where;
    best = s_line > best ? s_line : best;
    h[i] = best;
    arg[i] = where;
  }
}

#ifdef HORIZON_SIMD_AVX2
namespace {

// Eight rays per iteration, lane for lane the scalar loop's operations
// (simd.hpp gives std::min / std::max's exact NaN and tie behaviour); the
// last, partial group runs through the scalar loop.
HORIZON_AVX2 int step_cross_avx2(const LineStep& ls, int count, const float* slope, const float* inv_slope,
                                 const float* curv_k, const float* prev, const float* cur, const float* h,
                                 const int* arg, float* cross_slope, int* cross_v, int* code) {
  using namespace simd;
  const __m256 eye_v = f8(ls.eye_v), k_start = f8(ls.k_start), kf = f8(ls.kf), v_min = f8(ls.v_min),
               v_max = f8(ls.v_max), kp = f8(ls.kp), eye = f8(ls.eye), eye_lo = f8(ls.eye_lo), zero = f8(0.0f),
               one = f8(1.0f);
  const __m256i zv = i8(ls.zv);
  int i = 0;
  for (; i + 8 <= count; i += 8) {
    const __m256 m = _mm256_loadu_ps(slope + i);
    const __m256 v_start = _mm256_add_ps(eye_v, _mm256_mul_ps(m, k_start));
    const __m256 v_end = _mm256_add_ps(eye_v, _mm256_mul_ps(m, kf));
    const __m256 up = _mm256_add_ps(_mm256_floor_ps(v_start), one);
    const __m256 down = _mm256_sub_ps(_mm256_ceil_ps(v_start), one);
    const __m256 rising = _mm256_cmp_ps(m, zero, _CMP_GT_OQ);
    const __m256 cv = _mm256_blendv_ps(down, up, rising);
    const __m256 crosses =
        _mm256_or_ps(_mm256_and_ps(rising, _mm256_cmp_ps(up, v_end, _CMP_LT_OQ)),
                     _mm256_and_ps(_mm256_cmp_ps(m, zero, _CMP_LT_OQ), _mm256_cmp_ps(down, v_end, _CMP_GT_OQ)));
    const __m256 valid = _mm256_and_ps(
        crosses, _mm256_and_ps(_mm256_cmp_ps(cv, v_min, _CMP_GE_OQ), _mm256_cmp_ps(cv, v_max, _CMP_LE_OQ)));
    const __m256 cv_clamped = min_of(max_of(cv, v_min), v_max);
    const __m256i jc = _mm256_cvttps_epi32(cv_clamped);
    const __m256 kc =
        max_of(_mm256_mul_ps(_mm256_sub_ps(cv_clamped, eye_v), _mm256_loadu_ps(inv_slope + i)), f8(1.0e-6f));
    const __m256 tc = _mm256_sub_ps(kc, kp);
    const __m256i at = _mm256_mullo_epi32(jc, zv);
    const __m256 pa = _mm256_i32gather_ps(prev, at, 4), pb = _mm256_i32gather_ps(cur, at, 4);
    const __m256 s_cross = _mm256_sub_ps(_mm256_div_ps(eye_relative8(pa, pb, tc, eye, eye_lo), kc),
                                         _mm256_mul_ps(_mm256_loadu_ps(curv_k + i), kc));
    const __m256 best = min_of(s_cross, _mm256_blendv_ps(f8(kNoHorizon), f8(3.0e38f), valid));
    const __m256i v = _mm256_blendv_epi8(i8(-1), jc, _mm256_castps_si256(valid));
    _mm256_storeu_ps(cross_slope + i, best);
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(cross_v + i), v);
    const __m256 wins = _mm256_cmp_ps(best, _mm256_loadu_ps(h + i), _CMP_GT_OQ);
    const __m256i kept = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(arg + i));
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(code + i),
                        _mm256_blendv_epi8(kept, _mm256_sub_epi32(i8(-2), v), _mm256_castps_si256(wins)));
  }
  return i;
}

HORIZON_AVX2 int step_line_avx2(const LineStep& ls, int count, const float* slope, const float* curv_k,
                                const float* cur, const float* cross_slope, const int* cross_v, float* h, int* arg,
                                int n) {
  using namespace simd;
  const float inv_kf_scalar = 1.0f / ls.kf;
  const __m256 inv_kf = f8(inv_kf_scalar), kf = f8(ls.kf), eye_v = f8(ls.eye_v), v_min = f8(ls.v_min),
               v_max = f8(ls.v_max), eye = f8(ls.eye), eye_lo = f8(ls.eye_lo);
  const __m256i zv = i8(ls.zv), j_max = i8(ls.j_max), line = i8(n), minus_two = i8(-2);
  int i = 0;
  for (; i + 8 <= count; i += 8) {
    const __m256 v = min_of(max_of(_mm256_add_ps(eye_v, _mm256_mul_ps(_mm256_loadu_ps(slope + i), kf)), v_min), v_max);
    const __m256i j0 = mini_of(_mm256_cvttps_epi32(v), j_max);
    const __m256 t = _mm256_sub_ps(v, _mm256_cvtepi32_ps(j0));
    const __m256i at = _mm256_mullo_epi32(j0, zv);
    const __m256 a = _mm256_i32gather_ps(cur, at, 4), b = _mm256_i32gather_ps(cur, _mm256_add_epi32(at, zv), 4);
    const __m256 s_line = _mm256_sub_ps(_mm256_mul_ps(eye_relative8(a, b, t, eye, eye_lo), inv_kf),
                                        _mm256_mul_ps(_mm256_loadu_ps(curv_k + i), kf));
    __m256 best = _mm256_loadu_ps(h + i);
    __m256i where = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(arg + i));
    const __m256 cs = _mm256_loadu_ps(cross_slope + i);
    const __m256 cross_wins = _mm256_cmp_ps(cs, best, _CMP_GT_OQ);
    const __m256i cross_where =
        _mm256_sub_epi32(minus_two, _mm256_loadu_si256(reinterpret_cast<const __m256i*>(cross_v + i)));
    where = _mm256_blendv_epi8(where, cross_where, _mm256_castps_si256(cross_wins));
    best = _mm256_blendv_ps(best, cs, cross_wins);
    const __m256 line_wins = _mm256_cmp_ps(s_line, best, _CMP_GT_OQ);
    where = _mm256_blendv_epi8(where, line, _mm256_castps_si256(line_wins));
    best = _mm256_blendv_ps(best, s_line, line_wins);
    _mm256_storeu_ps(h + i, best);
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(arg + i), where);
  }
  return i;
}

// The same two loops sixteen rays at a time with AVX-512: lane for lane the
// AVX2 kernels' operations, with mask registers for the comparisons. The
// last, partial group runs masked: its absent lanes read and write nothing.
HORIZON_AVX512 void step_cross_avx512(const LineStep& ls, int count, const float* slope, const float* inv_slope,
                                      const float* curv_k, const float* prev, const float* cur, const float* h,
                                      const int* arg, float* cross_slope, int* cross_v, int* code) {
  using namespace simd;
  const __m512 eye_v = f16(ls.eye_v), k_start = f16(ls.k_start), kf = f16(ls.kf), v_min = f16(ls.v_min),
               v_max = f16(ls.v_max), kp = f16(ls.kp), eye = f16(ls.eye), eye_lo = f16(ls.eye_lo), zero = f16(0.0f),
               one = f16(1.0f);
  const __m512i zv = i16(ls.zv);
  for (int i = 0; i < count; i += 16) {
    const __mmask16 in = count - i >= 16 ? __mmask16(0xffff) : __mmask16((1u << (count - i)) - 1);
    const __m512 m = _mm512_maskz_loadu_ps(in, slope + i);
    const __m512 v_start = _mm512_add_ps(eye_v, _mm512_mul_ps(m, k_start));
    const __m512 v_end = _mm512_add_ps(eye_v, _mm512_mul_ps(m, kf));
    const __m512 up = _mm512_add_ps(floor16(v_start), one);
    const __m512 down = _mm512_sub_ps(ceil16(v_start), one);
    const __mmask16 rising = _mm512_cmp_ps_mask(m, zero, _CMP_GT_OQ);
    const __m512 cv = _mm512_mask_blend_ps(rising, down, up);
    const __mmask16 crosses = (rising & _mm512_cmp_ps_mask(up, v_end, _CMP_LT_OQ)) |
                              (_mm512_cmp_ps_mask(m, zero, _CMP_LT_OQ) & _mm512_cmp_ps_mask(down, v_end, _CMP_GT_OQ));
    const __mmask16 valid =
        crosses & _mm512_cmp_ps_mask(cv, v_min, _CMP_GE_OQ) & _mm512_cmp_ps_mask(cv, v_max, _CMP_LE_OQ);
    const __m512 cv_clamped = min_of(max_of(cv, v_min), v_max);
    const __m512i jc = _mm512_cvttps_epi32(cv_clamped);
    const __m512 kc =
        max_of(_mm512_mul_ps(_mm512_sub_ps(cv_clamped, eye_v), _mm512_maskz_loadu_ps(in, inv_slope + i)), f16(1.0e-6f));
    const __m512 tc = _mm512_sub_ps(kc, kp);
    const __m512i at = _mm512_mullo_epi32(jc, zv);
    const __m512 pa = gather_masked(prev, at, in), pb = gather_masked(cur, at, in);
    const __m512 s_cross = _mm512_sub_ps(_mm512_div_ps(eye_relative16(pa, pb, tc, eye, eye_lo), kc),
                                         _mm512_mul_ps(_mm512_maskz_loadu_ps(in, curv_k + i), kc));
    const __m512 best = min_of(s_cross, _mm512_mask_blend_ps(valid, f16(kNoHorizon), f16(3.0e38f)));
    const __m512i v = _mm512_mask_blend_epi32(valid, i16(-1), jc);
    _mm512_mask_storeu_ps(cross_slope + i, in, best);
    _mm512_mask_storeu_epi32(cross_v + i, in, v);
    const __mmask16 wins = _mm512_cmp_ps_mask(best, _mm512_maskz_loadu_ps(in, h + i), _CMP_GT_OQ);
    const __m512i kept = _mm512_maskz_loadu_epi32(in, arg + i);
    _mm512_mask_storeu_epi32(code + i, in, _mm512_mask_blend_epi32(wins, kept, _mm512_sub_epi32(i16(-2), v)));
  }
}

HORIZON_AVX512 void step_line_avx512(const LineStep& ls, int count, const float* slope, const float* curv_k,
                                     const float* cur, const float* cross_slope, const int* cross_v, float* h, int* arg,
                                     int n) {
  using namespace simd;
  const float inv_kf_scalar = 1.0f / ls.kf;
  const __m512 inv_kf = f16(inv_kf_scalar), kf = f16(ls.kf), eye_v = f16(ls.eye_v), v_min = f16(ls.v_min),
               v_max = f16(ls.v_max), eye = f16(ls.eye), eye_lo = f16(ls.eye_lo);
  const __m512i zv = i16(ls.zv), j_max = i16(ls.j_max), line = i16(n), minus_two = i16(-2);
  for (int i = 0; i < count; i += 16) {
    const __mmask16 in = count - i >= 16 ? __mmask16(0xffff) : __mmask16((1u << (count - i)) - 1);
    const __m512 v =
        min_of(max_of(_mm512_add_ps(eye_v, _mm512_mul_ps(_mm512_maskz_loadu_ps(in, slope + i), kf)), v_min), v_max);
    const __m512i j0 = mini_of(_mm512_cvttps_epi32(v), j_max);
    const __m512 t = _mm512_sub_ps(v, _mm512_cvtepi32_ps(j0));
    const __m512i at = _mm512_mullo_epi32(j0, zv);
    const __m512 a = gather_masked(cur, at, in), b = gather_masked(cur, _mm512_add_epi32(at, zv), in);
    const __m512 s_line = _mm512_sub_ps(_mm512_mul_ps(eye_relative16(a, b, t, eye, eye_lo), inv_kf),
                                        _mm512_mul_ps(_mm512_maskz_loadu_ps(in, curv_k + i), kf));
    __m512 best = _mm512_maskz_loadu_ps(in, h + i);
    __m512i where = _mm512_maskz_loadu_epi32(in, arg + i);
    const __m512 cs = _mm512_maskz_loadu_ps(in, cross_slope + i);
    const __mmask16 cross_wins = _mm512_cmp_ps_mask(cs, best, _CMP_GT_OQ);
    where = _mm512_mask_blend_epi32(cross_wins, where,
                                    _mm512_sub_epi32(minus_two, _mm512_maskz_loadu_epi32(in, cross_v + i)));
    best = _mm512_mask_blend_ps(cross_wins, best, cs);
    const __mmask16 line_wins = _mm512_cmp_ps_mask(s_line, best, _CMP_GT_OQ);
    where = _mm512_mask_blend_epi32(line_wins, where, line);
    best = _mm512_mask_blend_ps(line_wins, best, s_line);
    _mm512_mask_storeu_ps(h + i, in, best);
    _mm512_mask_storeu_epi32(arg + i, in, where);
  }
}

}  // namespace
#endif

void step_cross(const LineStep& ls, int count, const float* slope, const float* inv_slope, const float* curv_k,
                const float* prev, const float* cur, const float* h, const int* arg, float* cross_slope, int* cross_v,
                int* code) {
  // AVX-512 takes every ray; AVX2 groups of eight, then one by one.
#ifdef HORIZON_SIMD_AVX2
  if (simd::has_avx512()) {
    step_cross_avx512(ls, count, slope, inv_slope, curv_k, prev, cur, h, arg, cross_slope, cross_v, code);
    return;
  }
#endif
  int done = 0;
#ifdef HORIZON_SIMD_AVX2
  if (simd::has_avx2())
    done = step_cross_avx2(ls, count, slope, inv_slope, curv_k, prev, cur, h, arg, cross_slope, cross_v, code);
#endif
  step_cross_scalar(ls, count - done, slope + done, inv_slope + done, curv_k + done, prev, cur, h + done, arg + done,
                    cross_slope + done, cross_v + done, code + done);
}

void step_line(const LineStep& ls, int count, const float* slope, const float* curv_k, const float* cur,
               const float* cross_slope, const int* cross_v, float* h, int* arg, int n) {
#ifdef HORIZON_SIMD_AVX2
  if (simd::has_avx512()) {
    step_line_avx512(ls, count, slope, curv_k, cur, cross_slope, cross_v, h, arg, n);
    return;
  }
#endif
  int done = 0;
#ifdef HORIZON_SIMD_AVX2
  if (simd::has_avx2()) done = step_line_avx2(ls, count, slope, curv_k, cur, cross_slope, cross_v, h, arg, n);
#endif
  step_line_scalar(ls, count - done, slope + done, curv_k + done, cur, cross_slope + done, cross_v + done, h + done,
                   arg + done, n);
}

}  // namespace horizon::visibility::sweep
