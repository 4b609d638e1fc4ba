// The exact sweep's crossing screen: scalar, AVX2 and AVX-512 kernels with
// the same double arithmetic (see exact_screen.hpp).
#include "exact_screen.hpp"

#include <algorithm>
#include <cmath>

#include "../common/simd_isa.hpp"

namespace horizon::visibility::detail {
namespace {

constexpr double kMargin = 1e-6;  // relative: outweighs the rounding of the screen's and R3's sums
// Runs of at most this many lines take the scalar kernel: a vector call's
// set-up (a dozen broadcasts, masked gathers of mostly idle lanes) costs
// more than they do. Most of the exact sweep's runs near the eye are a few
// lines long; on the 12 M-cell case 8 took the whole OHF from 1.36 s to
// 1.26-1.28 s (AVX-512) and from 1.40 s to 1.29 s (AVX2); 4 and 16 did less.
constexpr int kScalarBelow = 8;

}  // namespace

ScreenedFamily screen_family(const terrain::HeightView& z, Axis axis, double c0, double r0, double c1, double r1,
                             double total, double eye, double curvature) {
  const bool columns = axis == Axis::kColumns;
  const double a0 = columns ? c0 : r0, a1 = columns ? c1 : r1;
  const double b0 = columns ? r0 : c0, b1 = columns ? r1 : c1;
  const int line_count = columns ? z.width() : z.height(), pos_count = columns ? z.height() : z.width();
  ScreenedFamily family;
  // R3's crossings are the lines strictly between a0 and a1.
  family.first = std::max(floor_to_int(std::min(a0, a1)) + 1, 0);
  family.last = a0 == a1 ? -1 : std::min(ceil_to_int(std::max(a0, a1)) - 1, line_count - 1);
  // The crossing's two cells: (line, p0) and (line, p0 + 1) on a column
  // line, (p0, line) and (p0 + 1, line) on a row line.
  family.screen = {.cells = z.data(),
                   .line_stride = columns ? 1 : z.stride(),
                   .pos_stride = columns ? z.stride() : 1,
                   .a0 = a0,
                   .inv_da = 1.0 / (a1 - a0),
                   .b0 = b0,
                   .db = b1 - b0,
                   .pos_max = double(pos_count - 1),
                   .p_max = pos_count - 2,
                   .fill = z.void_fill(),
                   .total = total,
                   .eye = eye,
                   .curvature = curvature};
  return family;
}

std::uint64_t screen_crossings_scalar(const CrossingScreen& s, int first, int count, double slope) {
  std::uint64_t hits = 0;
  for (int i = 0; i < count; ++i) {
    const int line = first + i;
    const double t = (double(line) - s.a0) * s.inv_da;
    const double pos = std::clamp(s.b0 + t * s.db, 0.0, s.pos_max);
    const int p0 = std::min(static_cast<int>(pos), s.p_max);
    const float* cell = s.cells + line * s.line_stride + p0 * s.pos_stride;
    const float raw_a = cell[0], raw_b = cell[s.pos_stride];
    const double za = raw_a == raw_a ? raw_a : s.fill, zb = raw_b == raw_b ? raw_b : s.fill;
    const double terrain = za + (pos - double(p0)) * (zb - za);
    const double d = t * s.total;
    const double needed = s.eye + slope * d + s.curvature * d * d;
    const double floor = needed - kMargin * (1.0 + std::abs(needed));
    if (!(terrain < floor)) hits |= std::uint64_t{1} << i;  // NaN: a void, taken exactly
  }
  return hits;
}

#ifdef HORIZON_SIMD_AVX2
namespace {

// Four crossings a step. Lanes past `count` are neither read nor reported.
HORIZON_AVX2 std::uint64_t screen_avx2(const CrossingScreen& s, int first, int count, double slope) {
  const __m256d lane = _mm256_setr_pd(0, 1, 2, 3);
  const __m256i lane64 = _mm256_setr_epi64x(0, 1, 2, 3);
  const __m128i lane32 = _mm_setr_epi32(0, 1, 2, 3);
  const __m256d a0 = _mm256_set1_pd(s.a0), inv_da = _mm256_set1_pd(s.inv_da);
  const __m256d b0 = _mm256_set1_pd(s.b0), db = _mm256_set1_pd(s.db);
  const __m256d zero = _mm256_setzero_pd(), pos_max = _mm256_set1_pd(s.pos_max);
  const __m128i p_max = _mm_set1_epi32(s.p_max);
  const __m256i line_stride = _mm256_set1_epi64x(s.line_stride), pos_stride = _mm256_set1_epi64x(s.pos_stride);
  const __m256d fill = _mm256_set1_pd(s.fill), total = _mm256_set1_pd(s.total);
  const __m256d eye = _mm256_set1_pd(s.eye), curvature = _mm256_set1_pd(s.curvature);
  const __m256d slope4 = _mm256_set1_pd(slope), one = _mm256_set1_pd(1.0), margin = _mm256_set1_pd(kMargin);
  const __m256d sign = _mm256_set1_pd(-0.0);
  std::uint64_t hits = 0;
  for (int i = 0; i < count; i += 4) {
    const int n = std::min(4, count - i), line = first + i;
    const __m128 live = _mm_castsi128_ps(_mm_cmpgt_epi32(_mm_set1_epi32(n), lane32));
    const __m256d t = _mm256_mul_pd(_mm256_sub_pd(_mm256_add_pd(_mm256_set1_pd(double(line)), lane), a0), inv_da);
    const __m256d pos = _mm256_min_pd(_mm256_max_pd(_mm256_add_pd(b0, _mm256_mul_pd(t, db)), zero), pos_max);
    const __m128i p0 = _mm_min_epi32(_mm256_cvttpd_epi32(pos), p_max);
    // (line + lane) * line_stride + p0 * pos_stride, in 64 bits: every factor fits 32.
    const __m256i index =
        _mm256_add_epi64(_mm256_mul_epi32(_mm256_add_epi64(_mm256_set1_epi64x(line), lane64), line_stride),
                         _mm256_mul_epi32(_mm256_cvtepi32_epi64(p0), pos_stride));
    const __m128 raw_a = _mm256_mask_i64gather_ps(_mm_setzero_ps(), s.cells, index, live, 4);
    const __m128 raw_b =
        _mm256_mask_i64gather_ps(_mm_setzero_ps(), s.cells, _mm256_add_epi64(index, pos_stride), live, 4);
    __m256d za = _mm256_cvtps_pd(raw_a), zb = _mm256_cvtps_pd(raw_b);
    za = _mm256_blendv_pd(za, fill, _mm256_cmp_pd(za, za, _CMP_UNORD_Q));
    zb = _mm256_blendv_pd(zb, fill, _mm256_cmp_pd(zb, zb, _CMP_UNORD_Q));
    const __m256d terrain =
        _mm256_add_pd(za, _mm256_mul_pd(_mm256_sub_pd(pos, _mm256_cvtepi32_pd(p0)), _mm256_sub_pd(zb, za)));
    const __m256d d = _mm256_mul_pd(t, total);
    const __m256d needed =
        _mm256_add_pd(_mm256_add_pd(eye, _mm256_mul_pd(slope4, d)), _mm256_mul_pd(_mm256_mul_pd(curvature, d), d));
    const __m256d floor =
        _mm256_sub_pd(needed, _mm256_mul_pd(margin, _mm256_add_pd(one, _mm256_andnot_pd(sign, needed))));
    const int hit = _mm256_movemask_pd(_mm256_cmp_pd(terrain, floor, _CMP_NLT_UQ)) & ((1 << n) - 1);
    hits |= std::uint64_t(unsigned(hit)) << i;
  }
  return hits;
}

// Eight crossings a step, the same operations.
HORIZON_AVX512 std::uint64_t screen_avx512(const CrossingScreen& s, int first, int count, double slope) {
  const __m512d lane = _mm512_setr_pd(0, 1, 2, 3, 4, 5, 6, 7);
  const __m512i lane64 = _mm512_setr_epi64(0, 1, 2, 3, 4, 5, 6, 7);
  const __m512d a0 = _mm512_set1_pd(s.a0), inv_da = _mm512_set1_pd(s.inv_da);
  const __m512d b0 = _mm512_set1_pd(s.b0), db = _mm512_set1_pd(s.db);
  const __m512d zero = _mm512_setzero_pd(), pos_max = _mm512_set1_pd(s.pos_max);
  const __m256i p_max = _mm256_set1_epi32(s.p_max);
  const __m512i line_stride = _mm512_set1_epi64(s.line_stride), pos_stride = _mm512_set1_epi64(s.pos_stride);
  const __m512d fill = _mm512_set1_pd(s.fill), total = _mm512_set1_pd(s.total);
  const __m512d eye = _mm512_set1_pd(s.eye), curvature = _mm512_set1_pd(s.curvature);
  const __m512d slope8 = _mm512_set1_pd(slope), one = _mm512_set1_pd(1.0), margin = _mm512_set1_pd(kMargin);
  std::uint64_t hits = 0;
  for (int i = 0; i < count; i += 8) {
    const int n = std::min(8, count - i), line = first + i;
    const __mmask8 live = static_cast<__mmask8>((1u << n) - 1);
    const __m512d t = _mm512_mul_pd(_mm512_sub_pd(_mm512_add_pd(_mm512_set1_pd(double(line)), lane), a0), inv_da);
    const __m512d pos = _mm512_min_pd(_mm512_max_pd(_mm512_add_pd(b0, _mm512_mul_pd(t, db)), zero), pos_max);
    const __m256i p0 = _mm256_min_epi32(_mm512_cvttpd_epi32(pos), p_max);
    const __m512i index =
        _mm512_add_epi64(_mm512_mul_epi32(_mm512_add_epi64(_mm512_set1_epi64(line), lane64), line_stride),
                         _mm512_mul_epi32(_mm512_cvtepi32_epi64(p0), pos_stride));
    const __m256 raw_a = _mm512_mask_i64gather_ps(_mm256_setzero_ps(), live, index, s.cells, 4);
    const __m256 raw_b =
        _mm512_mask_i64gather_ps(_mm256_setzero_ps(), live, _mm512_add_epi64(index, pos_stride), s.cells, 4);
    __m512d za = _mm512_cvtps_pd(raw_a), zb = _mm512_cvtps_pd(raw_b);
    za = _mm512_mask_mov_pd(za, _mm512_cmp_pd_mask(za, za, _CMP_UNORD_Q), fill);
    zb = _mm512_mask_mov_pd(zb, _mm512_cmp_pd_mask(zb, zb, _CMP_UNORD_Q), fill);
    const __m512d terrain =
        _mm512_add_pd(za, _mm512_mul_pd(_mm512_sub_pd(pos, _mm512_cvtepi32_pd(p0)), _mm512_sub_pd(zb, za)));
    const __m512d d = _mm512_mul_pd(t, total);
    const __m512d needed =
        _mm512_add_pd(_mm512_add_pd(eye, _mm512_mul_pd(slope8, d)), _mm512_mul_pd(_mm512_mul_pd(curvature, d), d));
    const __m512d floor = _mm512_sub_pd(needed, _mm512_mul_pd(margin, _mm512_add_pd(one, _mm512_abs_pd(needed))));
    const __mmask8 hit = _mm512_mask_cmp_pd_mask(live, terrain, floor, _CMP_NLT_UQ);
    hits |= std::uint64_t{hit} << i;
  }
  return hits;
}

}  // namespace
#endif

std::uint64_t screen_crossings(const CrossingScreen& s, int first, int count, double slope) {
#ifdef HORIZON_SIMD_AVX2
  if (count <= kScalarBelow) return screen_crossings_scalar(s, first, count, slope);
  switch (simd_isa::kernel_isa()) {
    case simd_isa::Isa::kAvx512:
      return screen_avx512(s, first, count, slope);
    case simd_isa::Isa::kAvx2:
      return screen_avx2(s, first, count, slope);
    case simd_isa::Isa::kScalar:
      break;
  }
#endif
  return screen_crossings_scalar(s, first, count, slope);
}

}  // namespace horizon::visibility::detail
