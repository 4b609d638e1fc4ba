// The cull's vector kernels (cull_lanes.hpp): AVX-512 (eight doubles, mask
// registers) and AVX2 (four doubles, masks as bit sets expanded when a
// gather or a blend needs them), each the scalar twin's arithmetic of
// cull.cpp lane by lane. The file is built with -ffp-contract=off (all of
// horizon_mesh is): a * b + c must round twice here as it does there.
//
// The frustum. The scalar test asks whether the circle's arc of
// directions from the camera, [a − h, a + h] with h = asin(ρ / d), misses
// the view [from, from + width]. Two arcs whose half lengths add to less
// than π miss each other exactly when the angle φ between their middles
// exceeds the sum, here w + h with w = width / 2. With b the view's
// bisector and (fx, fy) the centre seen from the camera,
//   g = (fx, fy)·b − (cos w · √(d² − ρ²) − sin w · ρ) = d (cos φ − cos(w + h)),
// computed from the same fx, fy, ρ as the scalar test. The lanes call a
// circle outside when g < −10⁻⁸ d (so φ exceeds w + h by more than 10⁻⁸
// rad) and h + w < π by more than 10⁻⁸ (ρ / d under radius_limit), and
// inside when g > 10⁻⁸ d or the camera is well inside the circle; the
// rounding of g (at worst about 10⁻¹¹ d, near a tangent where √(d² − ρ²) is
// least exact: d² exceeds ρ² by at least 10⁻⁹ of it here) and of the
// scalar test's atan2, asin and sums (about 10⁻¹⁴ rad) cannot turn either
// answer. Every other lane, within those margins of an edge, runs the
// scalar test itself.
#include "mesh/cull_lanes.hpp"

#include "common/simd_isa.hpp"

namespace horizon::mesh {

#ifdef HORIZON_SIMD_AVX2
namespace {

constexpr double kCertainCircle = 1e-9;  // d² against ρ² (1 ± this)
constexpr double kCertainAngle = 1e-8;   // g against ± this · d

// ---------------------------------------------------------------- AVX-512

struct Lanes8 {
  const CullFrame& f;
  const PreparedMesh& m;
  __m512i g;  // the groups, in the low eight 32-bit lanes
};

HORIZON_AVX512 inline __m512d set8(double x) {
  return _mm512_set1_pd(x);
}
HORIZON_AVX512 inline __m512i seti8(int x) {
  return _mm512_set1_epi32(x);
}
HORIZON_AVX512 inline __m256i low(__m512i x) {
  return _mm512_castsi512_si256(x);
}
HORIZON_AVX512 inline __m512d gather8(__mmask8 k, __m512i index, const double* base) {
  return _mm512_mask_i32gather_pd(_mm512_setzero_pd(), k, low(index), base, 8);
}
HORIZON_AVX512 inline __m512i gatheri8(__mmask8 k, __m512i index, const std::uint32_t* base) {
  return _mm512_mask_i32gather_epi32(_mm512_setzero_si512(), static_cast<__mmask16>(k), index, base, 4);
}
HORIZON_AVX512 inline __mmask8 lt_i(__m512i a, __m512i b) {
  return static_cast<__mmask8>(_mm512_cmplt_epi32_mask(a, b));
}
HORIZON_AVX512 inline __mmask8 eq_i(__m512i a, __m512i b) {
  return static_cast<__mmask8>(_mm512_cmpeq_epi32_mask(a, b));
}

// PreparedMesh::sector_of lane by lane: pseudo_angle, then how many
// sector starts are not above it, less one (upper_bound's answer, NaN
// included: it compares above none, so it lands in the last sector).
HORIZON_AVX512 __m512i sector_of8(const PreparedMesh& m, __m512d x, __m512d y) {
  const __m512d sign = set8(-0.0);
  const __m512d ax = _mm512_castsi512_pd(_mm512_andnot_si512(_mm512_castpd_si512(sign), _mm512_castpd_si512(x)));
  const __m512d ay = _mm512_castsi512_pd(_mm512_andnot_si512(_mm512_castpd_si512(sign), _mm512_castpd_si512(y)));
  const __m512d q = _mm512_div_pd(x, _mm512_add_pd(ax, ay));
  const __mmask8 up = _mm512_cmp_pd_mask(y, _mm512_setzero_pd(), _CMP_GE_OQ);
  const __m512d p = _mm512_mask_blend_pd(up, _mm512_add_pd(set8(3.0), q), _mm512_sub_pd(set8(1.0), q));
  const __m512i one = seti8(1);
  __m512i count = _mm512_setzero_si512();
  for (double start : m.sector_starts) {
    const __mmask8 below = _mm512_cmp_pd_mask(p, set8(start), _CMP_NLT_UQ);
    count = _mm512_mask_add_epi32(count, below, count, one);
  }
  return _mm512_sub_epi32(count, one);
}

// hidden_in for the lanes of k: chain `chain`, sector `sector`.
HORIZON_AVX512 __mmask8 hidden_in8(const Lanes8& l, __mmask8 k, __m512i chain, __m512i sector) {
  const PreparedMesh& m = l.m;
  const __m512i one = seti8(1);
  const __m512i begin = gatheri8(k, chain, m.chain_begin.data());
  const __m512i end = gatheri8(k, _mm512_add_epi32(chain, one), m.chain_begin.data());
  const __m512d t = gather8(k, sector, l.f.sector_t);
  __mmask8 ok = k & static_cast<__mmask8>(~eq_i(begin, end));
  ok &= _mm512_cmp_pd_mask(t, gather8(ok, begin, m.corner_t.data()), _CMP_NLT_UQ);
  __m512i j = begin;
  for (;;) {
    const __m512i next = _mm512_add_epi32(j, one);
    __mmask8 more = ok & lt_i(next, end);
    if (!more) break;
    more &= _mm512_cmp_pd_mask(gather8(more, next, m.corner_t.data()), t, _CMP_LE_OQ);
    if (!more) break;
    j = _mm512_mask_mov_epi32(j, more, next);
  }
  if (!ok) return 0;
  const __m512i next = _mm512_add_epi32(j, one);
  const __mmask8 ray = ok & eq_i(next, end);
  const __mmask8 segment = ok & static_cast<__mmask8>(~ray);
  const __m512d at = gather8(ok, j, m.corner_t.data()), az = gather8(ok, j, m.corner_z.data());
  const __m512d ray_height =
      _mm512_add_pd(az, _mm512_mul_pd(gather8(ray, chain, m.chain_slope.data()), _mm512_sub_pd(t, at)));
  const __m512d nt = gather8(segment, next, m.corner_t.data()), nz = gather8(segment, next, m.corner_z.data());
  const __m512d segment_height = _mm512_add_pd(
      az, _mm512_mul_pd(_mm512_sub_pd(nz, az), _mm512_div_pd(_mm512_sub_pd(t, at), _mm512_sub_pd(nt, at))));
  const __m512d height = _mm512_mask_blend_pd(ray, segment_height, ray_height);
  return ok & _mm512_cmp_pd_mask(set8(l.f.camera.z), height, _CMP_LE_OQ);
}

// hidden() for the lanes of k.
HORIZON_AVX512 __mmask8 hidden8(const Lanes8& l, __mmask8 k, __m512d dx, __m512d dy, __m512d d2, __m512d r,
                                __mmask8 out) {
  const int s = l.m.sectors;
  const __m512d d = _mm512_sqrt_pd(d2);
  const __m512d sine = _mm512_add_pd(_mm512_mul_pd(_mm512_div_pd(r, d), set8(1 + 1e-9)), set8(1e-12));
  const __mmask8 wide = out & _mm512_cmp_pd_mask(sine, set8(1.0), _CMP_LT_OQ);
  const __m512d cosine = _mm512_sqrt_pd(_mm512_sub_pd(set8(1.0), _mm512_mul_pd(sine, sine)));
  const __m512d ux = _mm512_div_pd(dx, d), uy = _mm512_div_pd(dy, d);
  const __m512i vs = seti8(s);
  __m512i first = _mm512_setzero_si512(), count = vs;
  if (wide) {
    const __m512i a = sector_of8(l.m, _mm512_add_pd(_mm512_mul_pd(ux, cosine), _mm512_mul_pd(uy, sine)),
                                 _mm512_sub_pd(_mm512_mul_pd(uy, cosine), _mm512_mul_pd(ux, sine)));
    const __m512i b = sector_of8(l.m, _mm512_sub_pd(_mm512_mul_pd(ux, cosine), _mm512_mul_pd(uy, sine)),
                                 _mm512_add_pd(_mm512_mul_pd(uy, cosine), _mm512_mul_pd(ux, sine)));
    __m512i span = _mm512_add_epi32(_mm512_sub_epi32(b, a), vs);  // (last − first + s) % s, for both in [0, s)
    span = _mm512_mask_sub_epi32(span, static_cast<__mmask16>(~lt_i(span, vs)), span, vs);
    first = _mm512_mask_mov_epi32(first, wide, a);
    count = _mm512_mask_mov_epi32(count, wide, _mm512_add_epi32(span, seti8(1)));
  }
  const __m512i base = _mm512_mullo_epi32(l.g, vs);
  __mmask8 hid = k;
  __m512i sector = first;
  for (int i = 0;; ++i) {
    const __mmask8 lanes = hid & lt_i(seti8(i), count);
    if (!lanes) break;
    const __mmask8 in = hidden_in8(l, lanes, _mm512_add_epi32(base, sector), sector);
    hid &= static_cast<__mmask8>(~(lanes & static_cast<__mmask8>(~in)));
    sector = _mm512_add_epi32(sector, seti8(1));
    sector = _mm512_mask_sub_epi32(sector, static_cast<__mmask16>(~lt_i(sector, vs)), sector, vs);
  }
  return hid;
}

// walled() for the lanes of k.
HORIZON_AVX512 __mmask8 walled8(const Lanes8& l, __mmask8 k, __m512d dx, __m512d dy, __m512d d2, __m512d r,
                                __mmask8 out) {
  const PreparedMesh& m = l.m;
  const __m512i one = seti8(1);
  const __m512d d = _mm512_sqrt_pd(d2);
  __mmask8 ok = k & out & _mm512_cmp_pd_mask(d, r, _CMP_NLE_UQ);
  if (!ok) return 0;
  const __m512i chain = _mm512_add_epi32(_mm512_mullo_epi32(l.g, seti8(m.sectors)), sector_of8(m, dx, dy));
  const __m512i begin = gatheri8(ok, chain, m.wall_begin.data());
  const __m512i end = gatheri8(ok, _mm512_add_epi32(chain, one), m.wall_begin.data());
  ok &= static_cast<__mmask8>(~eq_i(begin, end));
  ok &= _mm512_cmp_pd_mask(gather8(ok, begin, m.wall_radius.data()), d, _CMP_NGE_UQ);
  __m512i best = begin;
  for (;;) {
    const __m512i next = _mm512_add_epi32(best, one);
    __mmask8 more = ok & lt_i(next, end);
    if (!more) break;
    more &= _mm512_cmp_pd_mask(gather8(more, next, m.wall_radius.data()), d, _CMP_LT_OQ);
    if (!more) break;
    best = _mm512_mask_mov_epi32(best, more, next);
  }
  if (!ok) return 0;
  const __m512d bound = _mm512_add_pd(gather8(ok, l.g, m.group_top.data()),
                                      _mm512_mul_pd(gather8(ok, best, m.wall_slope.data()), _mm512_sub_pd(d, r)));
  return ok & _mm512_cmp_pd_mask(set8(l.f.camera.z), bound, _CMP_LT_OQ);
}

// The frustum for all eight lanes (the header's argument); ids for the
// lanes left to the scalar test.
HORIZON_AVX512 __mmask8 frustum8(const Lanes8& l, const std::uint32_t* ids, __m512d x, __m512d y, __m512d d2,
                                 __m512d r) {
  const CullFrame& f = l.f;
  const __m512d fx = _mm512_sub_pd(x, set8(f.camera.x)), fy = _mm512_sub_pd(y, set8(f.camera.y));
  const __m512d r2 = _mm512_mul_pd(r, r);
  const __mmask8 in_circle = _mm512_cmp_pd_mask(d2, _mm512_mul_pd(r2, set8(1 - kCertainCircle)), _CMP_LT_OQ);
  const __mmask8 out_circle = _mm512_cmp_pd_mask(d2, _mm512_mul_pd(r2, set8(1 + kCertainCircle)), _CMP_GT_OQ);
  const __m512d d = _mm512_sqrt_pd(d2);
  const __m512d g = _mm512_sub_pd(
      _mm512_add_pd(_mm512_mul_pd(fx, set8(f.bx)), _mm512_mul_pd(fy, set8(f.by))),
      _mm512_sub_pd(_mm512_mul_pd(set8(f.cos_half), _mm512_sqrt_pd(_mm512_sub_pd(d2, r2))),
                    _mm512_mul_pd(set8(f.sin_half), r)));
  const __m512d margin = _mm512_mul_pd(d, set8(kCertainAngle));
  __mmask8 outside = out_circle & _mm512_cmp_pd_mask(g, _mm512_sub_pd(_mm512_setzero_pd(), margin), _CMP_LT_OQ) &
                     _mm512_cmp_pd_mask(r, _mm512_mul_pd(set8(f.radius_limit), d), _CMP_LT_OQ);
  const __mmask8 inside = in_circle | (out_circle & _mm512_cmp_pd_mask(g, margin, _CMP_GT_OQ));
  unsigned unsure = 0xffu & ~static_cast<unsigned>(outside | inside);
  while (unsure) {
    const int i = __builtin_ctz(unsure);
    unsure &= unsure - 1;
    if (outside_view(l.m.groups[ids[i]].circle, f.camera, f.view_from, f.view_width))
      outside |= static_cast<__mmask8>(1u << i);
  }
  return outside;
}

}  // namespace

HORIZON_AVX512 void cull_lanes_avx512(const CullFrame& f, const std::uint32_t* ids, std::size_t n,
                                      std::uint8_t* verdict) {
  const PreparedMesh& m = *f.mesh;
  const GroupColumns& c = m.columns;
  for (std::size_t at = 0; at < n; at += 8) {
    const Lanes8 l{f, m, _mm512_zextsi256_si512(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(ids + at)))};
    const __m512d x = gather8(0xff, l.g, c.x.data()), y = gather8(0xff, l.g, c.y.data());
    const __m512d r = gather8(0xff, l.g, c.radius.data());
    const __m512d dx = _mm512_sub_pd(set8(f.camera.x), x), dy = _mm512_sub_pd(set8(f.camera.y), y);
    const __m512d d2 = _mm512_add_pd(_mm512_mul_pd(dx, dx), _mm512_mul_pd(dy, dy));
    const __mmask8 out = _mm512_cmp_pd_mask(d2, _mm512_mul_pd(r, r), _CMP_GT_OQ);
    const __mmask8 framed = f.frustum ? frustum8(l, ids + at, x, y, d2, r) : __mmask8{0};
    const __mmask8 k = static_cast<__mmask8>(~framed);
    __mmask8 culled = 0;
    if (k) culled = f.mode == CullMode::kConservative ? walled8(l, k, dx, dy, d2, r, out) : hidden8(l, k, dx, dy, d2, r, out);
    for (int i = 0; i < 8; ++i)
      verdict[at + static_cast<std::size_t>(i)] = (framed >> i & 1) ? kFrustumCulled : (culled >> i & 1) ? kRegionCulled : kOpen;
  }
}

// ---------------------------------------------------------------- AVX2
//
// Four lanes; a mask is a 4-bit set, widened to a vector where a gather
// or a blend takes one.

namespace {

struct Lanes4 {
  const CullFrame& f;
  const PreparedMesh& m;
  __m128i g;
};

HORIZON_AVX2 inline __m256d set4(double x) {
  return _mm256_set1_pd(x);
}
HORIZON_AVX2 inline __m128i seti4(int x) {
  return _mm_set1_epi32(x);
}
HORIZON_AVX2 inline __m128i mask_i(unsigned k) {
  return _mm_cmpgt_epi32(_mm_and_si128(_mm_set1_epi32(static_cast<int>(k)), _mm_setr_epi32(1, 2, 4, 8)),
                         _mm_setzero_si128());
}
HORIZON_AVX2 inline __m256d mask_d(unsigned k) {
  return _mm256_castsi256_pd(_mm256_cvtepi32_epi64(mask_i(k)));
}
HORIZON_AVX2 inline unsigned bits(__m256d m) {
  return static_cast<unsigned>(_mm256_movemask_pd(m));
}
HORIZON_AVX2 inline unsigned bits(__m128i m) {
  return static_cast<unsigned>(_mm_movemask_ps(_mm_castsi128_ps(m)));
}
HORIZON_AVX2 inline __m256d gather4(unsigned k, __m128i index, const double* base) {
  return _mm256_mask_i32gather_pd(_mm256_setzero_pd(), base, index, mask_d(k), 8);
}
HORIZON_AVX2 inline __m128i gatheri4(unsigned k, __m128i index, const std::uint32_t* base) {
  return _mm_mask_i32gather_epi32(_mm_setzero_si128(), reinterpret_cast<const int*>(base), index, mask_i(k), 4);
}
HORIZON_AVX2 inline __m256d blend4(unsigned k, __m256d a, __m256d b) {  // b where k, else a
  return _mm256_blendv_pd(a, b, mask_d(k));
}
HORIZON_AVX2 inline __m128i blendi4(unsigned k, __m128i a, __m128i b) {
  return _mm_blendv_epi8(a, b, mask_i(k));
}
HORIZON_AVX2 inline unsigned lt_i(__m128i a, __m128i b) {
  return bits(_mm_cmplt_epi32(a, b));
}
HORIZON_AVX2 inline unsigned eq_i(__m128i a, __m128i b) {
  return bits(_mm_cmpeq_epi32(a, b));
}
// (a − s if a >= s) lane by lane, for a in [0, 2s).
HORIZON_AVX2 inline __m128i wrap_i(__m128i a, __m128i s) {
  return blendi4(~lt_i(a, s) & 0xfu, a, _mm_sub_epi32(a, s));
}

HORIZON_AVX2 __m128i sector_of4(const PreparedMesh& m, __m256d x, __m256d y) {
  const __m256d sign = set4(-0.0);
  const __m256d q = _mm256_div_pd(x, _mm256_add_pd(_mm256_andnot_pd(sign, x), _mm256_andnot_pd(sign, y)));
  const __m256d up = _mm256_cmp_pd(y, _mm256_setzero_pd(), _CMP_GE_OQ);
  const __m256d p = _mm256_blendv_pd(_mm256_add_pd(set4(3.0), q), _mm256_sub_pd(set4(1.0), q), up);
  // Each start not above p adds a lane's all-ones (−1) to a 64-bit count.
  __m256i count = _mm256_setzero_si256();
  for (double start : m.sector_starts)
    count = _mm256_sub_epi64(count, _mm256_castpd_si256(_mm256_cmp_pd(p, set4(start), _CMP_NLT_UQ)));
  const __m128i narrow =
      _mm256_castsi256_si128(_mm256_permutevar8x32_epi32(count, _mm256_setr_epi32(0, 2, 4, 6, 0, 2, 4, 6)));
  return _mm_sub_epi32(narrow, seti4(1));
}

HORIZON_AVX2 unsigned hidden_in4(const Lanes4& l, unsigned k, __m128i chain, __m128i sector) {
  const PreparedMesh& m = l.m;
  const __m128i one = seti4(1);
  const __m128i begin = gatheri4(k, chain, m.chain_begin.data());
  const __m128i end = gatheri4(k, _mm_add_epi32(chain, one), m.chain_begin.data());
  const __m256d t = gather4(k, sector, l.f.sector_t);
  unsigned ok = k & ~eq_i(begin, end);
  ok &= bits(_mm256_cmp_pd(t, gather4(ok, begin, m.corner_t.data()), _CMP_NLT_UQ));
  __m128i j = begin;
  for (;;) {
    const __m128i next = _mm_add_epi32(j, one);
    unsigned more = ok & lt_i(next, end);
    if (!more) break;
    more &= bits(_mm256_cmp_pd(gather4(more, next, m.corner_t.data()), t, _CMP_LE_OQ));
    if (!more) break;
    j = blendi4(more, j, next);
  }
  if (!ok) return 0;
  const __m128i next = _mm_add_epi32(j, one);
  const unsigned ray = ok & eq_i(next, end);
  const unsigned segment = ok & ~ray;
  const __m256d at = gather4(ok, j, m.corner_t.data()), az = gather4(ok, j, m.corner_z.data());
  const __m256d ray_height =
      _mm256_add_pd(az, _mm256_mul_pd(gather4(ray, chain, m.chain_slope.data()), _mm256_sub_pd(t, at)));
  const __m256d nt = gather4(segment, next, m.corner_t.data()), nz = gather4(segment, next, m.corner_z.data());
  const __m256d segment_height = _mm256_add_pd(
      az, _mm256_mul_pd(_mm256_sub_pd(nz, az), _mm256_div_pd(_mm256_sub_pd(t, at), _mm256_sub_pd(nt, at))));
  const __m256d height = blend4(ray, segment_height, ray_height);
  return ok & bits(_mm256_cmp_pd(set4(l.f.camera.z), height, _CMP_LE_OQ));
}

HORIZON_AVX2 unsigned hidden4(const Lanes4& l, unsigned k, __m256d dx, __m256d dy, __m256d d2, __m256d r,
                              unsigned out) {
  const __m256d d = _mm256_sqrt_pd(d2);
  const __m256d sine = _mm256_add_pd(_mm256_mul_pd(_mm256_div_pd(r, d), set4(1 + 1e-9)), set4(1e-12));
  const unsigned wide = out & bits(_mm256_cmp_pd(sine, set4(1.0), _CMP_LT_OQ));
  const __m256d cosine = _mm256_sqrt_pd(_mm256_sub_pd(set4(1.0), _mm256_mul_pd(sine, sine)));
  const __m256d ux = _mm256_div_pd(dx, d), uy = _mm256_div_pd(dy, d);
  const __m128i vs = seti4(l.m.sectors);
  __m128i first = _mm_setzero_si128(), count = vs;
  if (wide) {
    const __m128i a = sector_of4(l.m, _mm256_add_pd(_mm256_mul_pd(ux, cosine), _mm256_mul_pd(uy, sine)),
                                 _mm256_sub_pd(_mm256_mul_pd(uy, cosine), _mm256_mul_pd(ux, sine)));
    const __m128i b = sector_of4(l.m, _mm256_sub_pd(_mm256_mul_pd(ux, cosine), _mm256_mul_pd(uy, sine)),
                                 _mm256_add_pd(_mm256_mul_pd(uy, cosine), _mm256_mul_pd(ux, sine)));
    const __m128i span = wrap_i(_mm_add_epi32(_mm_sub_epi32(b, a), vs), vs);
    first = blendi4(wide, first, a);
    count = blendi4(wide, count, _mm_add_epi32(span, seti4(1)));
  }
  const __m128i base = _mm_mullo_epi32(l.g, vs);
  unsigned hid = k;
  __m128i sector = first;
  for (int i = 0;; ++i) {
    const unsigned lanes = hid & lt_i(seti4(i), count);
    if (!lanes) break;
    hid &= ~(lanes & ~hidden_in4(l, lanes, _mm_add_epi32(base, sector), sector));
    sector = wrap_i(_mm_add_epi32(sector, seti4(1)), vs);
  }
  return hid;
}

HORIZON_AVX2 unsigned walled4(const Lanes4& l, unsigned k, __m256d dx, __m256d dy, __m256d d2, __m256d r,
                              unsigned out) {
  const PreparedMesh& m = l.m;
  const __m128i one = seti4(1);
  const __m256d d = _mm256_sqrt_pd(d2);
  unsigned ok = k & out & bits(_mm256_cmp_pd(d, r, _CMP_NLE_UQ));
  if (!ok) return 0;
  const __m128i chain = _mm_add_epi32(_mm_mullo_epi32(l.g, seti4(m.sectors)), sector_of4(m, dx, dy));
  const __m128i begin = gatheri4(ok, chain, m.wall_begin.data());
  const __m128i end = gatheri4(ok, _mm_add_epi32(chain, one), m.wall_begin.data());
  ok &= ~eq_i(begin, end);
  ok &= bits(_mm256_cmp_pd(gather4(ok, begin, m.wall_radius.data()), d, _CMP_NGE_UQ));
  __m128i best = begin;
  for (;;) {
    const __m128i next = _mm_add_epi32(best, one);
    unsigned more = ok & lt_i(next, end);
    if (!more) break;
    more &= bits(_mm256_cmp_pd(gather4(more, next, m.wall_radius.data()), d, _CMP_LT_OQ));
    if (!more) break;
    best = blendi4(more, best, next);
  }
  if (!ok) return 0;
  const __m256d bound = _mm256_add_pd(gather4(ok, l.g, m.group_top.data()),
                                      _mm256_mul_pd(gather4(ok, best, m.wall_slope.data()), _mm256_sub_pd(d, r)));
  return ok & bits(_mm256_cmp_pd(set4(l.f.camera.z), bound, _CMP_LT_OQ));
}

HORIZON_AVX2 unsigned frustum4(const Lanes4& l, const std::uint32_t* ids, __m256d x, __m256d y, __m256d d2,
                               __m256d r) {
  const CullFrame& f = l.f;
  const __m256d fx = _mm256_sub_pd(x, set4(f.camera.x)), fy = _mm256_sub_pd(y, set4(f.camera.y));
  const __m256d r2 = _mm256_mul_pd(r, r);
  const unsigned in_circle = bits(_mm256_cmp_pd(d2, _mm256_mul_pd(r2, set4(1 - kCertainCircle)), _CMP_LT_OQ));
  const unsigned out_circle = bits(_mm256_cmp_pd(d2, _mm256_mul_pd(r2, set4(1 + kCertainCircle)), _CMP_GT_OQ));
  const __m256d d = _mm256_sqrt_pd(d2);
  const __m256d g = _mm256_sub_pd(
      _mm256_add_pd(_mm256_mul_pd(fx, set4(f.bx)), _mm256_mul_pd(fy, set4(f.by))),
      _mm256_sub_pd(_mm256_mul_pd(set4(f.cos_half), _mm256_sqrt_pd(_mm256_sub_pd(d2, r2))),
                    _mm256_mul_pd(set4(f.sin_half), r)));
  const __m256d margin = _mm256_mul_pd(d, set4(kCertainAngle));
  unsigned outside = out_circle & bits(_mm256_cmp_pd(g, _mm256_sub_pd(_mm256_setzero_pd(), margin), _CMP_LT_OQ)) &
                     bits(_mm256_cmp_pd(r, _mm256_mul_pd(set4(f.radius_limit), d), _CMP_LT_OQ));
  const unsigned inside = in_circle | (out_circle & bits(_mm256_cmp_pd(g, margin, _CMP_GT_OQ)));
  unsigned unsure = 0xfu & ~(outside | inside);
  while (unsure) {
    const int i = __builtin_ctz(unsure);
    unsure &= unsure - 1;
    if (outside_view(l.m.groups[ids[i]].circle, f.camera, f.view_from, f.view_width)) outside |= 1u << i;
  }
  return outside;
}

}  // namespace

HORIZON_AVX2 void cull_lanes_avx2(const CullFrame& f, const std::uint32_t* ids, std::size_t n, std::uint8_t* verdict) {
  const PreparedMesh& m = *f.mesh;
  const GroupColumns& c = m.columns;
  for (std::size_t at = 0; at < n; at += 4) {
    const Lanes4 l{f, m, _mm_loadu_si128(reinterpret_cast<const __m128i*>(ids + at))};
    const __m256d x = gather4(0xf, l.g, c.x.data()), y = gather4(0xf, l.g, c.y.data());
    const __m256d r = gather4(0xf, l.g, c.radius.data());
    const __m256d dx = _mm256_sub_pd(set4(f.camera.x), x), dy = _mm256_sub_pd(set4(f.camera.y), y);
    const __m256d d2 = _mm256_add_pd(_mm256_mul_pd(dx, dx), _mm256_mul_pd(dy, dy));
    const unsigned out = bits(_mm256_cmp_pd(d2, _mm256_mul_pd(r, r), _CMP_GT_OQ));
    const unsigned framed = f.frustum ? frustum4(l, ids + at, x, y, d2, r) : 0u;
    const unsigned k = 0xfu & ~framed;
    unsigned culled = 0;
    if (k) culled = f.mode == CullMode::kConservative ? walled4(l, k, dx, dy, d2, r, out) : hidden4(l, k, dx, dy, d2, r, out);
    for (int i = 0; i < 4; ++i)
      verdict[at + static_cast<std::size_t>(i)] = (framed >> i & 1) ? kFrustumCulled : (culled >> i & 1) ? kRegionCulled : kOpen;
  }
}

#endif  // HORIZON_SIMD_AVX2

}  // namespace horizon::mesh
