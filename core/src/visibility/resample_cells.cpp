#include "resample_cells.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "horizon/visibility/viewshed.hpp"  // min_target_height_at, kVisible, kHidden, kNoAnswer
#include "simd.hpp"

namespace horizon::visibility::sweep {
namespace {

// OHF = eye + d * (slope per metre) + curvature d^2, and d * slope = k * sigma.
inline float occlusion_height(const ResampleLine& L, float best, int j) {
  if (!(best > 0.5 * kNoHorizon)) return -std::numeric_limits<float>::infinity();
  const double dv = (j - L.eye_v) * L.metres_v;
  const double d2 = L.du2 + dv * dv;
  return static_cast<float>(L.eye + L.k * static_cast<double>(best) + L.curvature * d2);
}

// Whether put() codes a cell of this height hidden (ground not void).
inline bool hidden(const ResampleLine& L, float height, float ground) {
  return !std::isnan(height) && !(L.target_height >= min_target_height_at(height, ground));
}

// The cell's result: its height, or (L.mask) its code at the target height
// by visibility_mask()'s rule, a void target or no height first.
inline void put(const ResampleLine& L, int j, float height, float ground) {
  if (!L.mask) {
    L.out[j * L.o_v] = height;
    return;
  }
  std::uint8_t code = kNoAnswer;
  if (!std::isnan(ground) && !std::isnan(height))
    code = L.target_height >= min_target_height_at(height, ground) ? kVisible : kHidden;
  L.mask[j * L.o_v] = code;
  *L.visible += code == kVisible;
}

}  // namespace

std::uint64_t resample_cells_scalar(const ResampleLine& L, int j_begin, int j_end) {
  const CellLine& cl = *L.cells;
  std::uint64_t written = 0;
  for (int j = j_begin; j <= j_end; ++j) {
    const float zc = fill_void(L.elevation[j * cl.zv], cl.s->fill);
    if (std::isnan(zc)) {  // void target: no answer
      put(L, j, std::numeric_limits<float>::quiet_NaN(), zc);
      continue;
    }
    // Rays are evenly spaced: ray r has slope r / ray_half, so the cell's
    // own slope m sits at ray coordinate rho = m * ray_half.
    const double rho = (j - L.eye_v) * L.inv_k * L.ray_half;
    const int r = std::clamp(static_cast<int>(std::floor(rho)), -L.ray_half, L.ray_half - 1);
    const int i0 = (r - L.ra) >> L.level;  // the bracketing rays are i0 and i0 + 1
    const int a0 = L.code[i0], a1 = L.code[i0 + 1];
    // `x > best ? x : best`: a void (NaN) sample never wins.
    const CellRay cr = cell_ray(cl, j);
    float best = kNoHorizon;
    auto take = [&best](float x) { best = x > best ? x : best; };
    if (L.mask) {
      // A code: when the first candidate alone hides the cell, the others
      // could only hide it more (see the header).
      if (a0 != L.n - 1) take(sample_at(cl, cr, a0));
      const float height = occlusion_height(L, best, j);
      if (hidden(L, height, zc)) {
        put(L, j, height, zc);
        ++written;
        continue;
      }
      if (L.n > 0) take(sample_u(cl, cr, L.n - 1));
    } else {
      if (L.n > 0) take(sample_u(cl, cr, L.n - 1));
      if (a0 != L.n - 1) take(sample_at(cl, cr, a0));
    }
    if (a1 != a0 && a1 != L.n - 1) take(sample_at(cl, cr, a1));
    put(L, j, occlusion_height(L, best, j), zc);
    ++written;
  }
  return written;
}

#ifdef HORIZON_SIMD_AVX2
namespace {

// The AVX2 kernel: eight cells per iteration, each lane computing exactly
// what resample_cells_scalar computes for its cell (same operations in the
// same order, no fused multiply-add), with the scalar kernel's branches
// turned into masks: a candidate the scalar kernel skips (a0 == n - 1, or
// a1 == a0 or n - 1: already taken) becomes "none" (-1) in its lane, and a
// kind of sample no lane needs is not computed at all (neighbouring cells
// mostly share their candidates, so the second one is often skipped whole).
// Gathers read only the lanes a mask enables, so a lane never touches memory
// its scalar twin would not.

// std::clamp as the scalar kernel spells it: std::min(std::max(x, lo), hi).
HORIZON_AVX2 inline __m256 clamp8(__m256 x, __m256 lo, __m256 hi) {
  return simd::min_of(simd::max_of(x, lo), hi);
}
HORIZON_AVX2 inline __m256i clampi8(__m256i x, __m256i lo, __m256i hi) {
  return simd::mini_of(simd::maxi_of(x, lo), hi);
}

// sample_u on the u line at step `step` (per lane), for the lanes of `mask`;
// inv_step holds 1 / step per lane (L.inv_step[step], gathered or, for one
// step in every lane, broadcast).
HORIZON_AVX2 __attribute__((always_inline)) inline __m256 sample_u8(const CellLine& L, __m256 m, __m256 curv_k,
                                                                    __m256i step, __m256 mask, __m256 inv_step) {
  using namespace simd;
  const __m256 kn = _mm256_add_ps(f8(L.k0), _mm256_cvtepi32_ps(step));
  const __m256 v = clamp8(_mm256_add_ps(f8(L.eye_v), _mm256_mul_ps(m, kn)), f8(L.v_min), f8(L.v_max));
  const __m256i j0 = _mm256_min_epi32(_mm256_cvttps_epi32(v), i8(L.j_max));
  const __m256 t = _mm256_sub_ps(v, _mm256_cvtepi32_ps(j0));
  const __m256i line = _mm256_add_epi32(i8(L.line0), _mm256_mullo_epi32(i8(L.dir), step));
  const __m256i ia =
      _mm256_add_epi32(_mm256_mullo_epi32(line, i8(static_cast<int>(L.z_line))), _mm256_mullo_epi32(j0, i8(L.zv)));
  const __m256i ib = _mm256_add_epi32(ia, i8(L.zv));
  const __m256 fill = f8(L.s->fill);
  const __m256 a = fill_voids(gather_masked(L.s->z, ia, mask), fill);
  const __m256 b = fill_voids(gather_masked(L.s->z, ib, mask), fill);
  const __m256 er = eye_relative8(a, b, t, f8(L.eye), f8(L.eye_lo));
  return _mm256_sub_ps(_mm256_mul_ps(er, inv_step), _mm256_mul_ps(curv_k, kn));
}

// sample_at(L, cell, code) per lane of `lanes`: the u line, the v line, or
// kNoHorizon. A kind of line no lane needs is skipped.
HORIZON_AVX2 __attribute__((always_inline)) inline __m256 sample_at8(const CellLine& L, __m256 lanes, __m256i j,
                                                                     __m256 m, __m256 inv_m, __m256 curv_k,
                                                                     __m256i code) {
  using namespace simd;
  const __m256 none = f8(kNoHorizon);
  // u lines: code >= 0.
  const __m256 on_u = _mm256_and_ps(lanes, _mm256_castsi256_ps(_mm256_cmpgt_epi32(code, i8(-1))));
  const __m256i step = _mm256_max_epi32(code, i8(0));
  const __m256 su =
      _mm256_movemask_ps(on_u) == 0 ? none : sample_u8(L, m, curv_k, step, on_u, gather_masked(L.inv_step, step, on_u));
  // v lines: code <= -2, vline = -2 - code, not the cell's own, crossed strictly before the cell.
  const __m256i vline = _mm256_sub_epi32(i8(-2), code);
  __m256 on_v = _mm256_and_ps(lanes, _mm256_castsi256_ps(_mm256_cmpgt_epi32(i8(-1), code)));
  if (_mm256_movemask_ps(on_v) == 0) return _mm256_blendv_ps(none, su, on_u);
  on_v = _mm256_and_ps(on_v, _mm256_cmp_ps(inv_m, _mm256_setzero_ps(), _CMP_NEQ_OQ));
  on_v = _mm256_andnot_ps(_mm256_castsi256_ps(_mm256_cmpeq_epi32(vline, j)), on_v);
  const __m256 kc = _mm256_mul_ps(_mm256_sub_ps(_mm256_cvtepi32_ps(vline), f8(L.eye_v)), inv_m);
  on_v = _mm256_and_ps(on_v, _mm256_cmp_ps(kc, _mm256_setzero_ps(), _CMP_GT_OQ));
  on_v = _mm256_and_ps(on_v, _mm256_cmp_ps(kc, f8(L.k), _CMP_LT_OQ));
  const __m256 x = _mm256_sub_ps(kc, f8(L.k0));
  const __m256 xf = _mm256_floor_ps(x);
  const __m256i n1 = _mm256_cvttps_epi32(xf);
  const __m256 t = _mm256_sub_ps(x, _mm256_cvtepi32_ps(n1));
  const __m256i last = i8(L.line_count - 1), zero = _mm256_setzero_si256();
  const __m256i la = clampi8(_mm256_add_epi32(i8(L.line0), _mm256_mullo_epi32(i8(L.dir), n1)), zero, last);
  const __m256i lb =
      clampi8(_mm256_add_epi32(i8(L.line0), _mm256_mullo_epi32(i8(L.dir), _mm256_add_epi32(n1, i8(1)))), zero, last);
  const __m256i zl = i8(static_cast<int>(L.z_line));
  const __m256i vo = _mm256_mullo_epi32(vline, i8(L.zv));
  const __m256 fill = f8(L.s->fill);
  const __m256 a = fill_voids(gather_masked(L.s->z, _mm256_add_epi32(_mm256_mullo_epi32(la, zl), vo), on_v), fill);
  const __m256 b = fill_voids(gather_masked(L.s->z, _mm256_add_epi32(_mm256_mullo_epi32(lb, zl), vo), on_v), fill);
  const __m256 inv_dv = gather_masked(L.inv_dv, vline, on_v);
  const __m256 er = eye_relative8(a, b, t, f8(L.eye), f8(L.eye_lo));
  const __m256 sv = _mm256_sub_ps(_mm256_mul_ps(er, _mm256_mul_ps(m, inv_dv)), _mm256_mul_ps(curv_k, kc));
  return _mm256_blendv_ps(_mm256_blendv_ps(none, sv, on_v), su, on_u);
}

// Stores the codes (kVisible, kHidden or kNoAnswer per 32-bit lane) of
// the lanes of `lanes` (cells j, j + 1, ...) into the line's mask.
HORIZON_AVX2 inline void store_code_bytes8(const ResampleLine& L, int j, __m256 lanes, __m256i code) {
  // 32-bit lanes to bytes: 0, 1 and 255 survive both saturating packs.
  const __m128i words = _mm_packs_epi32(_mm256_castsi256_si128(code), _mm256_extracti128_si256(code, 1));
  const __m128i bytes = _mm_packus_epi16(words, words);
  const int count = __builtin_popcount(static_cast<unsigned>(_mm256_movemask_ps(lanes)));  // lanes 0 .. count - 1
  if (L.o_v == 1 && count == 8) {
    _mm_storel_epi64(reinterpret_cast<__m128i*>(L.mask + j), bytes);
    return;
  }
  alignas(16) std::uint8_t b[16];
  _mm_store_si128(reinterpret_cast<__m128i*>(b), bytes);
  for (int q = 0; q < count; ++q) L.mask[(j + q) * L.o_v] = b[q];
}

// The codes of put(), eight cells at once: the same float subtraction and
// compares as min_target_height_at. `lanes` are the cells j, j + 1, ... in
// the line's range, `ground` their elevations (NaN on a void target).
HORIZON_AVX2 inline void store_codes8(const ResampleLine& L, int j, __m256 lanes, __m256 height, __m256 ground) {
  using namespace simd;
  const __m256 above = _mm256_sub_ps(height, ground);
  const __m256 needed = _mm256_and_ps(_mm256_cmp_ps(above, f8(kTieTolerance), _CMP_GT_OQ), above);
  const __m256 seen = _mm256_cmp_ps(f8(L.target_height), needed, _CMP_GE_OQ);
  const __m256 answered =
      _mm256_and_ps(_mm256_cmp_ps(ground, ground, _CMP_ORD_Q), _mm256_cmp_ps(height, height, _CMP_ORD_Q));
  const __m256 visible = _mm256_and_ps(_mm256_and_ps(lanes, answered), seen);
  const __m256i code =
      _mm256_blendv_epi8(i8(kNoAnswer), _mm256_blendv_epi8(i8(kHidden), i8(kVisible), _mm256_castps_si256(seen)),
                         _mm256_castps_si256(answered));
  *L.visible += static_cast<std::uint64_t>(__builtin_popcount(static_cast<unsigned>(_mm256_movemask_ps(visible))));
  store_code_bytes8(L, j, lanes, code);
}

// store_codes8 for a group all_hidden8 found hidden: its answered cells
// (`valid`) are hidden, its void targets have no answer, none is visible.
HORIZON_AVX2 inline void store_hidden8(const ResampleLine& L, int j, __m256 lanes, __m256 valid) {
  using namespace simd;
  store_code_bytes8(L, j, lanes, _mm256_blendv_epi8(i8(kNoAnswer), i8(kHidden), _mm256_castps_si256(valid)));
}

// occlusion_height for eight cells from their best samples, in double (d2:
// the cells' squared ground distances, lanes 0-3 and 4-7); lanes outside
// `valid` (void targets) NaN, no answer.
HORIZON_AVX2 inline __m256 occlusion_heights8(__m256 best, __m256 valid, __m256d eye, __m256d k, __m256d curvature,
                                              __m256d d2_lo, __m256d d2_hi) {
  using namespace simd;
  const __m256d b_lo = _mm256_cvtps_pd(_mm256_castps256_ps128(best));
  const __m256d b_hi = _mm256_cvtps_pd(_mm256_extractf128_ps(best, 1));
  const __m256d h_lo = _mm256_add_pd(_mm256_add_pd(eye, _mm256_mul_pd(k, b_lo)), _mm256_mul_pd(curvature, d2_lo));
  const __m256d h_hi = _mm256_add_pd(_mm256_add_pd(eye, _mm256_mul_pd(k, b_hi)), _mm256_mul_pd(curvature, d2_hi));
  __m256 height = _mm256_set_m128(_mm256_cvtpd_ps(h_hi), _mm256_cvtpd_ps(h_lo));
  const __m256 some = _mm256_cmp_ps(best, f8(static_cast<float>(0.5 * kNoHorizon)), _CMP_GT_OQ);
  height = _mm256_blendv_ps(f8(-std::numeric_limits<float>::infinity()), height, some);
  return _mm256_blendv_ps(f8(std::numeric_limits<float>::quiet_NaN()), height, valid);
}

// Whether every lane of `valid` would be coded hidden at `height`
// (store_codes8's test).
HORIZON_AVX2 inline bool all_hidden8(const ResampleLine& L, __m256 valid, __m256 height, __m256 ground) {
  using namespace simd;
  const __m256 above = _mm256_sub_ps(height, ground);
  const __m256 needed = _mm256_and_ps(_mm256_cmp_ps(above, f8(kTieTolerance), _CMP_GT_OQ), above);
  const __m256 seen = _mm256_cmp_ps(f8(L.target_height), needed, _CMP_GE_OQ);
  const __m256 unanswered = _mm256_cmp_ps(height, height, _CMP_UNORD_Q);
  return _mm256_movemask_ps(_mm256_and_ps(valid, _mm256_or_ps(seen, unanswered))) == 0;
}

// Stores the lanes of `lanes` (cells j, j + 1, ...) into the line's output
// (heights, or codes from `ground`); `values` and `keep` are scratch for a
// line whose cells lie apart.
HORIZON_AVX2 inline void store_cells8(const ResampleLine& L, int j, __m256 lanes, __m256 height, __m256 ground,
                                      float* values, int* keep) {
  if (L.mask) {
    store_codes8(L, j, lanes, height, ground);
    return;
  }
  if (L.o_v == 1) {
    _mm256_maskstore_ps(L.out + j, _mm256_castps_si256(lanes), height);
    return;
  }
  _mm256_store_ps(values, height);
  _mm256_store_si256(reinterpret_cast<__m256i*>(keep), _mm256_castps_si256(lanes));
  for (int q = 0; q < 8; ++q)
    if (keep[q]) L.out[(j + q) * L.o_v] = values[q];
}

// The upper bracketing ray's code for eight cells (marching ray i0 + 1),
// none where it repeats the lower ray's (`a0`, as gathered) or is the line
// before, which the kernel samples anyway.
HORIZON_AVX2 inline __m256i upper_code8(const ResampleLine& L, __m256i i0, __m256 valid, __m256i a0) {
  using namespace simd;
  const __m256i none = i8(-1);
  const __m256i a1 =
      _mm256_mask_i32gather_epi32(none, L.code, _mm256_add_epi32(i0, i8(1)), _mm256_castps_si256(valid), 4);
  return _mm256_blendv_epi8(a1, none, _mm256_or_si256(_mm256_cmpeq_epi32(a1, a0), _mm256_cmpeq_epi32(a1, i8(L.n - 1))));
}

HORIZON_AVX2 std::uint64_t resample_cells_avx2(const ResampleLine& line, int j_begin, int j_end) {
  using namespace simd;
  // Copies of the line's constants: the codes are stored as bytes, which
  // may alias anything, so through the references every group would read
  // them again.
  const ResampleLine L = line;
  const CellLine cl = *L.cells;
  std::uint64_t written = 0;
  int j = j_begin;
  const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  const __m256d eye_v = _mm256_set1_pd(L.eye_v), inv_k = _mm256_set1_pd(L.inv_k),
                ray_half = _mm256_set1_pd(static_cast<double>(L.ray_half));
  const __m256d eye = _mm256_set1_pd(L.eye), k = _mm256_set1_pd(L.k), curvature = _mm256_set1_pd(L.curvature),
                du2 = _mm256_set1_pd(L.du2), metres_v = _mm256_set1_pd(L.metres_v);
  const __m128i shift = _mm_cvtsi32_si128(L.level);
  alignas(32) float values[8];
  alignas(32) int keep[8];
  for (; j <= j_end; j += 8) {
    const __m256i jv = _mm256_add_epi32(i8(j), lane);
    // The lanes inside [j, j_end] (all but in the last, partial group), then
    // those whose target is not void; void cells are left alone.
    const __m256 lanes = _mm256_castsi256_ps(_mm256_cmpgt_epi32(i8(j_end + 1), jv));
    const __m256 zc = fill_voids(cl.zv == 1 ? _mm256_maskload_ps(L.elevation + j, _mm256_castps_si256(lanes))
                                            : gather_masked(L.elevation, _mm256_mullo_epi32(jv, i8(cl.zv)), lanes),
                                 f8(cl.s->fill));
    const __m256 valid = _mm256_and_ps(lanes, _mm256_cmp_ps(zc, zc, _CMP_ORD_Q));
    const int valid_bits = _mm256_movemask_ps(valid);
    if (valid_bits == 0) {  // void targets only: no answers
      store_cells8(L, j, lanes, f8(std::numeric_limits<float>::quiet_NaN()), zc, values, keep);
      continue;
    }
    // rho and d^2 in double, four lanes at a time.
    const __m256d j_lo = _mm256_cvtepi32_pd(_mm256_castsi256_si128(jv));
    const __m256d j_hi = _mm256_cvtepi32_pd(_mm256_extracti128_si256(jv, 1));
    const __m256d dj_lo = _mm256_sub_pd(j_lo, eye_v), dj_hi = _mm256_sub_pd(j_hi, eye_v);
    const __m128i r_lo = _mm256_cvttpd_epi32(_mm256_floor_pd(_mm256_mul_pd(_mm256_mul_pd(dj_lo, inv_k), ray_half)));
    const __m128i r_hi = _mm256_cvttpd_epi32(_mm256_floor_pd(_mm256_mul_pd(_mm256_mul_pd(dj_hi, inv_k), ray_half)));
    const __m256i r = clampi8(_mm256_set_m128i(r_hi, r_lo), i8(-L.ray_half), i8(L.ray_half - 1));
    const __m256i i0 = _mm256_sra_epi32(_mm256_sub_epi32(r, i8(L.ra)), shift);
    const __m256i none = i8(-1), previous = i8(L.n - 1);
    // Where the lower ray found its horizon (none when that is the line
    // before, which is sampled anyway); the upper ray's code is read only
    // when the first candidate leaves a cell of the group to decide.
    const __m256i a0_code = _mm256_mask_i32gather_epi32(none, L.code, i0, _mm256_castps_si256(valid), 4);
    const __m256i a0 = _mm256_blendv_epi8(a0_code, none, _mm256_cmpeq_epi32(a0_code, previous));
    // cell_ray(cl, j).
    const __m256 m = _mm256_div_ps(_mm256_sub_ps(_mm256_cvtepi32_ps(jv), f8(cl.eye_v)), f8(cl.k));
    const __m256 inv_m = _mm256_mul_ps(f8(cl.k), _mm256_maskload_ps(cl.inv_dv + j, _mm256_castps_si256(valid)));
    const __m256 curv_k =
        _mm256_mul_ps(f8(cl.curvature), _mm256_add_ps(f8(cl.mu2), _mm256_mul_ps(_mm256_mul_ps(m, m), f8(cl.mv2))));
    const __m256d dv_lo = _mm256_mul_pd(dj_lo, metres_v), dv_hi = _mm256_mul_pd(dj_hi, metres_v);
    const __m256d d2_lo = _mm256_add_pd(du2, _mm256_mul_pd(dv_lo, dv_lo));
    const __m256d d2_hi = _mm256_add_pd(du2, _mm256_mul_pd(dv_hi, dv_hi));
    // The candidates; `max(x, best)` keeps best when x is NaN, as take() does.
    __m256 best = f8(kNoHorizon);
    if (L.mask) {
      // The codes: the first candidate alone usually hides all eight cells,
      // and a higher maximum would only hide them more (see the header).
      best = _mm256_max_ps(sample_at8(cl, valid, jv, m, inv_m, curv_k, a0), best);
      const __m256 height = occlusion_heights8(best, valid, eye, k, curvature, d2_lo, d2_hi);
      if (all_hidden8(L, valid, height, zc)) {
        store_hidden8(L, j, lanes, valid);
        written += static_cast<std::uint64_t>(__builtin_popcount(static_cast<unsigned>(valid_bits)));
        continue;
      }
      if (L.n > 0) best = _mm256_max_ps(sample_u8(cl, m, curv_k, i8(L.n - 1), valid, f8(cl.inv_step[L.n - 1])), best);
    } else {
      if (L.n > 0) best = _mm256_max_ps(sample_u8(cl, m, curv_k, i8(L.n - 1), valid, f8(cl.inv_step[L.n - 1])), best);
      best = _mm256_max_ps(sample_at8(cl, valid, jv, m, inv_m, curv_k, a0), best);
    }
    best = _mm256_max_ps(sample_at8(cl, valid, jv, m, inv_m, curv_k, upper_code8(L, i0, valid, a0_code)), best);
    store_cells8(L, j, lanes, occlusion_heights8(best, valid, eye, k, curvature, d2_lo, d2_hi), zc, values, keep);
    written += static_cast<std::uint64_t>(__builtin_popcount(static_cast<unsigned>(valid_bits)));
  }
  return written;
}

// The AVX-512 kernel: the AVX2 kernel sixteen cells at a time, lane for lane
// the same operations, with mask registers for the lane masks.

HORIZON_AVX512 inline __m512 clamp16(__m512 x, __m512 lo, __m512 hi) {
  return simd::min_of(simd::max_of(x, lo), hi);
}
HORIZON_AVX512 inline __m512i clampi16(__m512i x, __m512i lo, __m512i hi) {
  return simd::mini_of(simd::maxi_of(x, lo), hi);
}

HORIZON_AVX512 __attribute__((always_inline)) inline __m512 sample_u16(const CellLine& L, __m512 m, __m512 curv_k,
                                                                       __m512i step, __mmask16 mask, __m512 inv_step) {
  using namespace simd;
  const __m512 kn = _mm512_add_ps(f16(L.k0), _mm512_cvtepi32_ps(step));
  const __m512 v = clamp16(_mm512_add_ps(f16(L.eye_v), _mm512_mul_ps(m, kn)), f16(L.v_min), f16(L.v_max));
  const __m512i j0 = _mm512_min_epi32(_mm512_cvttps_epi32(v), i16(L.j_max));
  const __m512 t = _mm512_sub_ps(v, _mm512_cvtepi32_ps(j0));
  const __m512i line = _mm512_add_epi32(i16(L.line0), _mm512_mullo_epi32(i16(L.dir), step));
  const __m512i ia =
      _mm512_add_epi32(_mm512_mullo_epi32(line, i16(static_cast<int>(L.z_line))), _mm512_mullo_epi32(j0, i16(L.zv)));
  const __m512i ib = _mm512_add_epi32(ia, i16(L.zv));
  const __m512 fill = f16(L.s->fill);
  const __m512 a = fill_voids(gather_masked(L.s->z, ia, mask), fill);
  const __m512 b = fill_voids(gather_masked(L.s->z, ib, mask), fill);
  const __m512 er = eye_relative16(a, b, t, f16(L.eye), f16(L.eye_lo));
  return _mm512_sub_ps(_mm512_mul_ps(er, inv_step), _mm512_mul_ps(curv_k, kn));
}

HORIZON_AVX512 __attribute__((always_inline)) inline __m512 sample_at16(const CellLine& L, __mmask16 lanes, __m512i j,
                                                                        __m512 m, __m512 inv_m, __m512 curv_k,
                                                                        __m512i code) {
  using namespace simd;
  const __m512 none = f16(kNoHorizon);
  const __mmask16 on_u = _mm512_mask_cmpgt_epi32_mask(lanes, code, i16(-1));
  const __m512i step = _mm512_max_epi32(code, i16(0));
  const __m512 su = on_u == 0 ? none : sample_u16(L, m, curv_k, step, on_u, gather_masked(L.inv_step, step, on_u));
  const __m512i vline = _mm512_sub_epi32(i16(-2), code);
  __mmask16 on_v = _mm512_mask_cmpgt_epi32_mask(lanes, i16(-1), code);
  if (on_v == 0) return _mm512_mask_blend_ps(on_u, none, su);
  on_v = _mm512_mask_cmp_ps_mask(on_v, inv_m, _mm512_setzero_ps(), _CMP_NEQ_OQ);
  on_v = _mm512_mask_cmpneq_epi32_mask(on_v, vline, j);
  const __m512 kc = _mm512_mul_ps(_mm512_sub_ps(_mm512_cvtepi32_ps(vline), f16(L.eye_v)), inv_m);
  on_v = _mm512_mask_cmp_ps_mask(on_v, kc, _mm512_setzero_ps(), _CMP_GT_OQ);
  on_v = _mm512_mask_cmp_ps_mask(on_v, kc, f16(L.k), _CMP_LT_OQ);
  const __m512 x = _mm512_sub_ps(kc, f16(L.k0));
  const __m512 xf = floor16(x);
  const __m512i n1 = _mm512_cvttps_epi32(xf);
  const __m512 t = _mm512_sub_ps(x, _mm512_cvtepi32_ps(n1));
  const __m512i last = i16(L.line_count - 1), zero = _mm512_setzero_si512();
  const __m512i la = clampi16(_mm512_add_epi32(i16(L.line0), _mm512_mullo_epi32(i16(L.dir), n1)), zero, last);
  const __m512i lb = clampi16(
      _mm512_add_epi32(i16(L.line0), _mm512_mullo_epi32(i16(L.dir), _mm512_add_epi32(n1, i16(1)))), zero, last);
  const __m512i zl = i16(static_cast<int>(L.z_line));
  const __m512i vo = _mm512_mullo_epi32(vline, i16(L.zv));
  const __m512 fill = f16(L.s->fill);
  const __m512 a = fill_voids(gather_masked(L.s->z, _mm512_add_epi32(_mm512_mullo_epi32(la, zl), vo), on_v), fill);
  const __m512 b = fill_voids(gather_masked(L.s->z, _mm512_add_epi32(_mm512_mullo_epi32(lb, zl), vo), on_v), fill);
  const __m512 inv_dv = gather_masked(L.inv_dv, vline, on_v);
  const __m512 er = eye_relative16(a, b, t, f16(L.eye), f16(L.eye_lo));
  const __m512 sv = _mm512_sub_ps(_mm512_mul_ps(er, _mm512_mul_ps(m, inv_dv)), _mm512_mul_ps(curv_k, kc));
  return _mm512_mask_blend_ps(on_u, _mm512_mask_blend_ps(on_v, none, sv), su);
}

// The double-precision halves of sixteen lanes: lanes 0-7 and 8-15.
HORIZON_AVX512 inline __m512d low_pd(__m512i x) {
  return _mm512_cvtepi32_pd(_mm512_castsi512_si256(x));
}
HORIZON_AVX512 inline __m512d high_pd(__m512i x) {
  return _mm512_cvtepi32_pd(_mm512_extracti64x4_epi64(x, 1));
}

// store_code_bytes8's sixteen-cell twin.
HORIZON_AVX512 inline void store_code_bytes16(const ResampleLine& L, int j, __mmask16 lanes, __m512i code) {
  if (L.o_v == 1) {
    _mm512_mask_cvtepi32_storeu_epi8(L.mask + j, lanes, code);
    return;
  }
  alignas(16) std::uint8_t b[16];
  _mm_store_si128(reinterpret_cast<__m128i*>(b), _mm512_cvtepi32_epi8(code));
  for (unsigned left = lanes; left != 0; left &= left - 1) {
    const int q = __builtin_ctz(left);
    L.mask[(j + q) * L.o_v] = b[q];
  }
}

// store_codes8, sixteen cells at once.
HORIZON_AVX512 inline void store_codes16(const ResampleLine& L, int j, __mmask16 lanes, __m512 height, __m512 ground) {
  using namespace simd;
  const __m512 above = _mm512_sub_ps(height, ground);
  const __m512 needed = _mm512_maskz_mov_ps(_mm512_cmp_ps_mask(above, f16(kTieTolerance), _CMP_GT_OQ), above);
  const __mmask16 seen = _mm512_cmp_ps_mask(f16(L.target_height), needed, _CMP_GE_OQ);
  const __mmask16 answered =
      _mm512_cmp_ps_mask(ground, ground, _CMP_ORD_Q) & _mm512_cmp_ps_mask(height, height, _CMP_ORD_Q);
  const __m512i code =
      _mm512_mask_blend_epi32(answered, i16(kNoAnswer), _mm512_mask_blend_epi32(seen, i16(kHidden), i16(kVisible)));
  *L.visible += static_cast<std::uint64_t>(__builtin_popcount(static_cast<unsigned>(lanes & answered & seen)));
  store_code_bytes16(L, j, lanes, code);
}

// store_hidden8's sixteen-cell twin.
HORIZON_AVX512 inline void store_hidden16(const ResampleLine& L, int j, __mmask16 lanes, __mmask16 valid) {
  using namespace simd;
  store_code_bytes16(L, j, lanes, _mm512_mask_blend_epi32(valid, i16(kNoAnswer), i16(kHidden)));
}

// occlusion_height for sixteen cells from their best samples, in double
// (d2: the cells' squared ground distances, lanes 0-7 and 8-15); lanes
// outside `valid` (void targets) NaN, no answer.
HORIZON_AVX512 inline __m512 occlusion_heights16(__m512 best, __mmask16 valid, __m512d eye, __m512d k,
                                                 __m512d curvature, __m512d d2_lo, __m512d d2_hi) {
  using namespace simd;
  const __m512d b_lo = _mm512_cvtps_pd(_mm512_castps512_ps256(best));
  const __m512d b_hi = _mm512_cvtps_pd(_mm256_castpd_ps(_mm512_extractf64x4_pd(_mm512_castps_pd(best), 1)));
  const __m512d h_lo = _mm512_add_pd(_mm512_add_pd(eye, _mm512_mul_pd(k, b_lo)), _mm512_mul_pd(curvature, d2_lo));
  const __m512d h_hi = _mm512_add_pd(_mm512_add_pd(eye, _mm512_mul_pd(k, b_hi)), _mm512_mul_pd(curvature, d2_hi));
  const __m512 both = _mm512_castpd_ps(_mm512_insertf64x4(
      _mm512_castpd256_pd512(_mm256_castps_pd(_mm512_cvtpd_ps(h_lo))), _mm256_castps_pd(_mm512_cvtpd_ps(h_hi)), 1));
  const __mmask16 some = _mm512_cmp_ps_mask(best, f16(static_cast<float>(0.5 * kNoHorizon)), _CMP_GT_OQ);
  return _mm512_mask_blend_ps(valid, f16(std::numeric_limits<float>::quiet_NaN()),
                              _mm512_mask_blend_ps(some, f16(-std::numeric_limits<float>::infinity()), both));
}

// Whether every lane of `valid` would be coded hidden at `height`
// (store_codes16's test).
HORIZON_AVX512 inline bool all_hidden16(const ResampleLine& L, __mmask16 valid, __m512 height, __m512 ground) {
  using namespace simd;
  const __m512 above = _mm512_sub_ps(height, ground);
  const __m512 needed = _mm512_maskz_mov_ps(_mm512_cmp_ps_mask(above, f16(kTieTolerance), _CMP_GT_OQ), above);
  const __mmask16 answered = _mm512_mask_cmp_ps_mask(valid, height, height, _CMP_ORD_Q);
  return answered == valid && _mm512_mask_cmp_ps_mask(valid, f16(L.target_height), needed, _CMP_GE_OQ) == 0;
}

// Stores the lanes of `lanes` (cells jv) into the line's output (heights, or
// codes from `ground`).
HORIZON_AVX512 inline void store_cells16(const ResampleLine& L, int j, __m512i jv, __mmask16 lanes, __m512 height,
                                         __m512 ground, __m512i o_v) {
  if (L.mask) {
    store_codes16(L, j, lanes, height, ground);
    return;
  }
  if (L.o_v == 1) {
    _mm512_mask_storeu_ps(L.out + j, lanes, height);
  } else {
    _mm512_mask_i32scatter_ps(L.out, lanes, _mm512_mullo_epi32(jv, o_v), height, 4);
  }
}

// upper_code8's sixteen-cell twin.
HORIZON_AVX512 inline __m512i upper_code16(const ResampleLine& L, __m512i i0, __mmask16 valid, __m512i a0) {
  using namespace simd;
  const __m512i none = i16(-1);
  const __m512i a1 = _mm512_mask_i32gather_epi32(none, valid, _mm512_add_epi32(i0, i16(1)), L.code, 4);
  return _mm512_mask_blend_epi32(_mm512_cmpeq_epi32_mask(a1, a0) | _mm512_cmpeq_epi32_mask(a1, i16(L.n - 1)), a1, none);
}

HORIZON_AVX512 std::uint64_t resample_cells_avx512(const ResampleLine& line, int j_begin, int j_end) {
  using namespace simd;
  // Copies of the line's constants: the codes are stored as bytes, which
  // may alias anything, so through the references every group would read
  // them again.
  const ResampleLine L = line;
  const CellLine cl = *L.cells;
  std::uint64_t written = 0;
  const __m512i lane = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
  const __m512d eye_v = _mm512_set1_pd(L.eye_v), inv_k = _mm512_set1_pd(L.inv_k),
                ray_half = _mm512_set1_pd(static_cast<double>(L.ray_half));
  const __m512d eye = _mm512_set1_pd(L.eye), k = _mm512_set1_pd(L.k), curvature = _mm512_set1_pd(L.curvature),
                du2 = _mm512_set1_pd(L.du2), metres_v = _mm512_set1_pd(L.metres_v);
  const __m128i shift = _mm_cvtsi32_si128(L.level);
  const __m512i o_v = i16(static_cast<int>(L.o_v));
  constexpr int kFloor = _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC;
  for (int j = j_begin; j <= j_end; j += 16) {
    const __m512i jv = _mm512_add_epi32(i16(j), lane);
    const __mmask16 lanes = _mm512_cmpgt_epi32_mask(i16(j_end + 1), jv);
    const __m512 zc = fill_voids(cl.zv == 1 ? _mm512_maskz_loadu_ps(lanes, L.elevation + j)
                                            : gather_masked(L.elevation, _mm512_mullo_epi32(jv, i16(cl.zv)), lanes),
                                 f16(cl.s->fill));
    const __mmask16 valid = _mm512_mask_cmp_ps_mask(lanes, zc, zc, _CMP_ORD_Q);
    if (valid == 0) {  // void targets only: no answers
      store_cells16(L, j, jv, lanes, f16(std::numeric_limits<float>::quiet_NaN()), zc, o_v);
      continue;
    }
    const __m512d dj_lo = _mm512_sub_pd(low_pd(jv), eye_v), dj_hi = _mm512_sub_pd(high_pd(jv), eye_v);
    const __m256i r_lo =
        _mm512_cvttpd_epi32(_mm512_roundscale_pd(_mm512_mul_pd(_mm512_mul_pd(dj_lo, inv_k), ray_half), kFloor));
    const __m256i r_hi =
        _mm512_cvttpd_epi32(_mm512_roundscale_pd(_mm512_mul_pd(_mm512_mul_pd(dj_hi, inv_k), ray_half), kFloor));
    const __m512i r =
        clampi16(_mm512_inserti64x4(_mm512_castsi256_si512(r_lo), r_hi, 1), i16(-L.ray_half), i16(L.ray_half - 1));
    const __m512i i0 = _mm512_sra_epi32(_mm512_sub_epi32(r, i16(L.ra)), shift);
    const __m512i none = i16(-1), previous = i16(L.n - 1);
    // The lower ray's code now, the upper ray's only where it is needed (as
    // in the AVX2 kernel).
    const __m512i a0_code = _mm512_mask_i32gather_epi32(none, valid, i0, L.code, 4);
    const __m512i a0 = _mm512_mask_blend_epi32(_mm512_cmpeq_epi32_mask(a0_code, previous), a0_code, none);
    const __m512 m = _mm512_div_ps(_mm512_sub_ps(_mm512_cvtepi32_ps(jv), f16(cl.eye_v)), f16(cl.k));
    const __m512 inv_m = _mm512_mul_ps(f16(cl.k), _mm512_maskz_loadu_ps(valid, cl.inv_dv + j));
    const __m512 curv_k =
        _mm512_mul_ps(f16(cl.curvature), _mm512_add_ps(f16(cl.mu2), _mm512_mul_ps(_mm512_mul_ps(m, m), f16(cl.mv2))));
    const __m512d dv_lo = _mm512_mul_pd(dj_lo, metres_v), dv_hi = _mm512_mul_pd(dj_hi, metres_v);
    const __m512d d2_lo = _mm512_add_pd(du2, _mm512_mul_pd(dv_lo, dv_lo));
    const __m512d d2_hi = _mm512_add_pd(du2, _mm512_mul_pd(dv_hi, dv_hi));
    __m512 best = f16(kNoHorizon);
    if (L.mask) {
      // The codes: the first candidate alone usually hides all sixteen
      // cells, and a higher maximum would only hide them more (see the header).
      best = _mm512_max_ps(sample_at16(cl, valid, jv, m, inv_m, curv_k, a0), best);
      const __m512 height = occlusion_heights16(best, valid, eye, k, curvature, d2_lo, d2_hi);
      if (all_hidden16(L, valid, height, zc)) {
        store_hidden16(L, j, lanes, valid);
        written += static_cast<std::uint64_t>(__builtin_popcount(static_cast<unsigned>(valid)));
        continue;
      }
      if (L.n > 0)
        best = _mm512_max_ps(sample_u16(cl, m, curv_k, i16(L.n - 1), valid, f16(cl.inv_step[L.n - 1])), best);
    } else {
      if (L.n > 0)
        best = _mm512_max_ps(sample_u16(cl, m, curv_k, i16(L.n - 1), valid, f16(cl.inv_step[L.n - 1])), best);
      best = _mm512_max_ps(sample_at16(cl, valid, jv, m, inv_m, curv_k, a0), best);
    }
    best = _mm512_max_ps(sample_at16(cl, valid, jv, m, inv_m, curv_k, upper_code16(L, i0, valid, a0_code)), best);
    store_cells16(L, j, jv, lanes, occlusion_heights16(best, valid, eye, k, curvature, d2_lo, d2_hi), zc, o_v);
    written += static_cast<std::uint64_t>(__builtin_popcount(static_cast<unsigned>(valid)));
  }
  return written;
}

}  // namespace
#endif

std::uint64_t resample_cells(const ResampleLine& line, int j_begin, int j_end) {
#ifdef HORIZON_SIMD_AVX2
  if (simd::has_avx512()) return resample_cells_avx512(line, j_begin, j_end);
  if (simd::has_avx2()) return resample_cells_avx2(line, j_begin, j_end);
#endif
  return resample_cells_scalar(line, j_begin, j_end);
}

}  // namespace horizon::visibility::sweep
