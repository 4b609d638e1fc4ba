#include "ray_steps.hpp"

#include <algorithm>
#include <cmath>

#include "simd.hpp"

namespace horizon::visibility::sweep {
namespace {

// One ray's v-line crossing inside the step: its slope (kNoHorizon when it
// crosses none, NaN when the crossing reads a void, which never wins) and
// the v line (-1 when none). Every value is computed and selected at the
// end: branch-free.
struct Cross {
  float slope;
  int v;
};

inline Cross cross_one(const LineStep& ls, float m, float inv_m, float curv_k, const float* __restrict prev,
                       const float* __restrict cur) {
  const float v_start = ls.eye_v + m * ls.k_start, v_end = ls.eye_v + m * ls.kf;
  const float up = std::floor(v_start) + 1.0f, down = std::ceil(v_start) - 1.0f;
  const float cv = m > 0.0f ? up : down;
  // Integer masks rather than && / ||, which would become branches.
  const int crosses = (int(m > 0.0f) & int(up < v_end)) | (int(m < 0.0f) & int(down > v_end));
  const int valid = crosses & int(cv >= ls.v_min) & int(cv <= ls.v_max);
  const float cv_clamped = std::min(std::max(cv, ls.v_min), ls.v_max);  // a readable line even when not valid
  const int jc = static_cast<int>(cv_clamped);
  const float kc = std::max((cv_clamped - ls.eye_v) * inv_m, 1.0e-6f);
  const float tc = kc - ls.kp;
  const float pa = fill_void(prev[jc * ls.zv], ls.fill), pb = fill_void(cur[jc * ls.zv], ls.fill);
  const float s_cross = eye_relative(pa, pb, tc, ls.eye, ls.eye_lo) / kc - curv_k * kc;
  return {std::min(s_cross, valid ? 3.0e38f : kNoHorizon), (jc + 1) * valid - 1};
}

// One ray's slope where it crosses line n (`cur`); inv_kf = 1 / ls.kf.
inline float line_one(const LineStep& ls, float inv_kf, float m, float curv_k, const float* __restrict cur) {
  const float v = std::min(std::max(ls.eye_v + m * ls.kf, ls.v_min), ls.v_max);
  const int j0 = std::min(static_cast<int>(v), ls.j_max);
  const float t = v - static_cast<float>(j0);
  const float a = fill_void(cur[j0 * ls.zv], ls.fill), b = fill_void(cur[(j0 + 1) * ls.zv], ls.fill);
  return eye_relative(a, b, t, ls.eye, ls.eye_lo) * inv_kf - curv_k * ls.kf;
}

// Folds a crossing and a line sample into one ray's maximum. `x > best ? x :
// best` keeps best when x is NaN, and a tie keeps the earlier place.
inline void fold_one(float& best, int& where, float cross_slope, int cross_v, float s_line, int n) {
  where = cross_slope > best ? -2 - cross_v : where;
  best = cross_slope > best ? cross_slope : best;
  where = s_line > best ? n : where;
  best = s_line > best ? s_line : best;
}

}  // namespace

void step_cross_scalar(const LineStep& ls, int count, const float* __restrict slope, const float* __restrict inv_slope,
                       const float* __restrict curv_k, const float* __restrict prev, const float* __restrict cur,
                       const float* __restrict h, const int* __restrict arg, float* __restrict cross_slope,
                       int* __restrict cross_v, int* __restrict code) {
  for (int i = 0; i < count; ++i) {
    const Cross c = cross_one(ls, slope[i], inv_slope[i], curv_k[i], prev, cur);
    cross_slope[i] = c.slope;
    cross_v[i] = c.v;
    code[i] = c.slope > h[i] ? -2 - c.v : arg[i];
  }
}

void step_line_scalar(const LineStep& ls, int count, const float* __restrict slope, const float* __restrict curv_k,
                      const float* __restrict cur, const float* __restrict cross_slope, const int* __restrict cross_v,
                      float* __restrict h, int* __restrict arg, int n) {
  const float inv_kf = 1.0f / ls.kf;
  for (int i = 0; i < count; ++i) {
    const float s_line = line_one(ls, inv_kf, slope[i], curv_k[i], cur);
    float best = h[i];
    int where = arg[i];
    fold_one(best, where, cross_slope[i], cross_v[i], s_line, n);
    h[i] = best;
    arg[i] = where;
  }
}

void step_rays_scalar(const LineStep& ls, int count, const float* __restrict slope, const float* __restrict inv_slope,
                      const float* __restrict curv_k, const float* __restrict prev, const float* __restrict cur,
                      float* __restrict h, int* __restrict arg, int* __restrict code, int n) {
  const float inv_kf = 1.0f / ls.kf;
  for (int i = 0; i < count; ++i) {
    const Cross c = cross_one(ls, slope[i], inv_slope[i], curv_k[i], prev, cur);
    float best = h[i];
    int where = arg[i];
    code[i] = c.slope > best ? -2 - c.v : where;
    fold_one(best, where, c.slope, c.v, line_one(ls, inv_kf, slope[i], curv_k[i], cur), n);
    h[i] = best;
    arg[i] = where;
  }
}

#ifdef HORIZON_SIMD_AVX2
namespace {

// The AVX2 forms: eight rays per iteration, lane for lane the scalar loops'
// operations (simd.hpp gives std::min / std::max's exact NaN and tie
// behaviour); the last, partial group runs through the scalar loop. Each
// kernel first finds where its group reads (cross_at8, line_at8), then reads
// (Reads8: one run of each line, or gathers), then computes the slopes.
struct Step8 {
  __m256 eye_v, k_start, kf, inv_kf, v_min, v_max, kp, eye, eye_lo, fill;
  __m256i zv, j_max;
  int run_last;
};

HORIZON_AVX2 inline Step8 step8(const LineStep& ls) {
  using namespace simd;
  const float inv_kf = 1.0f / ls.kf;
  return {f8(ls.eye_v), f8(ls.k_start), f8(ls.kf),   f8(inv_kf), f8(ls.v_min), f8(ls.v_max), f8(ls.kp),
          f8(ls.eye),   f8(ls.eye_lo),  f8(ls.fill), i8(ls.zv),  i8(ls.j_max), ls.run_last};
}

// A group's terrain reads. Where v is contiguous (LineStep::run_last) and
// every v position the group reads, [lowest, highest] lane by lane, lies in
// one run of sixteen inside the line, a line is two plain loads and each lane
// picks its element by permute; otherwise each read is a hardware gather.
// The bits are the same; the run saves the gathers' cost (rays one cell
// apart or closer put eight rays' reads within about ten cells). The run
// starts at lane 0's lowest read: the plan's rays rise in slope lane by
// lane, so their reads do too (almost always; a group where another lane
// reads lower is gathered), and one lane is cheaper to take than the
// minimum of eight.
class Reads8 {
 public:
  HORIZON_AVX2 Reads8(const Step8& s, __m256i lowest, __m256i highest) : zv_(s.zv) {
    if (s.run_last < 0) return;
    const int base = _mm256_cvtsi256_si32(lowest);
    if (base < 0 || base + 15 > s.run_last) return;
    const __m256i outside =
        _mm256_or_si256(_mm256_cmpgt_epi32(simd::i8(base), lowest), _mm256_cmpgt_epi32(highest, simd::i8(base + 15)));
    if (!_mm256_testz_si256(outside, outside)) return;
    base_ = base;
  }

  // line[v * zv] for each lane's v.
  HORIZON_AVX2 __m256 at(const float* line, __m256i v) const {
    if (base_ < 0) return _mm256_i32gather_ps(line, _mm256_mullo_epi32(v, zv_), 4);
    return simd::pick8(simd::load_run8(line + base_), _mm256_sub_epi32(v, simd::i8(base_)));
  }

 private:
  __m256i zv_;
  int base_ = -1;
};

// Heights as the view's void policy reads them: the fill applied only when
// the view has one (a transparent view reads NaN as NaN without the blend).
template <bool kFill>
HORIZON_AVX2 inline __m256 heights8(__m256 v, __m256 fill) {
  if constexpr (kFill) return simd::fill_voids(v, fill);
  return v;
}

// Where a group's v-line crossings lie (cross_one's geometry).
struct CrossAt8 {
  __m256 kc, tc, valid;
  __m256i jc;
};

HORIZON_AVX2 inline CrossAt8 cross_at8(const Step8& s, __m256 m, __m256 inv_m) {
  using namespace simd;
  const __m256 zero = _mm256_setzero_ps(), one = f8(1.0f);
  const __m256 v_start = _mm256_add_ps(s.eye_v, _mm256_mul_ps(m, s.k_start));
  const __m256 v_end = _mm256_add_ps(s.eye_v, _mm256_mul_ps(m, s.kf));
  const __m256 up = _mm256_add_ps(_mm256_floor_ps(v_start), one);
  const __m256 down = _mm256_sub_ps(_mm256_ceil_ps(v_start), one);
  const __m256 rising = _mm256_cmp_ps(m, zero, _CMP_GT_OQ);
  const __m256 cv = _mm256_blendv_ps(down, up, rising);
  const __m256 crosses =
      _mm256_or_ps(_mm256_and_ps(rising, _mm256_cmp_ps(up, v_end, _CMP_LT_OQ)),
                   _mm256_and_ps(_mm256_cmp_ps(m, zero, _CMP_LT_OQ), _mm256_cmp_ps(down, v_end, _CMP_GT_OQ)));
  const __m256 valid = _mm256_and_ps(
      crosses, _mm256_and_ps(_mm256_cmp_ps(cv, s.v_min, _CMP_GE_OQ), _mm256_cmp_ps(cv, s.v_max, _CMP_LE_OQ)));
  const __m256 cv_clamped = min_of(max_of(cv, s.v_min), s.v_max);
  const __m256 kc = max_of(_mm256_mul_ps(_mm256_sub_ps(cv_clamped, s.eye_v), inv_m), f8(1.0e-6f));
  return {kc, _mm256_sub_ps(kc, s.kp), valid, _mm256_cvttps_epi32(cv_clamped)};
}

struct Cross8 {
  __m256 slope;
  __m256i v;
};

// The crossings' slopes from the heights read at them on lines n-1 (pa) and n (pb).
template <bool kFill>
HORIZON_AVX2 inline Cross8 cross8(const Step8& s, const CrossAt8& x, __m256 pa, __m256 pb, __m256 curv_k) {
  using namespace simd;
  pa = heights8<kFill>(pa, s.fill);
  pb = heights8<kFill>(pb, s.fill);
  const __m256 s_cross =
      _mm256_sub_ps(_mm256_div_ps(eye_relative8(pa, pb, x.tc, s.eye, s.eye_lo), x.kc), _mm256_mul_ps(curv_k, x.kc));
  return {min_of(s_cross, _mm256_blendv_ps(f8(kNoHorizon), f8(3.0e38f), x.valid)),
          _mm256_blendv_epi8(i8(-1), x.jc, _mm256_castps_si256(x.valid))};
}

// Where a group crosses line n: the bracket's first v index and the fraction past it.
struct LineAt8 {
  __m256 t;
  __m256i j0;
};

HORIZON_AVX2 inline LineAt8 line_at8(const Step8& s, __m256 m) {
  using namespace simd;
  const __m256 v = min_of(max_of(_mm256_add_ps(s.eye_v, _mm256_mul_ps(m, s.kf)), s.v_min), s.v_max);
  const __m256i j0 = mini_of(_mm256_cvttps_epi32(v), s.j_max);
  return {_mm256_sub_ps(v, _mm256_cvtepi32_ps(j0)), j0};
}

// The slopes where a group crosses line n, from the bracket's heights a and b.
template <bool kFill>
HORIZON_AVX2 inline __m256 line8(const Step8& s, const LineAt8& l, __m256 a, __m256 b, __m256 curv_k) {
  a = heights8<kFill>(a, s.fill);
  b = heights8<kFill>(b, s.fill);
  return _mm256_sub_ps(_mm256_mul_ps(simd::eye_relative8(a, b, l.t, s.eye, s.eye_lo), s.inv_kf),
                       _mm256_mul_ps(curv_k, s.kf));
}

// The code a crossing leaves: its v line when it beats the maximum, else `arg`.
HORIZON_AVX2 inline __m256i code8(const Cross8& c, __m256 h, __m256i arg) {
  const __m256 wins = _mm256_cmp_ps(c.slope, h, _CMP_GT_OQ);
  return _mm256_blendv_epi8(arg, _mm256_sub_epi32(simd::i8(-2), c.v), _mm256_castps_si256(wins));
}

HORIZON_AVX2 inline void fold8(__m256& best, __m256i& where, __m256 cross_slope, __m256i cross_v, __m256 s_line,
                               __m256i n) {
  const __m256 cross_wins = _mm256_cmp_ps(cross_slope, best, _CMP_GT_OQ);
  where = _mm256_blendv_epi8(where, _mm256_sub_epi32(simd::i8(-2), cross_v), _mm256_castps_si256(cross_wins));
  best = _mm256_blendv_ps(best, cross_slope, cross_wins);
  const __m256 line_wins = _mm256_cmp_ps(s_line, best, _CMP_GT_OQ);
  where = _mm256_blendv_epi8(where, n, _mm256_castps_si256(line_wins));
  best = _mm256_blendv_ps(best, s_line, line_wins);
}

HORIZON_AVX2 inline __m256i load8(const int* p) {
  return _mm256_loadu_si256(reinterpret_cast<const __m256i*>(p));
}
HORIZON_AVX2 inline void store8(int* p, __m256i x) {
  _mm256_storeu_si256(reinterpret_cast<__m256i*>(p), x);
}

template <bool kFill>
HORIZON_AVX2 int step_cross_avx2(const LineStep& ls, int count, const float* slope, const float* inv_slope,
                                 const float* curv_k, const float* prev, const float* cur, const float* h,
                                 const int* arg, float* cross_slope, int* cross_v, int* code) {
  const Step8 s = step8(ls);
  int i = 0;
  for (; i + 8 <= count; i += 8) {
    const CrossAt8 x = cross_at8(s, _mm256_loadu_ps(slope + i), _mm256_loadu_ps(inv_slope + i));
    const Reads8 read(s, x.jc, x.jc);
    const Cross8 c = cross8<kFill>(s, x, read.at(prev, x.jc), read.at(cur, x.jc), _mm256_loadu_ps(curv_k + i));
    _mm256_storeu_ps(cross_slope + i, c.slope);
    store8(cross_v + i, c.v);
    store8(code + i, code8(c, _mm256_loadu_ps(h + i), load8(arg + i)));
  }
  return i;
}

template <bool kFill>
HORIZON_AVX2 int step_line_avx2(const LineStep& ls, int count, const float* slope, const float* curv_k,
                                const float* cur, const float* cross_slope, const int* cross_v, float* h, int* arg,
                                int n) {
  const Step8 s = step8(ls);
  const __m256i line = simd::i8(n), one = simd::i8(1);
  int i = 0;
  for (; i + 8 <= count; i += 8) {
    const LineAt8 l = line_at8(s, _mm256_loadu_ps(slope + i));
    const __m256i j1 = _mm256_add_epi32(l.j0, one);
    const Reads8 read(s, l.j0, j1);
    const __m256 s_line = line8<kFill>(s, l, read.at(cur, l.j0), read.at(cur, j1), _mm256_loadu_ps(curv_k + i));
    __m256 best = _mm256_loadu_ps(h + i);
    __m256i where = load8(arg + i);
    fold8(best, where, _mm256_loadu_ps(cross_slope + i), load8(cross_v + i), s_line, line);
    _mm256_storeu_ps(h + i, best);
    store8(arg + i, where);
  }
  return i;
}

template <bool kFill>
HORIZON_AVX2 int step_rays_avx2(const LineStep& ls, int count, const float* slope, const float* inv_slope,
                                const float* curv_k, const float* prev, const float* cur, float* h, int* arg, int* code,
                                int n) {
  const Step8 s = step8(ls);
  const __m256i line = simd::i8(n), one = simd::i8(1);
  int i = 0;
  for (; i + 8 <= count; i += 8) {
    const __m256 m = _mm256_loadu_ps(slope + i), ck = _mm256_loadu_ps(curv_k + i);
    const CrossAt8 x = cross_at8(s, m, _mm256_loadu_ps(inv_slope + i));
    const LineAt8 l = line_at8(s, m);
    const __m256i j1 = _mm256_add_epi32(l.j0, one);
    const Reads8 read(s, simd::mini_of(x.jc, l.j0), simd::maxi_of(x.jc, j1));
    const Cross8 c = cross8<kFill>(s, x, read.at(prev, x.jc), read.at(cur, x.jc), ck);
    __m256 best = _mm256_loadu_ps(h + i);
    __m256i where = load8(arg + i);
    store8(code + i, code8(c, best, where));
    fold8(best, where, c.slope, c.v, line8<kFill>(s, l, read.at(cur, l.j0), read.at(cur, j1), ck), line);
    _mm256_storeu_ps(h + i, best);
    store8(arg + i, where);
  }
  return i;
}

// The AVX-512 forms: the AVX2 forms sixteen rays at a time, with mask
// registers for the comparisons. The last, partial group runs masked: its
// absent lanes read and write nothing.
struct Step16 {
  __m512 eye_v, k_start, kf, inv_kf, v_min, v_max, kp, eye, eye_lo, fill;
  __m512i zv, j_max;
  int run_last;
};

HORIZON_AVX512 inline Step16 step16(const LineStep& ls) {
  using namespace simd;
  const float inv_kf = 1.0f / ls.kf;
  return {f16(ls.eye_v), f16(ls.k_start), f16(ls.kf),   f16(inv_kf), f16(ls.v_min), f16(ls.v_max), f16(ls.kp),
          f16(ls.eye),   f16(ls.eye_lo),  f16(ls.fill), i16(ls.zv),  i16(ls.j_max), ls.run_last};
}

// Reads8 for sixteen lanes, of which `in` hold rays: a run is thirty-two
// positions (two loads of a line), picked by one two-register permute.
class Reads16 {
 public:
  HORIZON_AVX512 Reads16(const Step16& s, __mmask16 in, __m512i lowest, __m512i highest) : zv_(s.zv), in_(in) {
    if (s.run_last < 0 || in == 0) return;
    const int base = _mm_cvtsi128_si32(_mm512_castsi512_si128(lowest));  // lane 0, always in (as Reads8's)
    if (base < 0 || base + 31 > s.run_last) return;
    if ((_mm512_mask_cmpgt_epi32_mask(in, simd::i16(base), lowest) |
         _mm512_mask_cmpgt_epi32_mask(in, highest, simd::i16(base + 31))) != 0)
      return;
    base_ = base;
  }

  // line[v * zv] for each lane's v (0 in absent lanes when gathered).
  HORIZON_AVX512 __m512 at(const float* line, __m512i v) const {
    if (base_ < 0) return simd::gather_masked(line, _mm512_mullo_epi32(v, zv_), in_);
    return simd::pick16(simd::load_run16(line + base_), _mm512_sub_epi32(v, simd::i16(base_)));
  }

 private:
  __m512i zv_;
  __mmask16 in_;
  int base_ = -1;
};

struct Cross16 {
  __m512 slope;
  __m512i v;
};

template <bool kFill>
HORIZON_AVX512 inline __m512 heights16(__m512 v, __m512 fill) {
  if constexpr (kFill) return simd::fill_voids(v, fill);
  return v;
}

struct CrossAt16 {
  __m512 kc, tc;
  __mmask16 valid;
  __m512i jc;
};

HORIZON_AVX512 inline CrossAt16 cross_at16(const Step16& s, __m512 m, __m512 inv_m) {
  using namespace simd;
  const __m512 zero = _mm512_setzero_ps(), one = f16(1.0f);
  const __m512 v_start = _mm512_add_ps(s.eye_v, _mm512_mul_ps(m, s.k_start));
  const __m512 v_end = _mm512_add_ps(s.eye_v, _mm512_mul_ps(m, s.kf));
  const __m512 up = _mm512_add_ps(floor16(v_start), one);
  const __m512 down = _mm512_sub_ps(ceil16(v_start), one);
  const __mmask16 rising = _mm512_cmp_ps_mask(m, zero, _CMP_GT_OQ);
  const __m512 cv = _mm512_mask_blend_ps(rising, down, up);
  const __mmask16 crosses = (rising & _mm512_cmp_ps_mask(up, v_end, _CMP_LT_OQ)) |
                            (_mm512_cmp_ps_mask(m, zero, _CMP_LT_OQ) & _mm512_cmp_ps_mask(down, v_end, _CMP_GT_OQ));
  const __mmask16 valid =
      crosses & _mm512_cmp_ps_mask(cv, s.v_min, _CMP_GE_OQ) & _mm512_cmp_ps_mask(cv, s.v_max, _CMP_LE_OQ);
  const __m512 cv_clamped = min_of(max_of(cv, s.v_min), s.v_max);
  const __m512 kc = max_of(_mm512_mul_ps(_mm512_sub_ps(cv_clamped, s.eye_v), inv_m), f16(1.0e-6f));
  return {kc, _mm512_sub_ps(kc, s.kp), valid, _mm512_cvttps_epi32(cv_clamped)};
}

template <bool kFill>
HORIZON_AVX512 inline Cross16 cross16(const Step16& s, const CrossAt16& x, __m512 pa, __m512 pb, __m512 curv_k) {
  using namespace simd;
  pa = heights16<kFill>(pa, s.fill);
  pb = heights16<kFill>(pb, s.fill);
  const __m512 s_cross =
      _mm512_sub_ps(_mm512_div_ps(eye_relative16(pa, pb, x.tc, s.eye, s.eye_lo), x.kc), _mm512_mul_ps(curv_k, x.kc));
  return {min_of(s_cross, _mm512_mask_blend_ps(x.valid, f16(kNoHorizon), f16(3.0e38f))),
          _mm512_mask_blend_epi32(x.valid, i16(-1), x.jc)};
}

struct LineAt16 {
  __m512 t;
  __m512i j0;
};

HORIZON_AVX512 inline LineAt16 line_at16(const Step16& s, __m512 m) {
  using namespace simd;
  const __m512 v = min_of(max_of(_mm512_add_ps(s.eye_v, _mm512_mul_ps(m, s.kf)), s.v_min), s.v_max);
  const __m512i j0 = mini_of(_mm512_cvttps_epi32(v), s.j_max);
  return {_mm512_sub_ps(v, _mm512_cvtepi32_ps(j0)), j0};
}

template <bool kFill>
HORIZON_AVX512 inline __m512 line16(const Step16& s, const LineAt16& l, __m512 a, __m512 b, __m512 curv_k) {
  a = heights16<kFill>(a, s.fill);
  b = heights16<kFill>(b, s.fill);
  return _mm512_sub_ps(_mm512_mul_ps(simd::eye_relative16(a, b, l.t, s.eye, s.eye_lo), s.inv_kf),
                       _mm512_mul_ps(curv_k, s.kf));
}

HORIZON_AVX512 inline __m512i code16(const Cross16& c, __m512 h, __m512i arg) {
  const __mmask16 wins = _mm512_cmp_ps_mask(c.slope, h, _CMP_GT_OQ);
  return _mm512_mask_blend_epi32(wins, arg, _mm512_sub_epi32(simd::i16(-2), c.v));
}

HORIZON_AVX512 inline void fold16(__m512& best, __m512i& where, __m512 cross_slope, __m512i cross_v, __m512 s_line,
                                  __m512i n) {
  const __mmask16 cross_wins = _mm512_cmp_ps_mask(cross_slope, best, _CMP_GT_OQ);
  where = _mm512_mask_blend_epi32(cross_wins, where, _mm512_sub_epi32(simd::i16(-2), cross_v));
  best = _mm512_mask_blend_ps(cross_wins, best, cross_slope);
  const __mmask16 line_wins = _mm512_cmp_ps_mask(s_line, best, _CMP_GT_OQ);
  where = _mm512_mask_blend_epi32(line_wins, where, n);
  best = _mm512_mask_blend_ps(line_wins, best, s_line);
}

// The lanes of the group starting at i that hold rays.
HORIZON_AVX512 inline __mmask16 lanes16(int i, int count) {
  return count - i >= 16 ? __mmask16(0xffff) : __mmask16((1u << (count - i)) - 1);
}

template <bool kFill>
HORIZON_AVX512 void step_cross_avx512(const LineStep& ls, int count, const float* slope, const float* inv_slope,
                                      const float* curv_k, const float* prev, const float* cur, const float* h,
                                      const int* arg, float* cross_slope, int* cross_v, int* code) {
  const Step16 s = step16(ls);
  for (int i = 0; i < count; i += 16) {
    const __mmask16 in = lanes16(i, count);
    const CrossAt16 x = cross_at16(s, _mm512_maskz_loadu_ps(in, slope + i), _mm512_maskz_loadu_ps(in, inv_slope + i));
    const Reads16 read(s, in, x.jc, x.jc);
    const Cross16 c =
        cross16<kFill>(s, x, read.at(prev, x.jc), read.at(cur, x.jc), _mm512_maskz_loadu_ps(in, curv_k + i));
    _mm512_mask_storeu_ps(cross_slope + i, in, c.slope);
    _mm512_mask_storeu_epi32(cross_v + i, in, c.v);
    _mm512_mask_storeu_epi32(code + i, in,
                             code16(c, _mm512_maskz_loadu_ps(in, h + i), _mm512_maskz_loadu_epi32(in, arg + i)));
  }
}

template <bool kFill>
HORIZON_AVX512 void step_line_avx512(const LineStep& ls, int count, const float* slope, const float* curv_k,
                                     const float* cur, const float* cross_slope, const int* cross_v, float* h, int* arg,
                                     int n) {
  const Step16 s = step16(ls);
  const __m512i line = simd::i16(n), one = simd::i16(1);
  for (int i = 0; i < count; i += 16) {
    const __mmask16 in = lanes16(i, count);
    const LineAt16 l = line_at16(s, _mm512_maskz_loadu_ps(in, slope + i));
    const __m512i j1 = _mm512_add_epi32(l.j0, one);
    const Reads16 read(s, in, l.j0, j1);
    const __m512 s_line =
        line16<kFill>(s, l, read.at(cur, l.j0), read.at(cur, j1), _mm512_maskz_loadu_ps(in, curv_k + i));
    __m512 best = _mm512_maskz_loadu_ps(in, h + i);
    __m512i where = _mm512_maskz_loadu_epi32(in, arg + i);
    fold16(best, where, _mm512_maskz_loadu_ps(in, cross_slope + i), _mm512_maskz_loadu_epi32(in, cross_v + i), s_line,
           line);
    _mm512_mask_storeu_ps(h + i, in, best);
    _mm512_mask_storeu_epi32(arg + i, in, where);
  }
}

template <bool kFill>
HORIZON_AVX512 void step_rays_avx512(const LineStep& ls, int count, const float* slope, const float* inv_slope,
                                     const float* curv_k, const float* prev, const float* cur, float* h, int* arg,
                                     int* code, int n) {
  const Step16 s = step16(ls);
  const __m512i line = simd::i16(n), one = simd::i16(1);
  for (int i = 0; i < count; i += 16) {
    const __mmask16 in = lanes16(i, count);
    const __m512 m = _mm512_maskz_loadu_ps(in, slope + i), ck = _mm512_maskz_loadu_ps(in, curv_k + i);
    const CrossAt16 x = cross_at16(s, m, _mm512_maskz_loadu_ps(in, inv_slope + i));
    const LineAt16 l = line_at16(s, m);
    const __m512i j1 = _mm512_add_epi32(l.j0, one);
    const Reads16 read(s, in, simd::mini_of(x.jc, l.j0), simd::maxi_of(x.jc, j1));
    const Cross16 c = cross16<kFill>(s, x, read.at(prev, x.jc), read.at(cur, x.jc), ck);
    __m512 best = _mm512_maskz_loadu_ps(in, h + i);
    __m512i where = _mm512_maskz_loadu_epi32(in, arg + i);
    _mm512_mask_storeu_epi32(code + i, in, code16(c, best, where));
    fold16(best, where, c.slope, c.v, line16<kFill>(s, l, read.at(cur, l.j0), read.at(cur, j1), ck), line);
    _mm512_mask_storeu_ps(h + i, in, best);
    _mm512_mask_storeu_epi32(arg + i, in, where);
  }
}

}  // namespace
#endif

namespace {
bool has_fill(const LineStep& ls) {
  return !std::isnan(ls.fill);
}
}  // namespace

// Each entry point: AVX-512 takes every ray; AVX2 groups of eight, then the
// scalar loop the rest; the vector forms without the void fill's blend when
// the view has none.

void step_cross(const LineStep& ls, int count, const float* slope, const float* inv_slope, const float* curv_k,
                const float* prev, const float* cur, const float* h, const int* arg, float* cross_slope, int* cross_v,
                int* code) {
  int done = 0;
#ifdef HORIZON_SIMD_AVX2
  if (simd::has_avx512())
    return has_fill(ls) ? step_cross_avx512<true>(ls, count, slope, inv_slope, curv_k, prev, cur, h, arg, cross_slope,
                                                  cross_v, code)
                        : step_cross_avx512<false>(ls, count, slope, inv_slope, curv_k, prev, cur, h, arg, cross_slope,
                                                   cross_v, code);
  if (simd::has_avx2())
    done = has_fill(ls) ? step_cross_avx2<true>(ls, count, slope, inv_slope, curv_k, prev, cur, h, arg, cross_slope,
                                                cross_v, code)
                        : step_cross_avx2<false>(ls, count, slope, inv_slope, curv_k, prev, cur, h, arg, cross_slope,
                                                 cross_v, code);
#endif
  step_cross_scalar(ls, count - done, slope + done, inv_slope + done, curv_k + done, prev, cur, h + done, arg + done,
                    cross_slope + done, cross_v + done, code + done);
}

void step_line(const LineStep& ls, int count, const float* slope, const float* curv_k, const float* cur,
               const float* cross_slope, const int* cross_v, float* h, int* arg, int n) {
  int done = 0;
#ifdef HORIZON_SIMD_AVX2
  if (simd::has_avx512())
    return has_fill(ls) ? step_line_avx512<true>(ls, count, slope, curv_k, cur, cross_slope, cross_v, h, arg, n)
                        : step_line_avx512<false>(ls, count, slope, curv_k, cur, cross_slope, cross_v, h, arg, n);
  if (simd::has_avx2())
    done = has_fill(ls) ? step_line_avx2<true>(ls, count, slope, curv_k, cur, cross_slope, cross_v, h, arg, n)
                        : step_line_avx2<false>(ls, count, slope, curv_k, cur, cross_slope, cross_v, h, arg, n);
#endif
  step_line_scalar(ls, count - done, slope + done, curv_k + done, cur, cross_slope + done, cross_v + done, h + done,
                   arg + done, n);
}

void step_rays(const LineStep& ls, int count, const float* slope, const float* inv_slope, const float* curv_k,
               const float* prev, const float* cur, float* h, int* arg, int* code, int n) {
  int done = 0;
#ifdef HORIZON_SIMD_AVX2
  if (simd::has_avx512())
    return has_fill(ls) ? step_rays_avx512<true>(ls, count, slope, inv_slope, curv_k, prev, cur, h, arg, code, n)
                        : step_rays_avx512<false>(ls, count, slope, inv_slope, curv_k, prev, cur, h, arg, code, n);
  if (simd::has_avx2())
    done = has_fill(ls) ? step_rays_avx2<true>(ls, count, slope, inv_slope, curv_k, prev, cur, h, arg, code, n)
                        : step_rays_avx2<false>(ls, count, slope, inv_slope, curv_k, prev, cur, h, arg, code, n);
#endif
  step_rays_scalar(ls, count - done, slope + done, inv_slope + done, curv_k + done, prev, cur, h + done, arg + done,
                   code + done, n);
}

}  // namespace horizon::visibility::sweep
