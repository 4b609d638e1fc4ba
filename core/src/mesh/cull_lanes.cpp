// The cull's vector kernels (cull_lanes.hpp): AVX-512 (eight doubles, mask
// registers) and AVX2 (four doubles, masks as bit sets expanded when a
// gather or a blend needs them), each the scalar twin's arithmetic of
// cull.cpp lane by lane. Gathers are most of the cost, so each form runs
// two batches side by side (H = 2) and reads what it can once: a chain's
// begin and end in one 64-bit gather, the corners the walk passed kept. The file is built with -ffp-contract=off (all of
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

#include <cmath>

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
  __m512d t_low, t_high;            // sector_t[0, 16), where there are no more sectors
  __m512d starts_low, starts_high;  // sector_starts[0, 16), padded with +inf
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
HORIZON_AVX512 inline __mmask8 lt_i(__m512i a, __m512i b) {
  return static_cast<__mmask8>(_mm512_cmplt_epi32_mask(a, b));
}
HORIZON_AVX512 inline __mmask8 eq_i(__m512i a, __m512i b) {
  return static_cast<__mmask8>(_mm512_cmpeq_epi32_mask(a, b));
}

// PreparedMesh::sector_of lane by lane: pseudo_angle, then the last
// sector start not above it, as upper_bound finds it (NaN, which compares
// above none, lands in the last sector). Up to sixteen starts sit in two
// registers, padded with +inf, and are searched by halves; more are
// counted one by one.
HORIZON_AVX512 __m512i sector_of8(const Lanes8& l, __m512d x, __m512d y) {
  const __m512d sign = set8(-0.0);
  const __m512d ax = _mm512_castsi512_pd(_mm512_andnot_si512(_mm512_castpd_si512(sign), _mm512_castpd_si512(x)));
  const __m512d ay = _mm512_castsi512_pd(_mm512_andnot_si512(_mm512_castpd_si512(sign), _mm512_castpd_si512(y)));
  const __m512d q = _mm512_div_pd(x, _mm512_add_pd(ax, ay));
  const __mmask8 up = _mm512_cmp_pd_mask(y, _mm512_setzero_pd(), _CMP_GE_OQ);
  const __m512d p = _mm512_mask_blend_pd(up, _mm512_add_pd(set8(3.0), q), _mm512_sub_pd(set8(1.0), q));
  const int s = l.m.sectors;
  if (s <= 16) {
    // p >= 0 = starts[0] (|x| <= |x| + |y| after rounding too), so the
    // search starts at 0 and finds the last start that p is not below.
    __m512i at = _mm512_setzero_si512();
    for (long long step : {8LL, 4LL, 2LL, 1LL}) {
      const __m512i probe = _mm512_add_epi64(at, _mm512_set1_epi64(step));
      const __mmask8 below =
          _mm512_cmp_pd_mask(p, _mm512_permutex2var_pd(l.starts_low, probe, l.starts_high), _CMP_NLT_UQ);
      at = _mm512_mask_mov_epi64(at, below, probe);
    }
    return _mm512_min_epi32(_mm512_zextsi256_si512(_mm512_cvtepi64_epi32(at)), seti8(s - 1));
  }
  const __m512i one = seti8(1);
  __m512i count = _mm512_setzero_si512();
  for (double start : l.m.sector_starts) {
    const __mmask8 below = _mm512_cmp_pd_mask(p, set8(start), _CMP_NLT_UQ);
    count = _mm512_mask_add_epi32(count, below, count, one);
  }
  return _mm512_sub_epi32(count, one);
}

// begin[index] and begin[index + 1] for the lanes of k, by one 64-bit
// gather of the adjacent pair.
HORIZON_AVX512 inline void pair8(__mmask8 k, __m512i index, const std::uint32_t* begin, __m512i& first,
                                 __m512i& second) {
  const __m512i both = _mm512_mask_i32gather_epi64(_mm512_setzero_si512(), k, low(index), begin, 4);
  first = _mm512_zextsi256_si512(_mm512_cvtepi64_epi32(both));
  second = _mm512_zextsi256_si512(_mm512_cvtepi64_epi32(_mm512_srli_epi64(both, 32)));
}

// The loops below run H batches of eight lanes side by side (H = 2:
// sixteen groups), so that one batch's gathers wait while the other's
// issue; a loop runs until every batch is done.

// hidden_in for the lanes of k: chain `chain`, sector `sector`. The walk
// carries the corner it stands on (at) and the first one past the camera
// (past), so that neither is gathered again.
template <int H>
HORIZON_AVX512 void hidden_in8(const Lanes8& l, const __mmask8* k, const __m512i* chain, const __m512i* sector,
                               __mmask8* hidden) {
  const PreparedMesh& m = l.m;
  const __m512i one = seti8(1);
  __m512i begin[H], end[H], j[H];
  __m512d t[H], at[H], past[H];
  __mmask8 ok[H], walking[H];
  unsigned any = 0;
  for (int h = 0; h < H; ++h) {
    pair8(k[h], chain[h], m.chain_begin.data(), begin[h], end[h]);
    // Up to sixteen sectors' t sit in two registers: a permute, not a gather.
    t[h] = m.sectors <= 16 ? _mm512_permutex2var_pd(l.t_low, _mm512_cvtepi32_epi64(low(sector[h])), l.t_high)
                           : gather8(k[h], sector[h], l.f.sector_t);
    ok[h] = k[h] & static_cast<__mmask8>(~eq_i(begin[h], end[h]));
    at[h] = gather8(ok[h], begin[h], m.corner_t.data());
    ok[h] &= _mm512_cmp_pd_mask(t[h], at[h], _CMP_NLT_UQ);
    j[h] = begin[h];
    past[h] = _mm512_setzero_pd();
    walking[h] = ok[h];
    any |= walking[h];
  }
  while (any) {
    any = 0;
    for (int h = 0; h < H; ++h) {
      const __m512i next = _mm512_add_epi32(j[h], one);
      const __mmask8 more = walking[h] & lt_i(next, end[h]);  // the others stand on their last corner
      const __m512d nt = gather8(more, next, m.corner_t.data());
      const __mmask8 step = more & _mm512_cmp_pd_mask(nt, t[h], _CMP_LE_OQ);
      past[h] = _mm512_mask_mov_pd(past[h], more & static_cast<__mmask8>(~step), nt);
      at[h] = _mm512_mask_mov_pd(at[h], step, nt);
      j[h] = _mm512_mask_mov_epi32(j[h], step, next);
      walking[h] = step;
      any |= step;
    }
  }
  for (int h = 0; h < H; ++h) {
    const __m512i next = _mm512_add_epi32(j[h], one);
    const __mmask8 ray = ok[h] & eq_i(next, end[h]);
    const __mmask8 segment = ok[h] & static_cast<__mmask8>(~ray);
    const __m512d az = gather8(ok[h], j[h], m.corner_z.data());
    const __m512d ray_height =
        _mm512_add_pd(az, _mm512_mul_pd(gather8(ray, chain[h], m.chain_slope.data()), _mm512_sub_pd(t[h], at[h])));
    const __m512d nz = gather8(segment, next, m.corner_z.data());
    const __m512d segment_height =
        _mm512_add_pd(az, _mm512_mul_pd(_mm512_sub_pd(nz, az), _mm512_div_pd(_mm512_sub_pd(t[h], at[h]),
                                                                             _mm512_sub_pd(past[h], at[h]))));
    const __m512d height = _mm512_mask_blend_pd(ray, segment_height, ray_height);
    hidden[h] = ok[h] & _mm512_cmp_pd_mask(set8(l.f.camera.z), height, _CMP_LE_OQ);
  }
}

// Per batch: its groups, the camera's offset from their centres, the
// squared distance, the radii, and which lanes have the camera outside
// the circle.
struct Centres8 {
  __m512i g;
  __m512d dx, dy, d2, r;
  __mmask8 out;
};

// hidden() for the lanes of k.
template <int H>
HORIZON_AVX512 void hidden8(const Lanes8& l, const __mmask8* k, const Centres8* c, __mmask8* hid) {
  const __m512i vs = seti8(l.m.sectors);
  __m512i count[H], sector[H], base[H];
  for (int h = 0; h < H; ++h) {
    const __m512d d = _mm512_sqrt_pd(c[h].d2);
    const __m512d sine = _mm512_add_pd(_mm512_mul_pd(_mm512_div_pd(c[h].r, d), set8(1 + 1e-9)), set8(1e-12));
    const __mmask8 wide = c[h].out & _mm512_cmp_pd_mask(sine, set8(1.0), _CMP_LT_OQ);
    sector[h] = _mm512_setzero_si512();
    count[h] = vs;
    if (wide) {
      const __m512d cosine = _mm512_sqrt_pd(_mm512_sub_pd(set8(1.0), _mm512_mul_pd(sine, sine)));
      const __m512d ux = _mm512_div_pd(c[h].dx, d), uy = _mm512_div_pd(c[h].dy, d);
      const __m512i a = sector_of8(l, _mm512_add_pd(_mm512_mul_pd(ux, cosine), _mm512_mul_pd(uy, sine)),
                                   _mm512_sub_pd(_mm512_mul_pd(uy, cosine), _mm512_mul_pd(ux, sine)));
      const __m512i b = sector_of8(l, _mm512_sub_pd(_mm512_mul_pd(ux, cosine), _mm512_mul_pd(uy, sine)),
                                   _mm512_add_pd(_mm512_mul_pd(uy, cosine), _mm512_mul_pd(ux, sine)));
      __m512i span = _mm512_add_epi32(_mm512_sub_epi32(b, a), vs);  // (last − first + s) % s, for both in [0, s)
      span = _mm512_mask_sub_epi32(span, static_cast<__mmask16>(~lt_i(span, vs)), span, vs);
      sector[h] = _mm512_mask_mov_epi32(sector[h], wide, a);
      count[h] = _mm512_mask_mov_epi32(count[h], wide, _mm512_add_epi32(span, seti8(1)));
    }
    base[h] = _mm512_mullo_epi32(c[h].g, vs);
    hid[h] = k[h];
  }
  for (int i = 0;; ++i) {
    __mmask8 lanes[H], in[H];
    __m512i chain[H];
    unsigned any = 0;
    for (int h = 0; h < H; ++h) {
      lanes[h] = hid[h] & lt_i(seti8(i), count[h]);
      chain[h] = _mm512_add_epi32(base[h], sector[h]);
      any |= lanes[h];
    }
    if (!any) break;
    hidden_in8<H>(l, lanes, chain, sector, in);
    for (int h = 0; h < H; ++h) {
      hid[h] &= static_cast<__mmask8>(~(lanes[h] & static_cast<__mmask8>(~in[h])));
      sector[h] = _mm512_add_epi32(sector[h], seti8(1));
      sector[h] = _mm512_mask_sub_epi32(sector[h], static_cast<__mmask16>(~lt_i(sector[h], vs)), sector[h], vs);
    }
  }
}

// walled() for the lanes of k.
template <int H>
HORIZON_AVX512 void walled8(const Lanes8& l, const __mmask8* k, const Centres8* c, __mmask8* culled) {
  const PreparedMesh& m = l.m;
  const __m512i one = seti8(1);
  __m512d d[H];
  __m512i best[H], end[H];
  __mmask8 ok[H], walking[H];
  unsigned any = 0;
  for (int h = 0; h < H; ++h) {
    d[h] = _mm512_sqrt_pd(c[h].d2);
    ok[h] = k[h] & c[h].out & _mm512_cmp_pd_mask(d[h], c[h].r, _CMP_NLE_UQ);
    const __m512i chain = _mm512_add_epi32(_mm512_mullo_epi32(c[h].g, seti8(m.sectors)), sector_of8(l, c[h].dx, c[h].dy));
    pair8(ok[h], chain, m.wall_begin.data(), best[h], end[h]);
    ok[h] &= static_cast<__mmask8>(~eq_i(best[h], end[h]));
    // Most chains have no wall: skip the gathers of a batch without one.
    if (ok[h]) ok[h] &= _mm512_cmp_pd_mask(gather8(ok[h], best[h], m.wall_radius.data()), d[h], _CMP_NGE_UQ);
    walking[h] = ok[h];
    any |= ok[h];
  }
  while (any) {
    any = 0;
    for (int h = 0; h < H; ++h) {
      const __m512i next = _mm512_add_epi32(best[h], one);
      __mmask8 more = walking[h] & lt_i(next, end[h]);
      more &= _mm512_cmp_pd_mask(gather8(more, next, m.wall_radius.data()), d[h], _CMP_LT_OQ);
      best[h] = _mm512_mask_mov_epi32(best[h], more, next);
      walking[h] = more;
      any |= more;
    }
  }
  for (int h = 0; h < H; ++h) {
    culled[h] = 0;
    if (!ok[h]) continue;
    const __m512d bound =
        _mm512_add_pd(gather8(ok[h], c[h].g, m.group_top.data()),
                      _mm512_mul_pd(gather8(ok[h], best[h], m.wall_slope.data()), _mm512_sub_pd(d[h], c[h].r)));
    culled[h] = ok[h] & _mm512_cmp_pd_mask(set8(l.f.camera.z), bound, _CMP_LT_OQ);
  }
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
  constexpr int H = 2;
  const PreparedMesh& m = *f.mesh;
  const GroupColumns& columns = m.columns;
  double t16[16] = {}, starts16[16];
  for (int i = 0; i < 16; ++i) {
    t16[i] = i < m.sectors ? f.sector_t[i] : 0.0;
    starts16[i] = i < m.sectors ? m.sector_starts[static_cast<std::size_t>(i)] : HUGE_VAL;
  }
  const Lanes8 l{f, m, _mm512_loadu_pd(t16), _mm512_loadu_pd(t16 + 8), _mm512_loadu_pd(starts16),
                 _mm512_loadu_pd(starts16 + 8)};
  for (std::size_t at = 0; at < n; at += 8 * H) {
    Centres8 c[H];
    __mmask8 framed[H], k[H], culled[H];
    unsigned any = 0;
    for (int h = 0; h < H; ++h) {
      const std::uint32_t* batch = ids + at + 8 * static_cast<std::size_t>(h);
      c[h].g = _mm512_zextsi256_si512(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(batch)));
      const __m512d x = gather8(0xff, c[h].g, columns.x.data()), y = gather8(0xff, c[h].g, columns.y.data());
      c[h].r = gather8(0xff, c[h].g, columns.radius.data());
      c[h].dx = _mm512_sub_pd(set8(f.camera.x), x);
      c[h].dy = _mm512_sub_pd(set8(f.camera.y), y);
      c[h].d2 = _mm512_add_pd(_mm512_mul_pd(c[h].dx, c[h].dx), _mm512_mul_pd(c[h].dy, c[h].dy));
      c[h].out = _mm512_cmp_pd_mask(c[h].d2, _mm512_mul_pd(c[h].r, c[h].r), _CMP_GT_OQ);
      framed[h] = f.frustum ? frustum8(l, batch, x, y, c[h].d2, c[h].r) : __mmask8{0};
      k[h] = static_cast<__mmask8>(~framed[h]);
      culled[h] = 0;
      any |= k[h];
    }
    if (any) {
      if (f.mode == CullMode::kConservative)
        walled8<H>(l, k, c, culled);
      else
        hidden8<H>(l, k, c, culled);
    }
    for (int h = 0; h < H; ++h)
      for (int i = 0; i < 8; ++i)
        verdict[at + static_cast<std::size_t>(8 * h + i)] = (framed[h] >> i & 1)   ? kFrustumCulled
                                                            : (culled[h] >> i & 1) ? kRegionCulled
                                                                                   : kOpen;
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
  // Each start not above p adds a lane's all-ones (−1) to a 64-bit count,
  // in two sums that do not wait on each other.
  __m256i even = _mm256_setzero_si256(), odd = _mm256_setzero_si256();
  const std::size_t n = m.sector_starts.size();
  for (std::size_t i = 0; i < n; i += 2) {
    even = _mm256_sub_epi64(even, _mm256_castpd_si256(_mm256_cmp_pd(p, set4(m.sector_starts[i]), _CMP_NLT_UQ)));
    if (i + 1 < n)
      odd = _mm256_sub_epi64(odd, _mm256_castpd_si256(_mm256_cmp_pd(p, set4(m.sector_starts[i + 1]), _CMP_NLT_UQ)));
  }
  const __m256i count = _mm256_add_epi64(even, odd);
  const __m128i narrow =
      _mm256_castsi256_si128(_mm256_permutevar8x32_epi32(count, _mm256_setr_epi32(0, 2, 4, 6, 0, 2, 4, 6)));
  return _mm_sub_epi32(narrow, seti4(1));
}

// begin[index] and begin[index + 1] for the lanes of k, by one 64-bit
// gather of the adjacent pair.
HORIZON_AVX2 inline void pair4(unsigned k, __m128i index, const std::uint32_t* begin, __m128i& first,
                               __m128i& second) {
  const __m256i both = _mm256_mask_i32gather_epi64(_mm256_setzero_si256(), reinterpret_cast<const long long*>(begin),
                                                   index, _mm256_castpd_si256(mask_d(k)), 4);
  first = _mm256_castsi256_si128(_mm256_permutevar8x32_epi32(both, _mm256_setr_epi32(0, 2, 4, 6, 0, 2, 4, 6)));
  second = _mm256_castsi256_si128(_mm256_permutevar8x32_epi32(both, _mm256_setr_epi32(1, 3, 5, 7, 1, 3, 5, 7)));
}

// hidden_in8's twin, H batches of four side by side.
template <int H>
HORIZON_AVX2 void hidden_in4(const Lanes4& l, const unsigned* k, const __m128i* chain, const __m128i* sector,
                             unsigned* hidden) {
  const PreparedMesh& m = l.m;
  const __m128i one = seti4(1);
  __m128i begin[H], end[H], j[H];
  __m256d t[H], at[H], past[H];
  unsigned ok[H], walking[H], any = 0;
  for (int h = 0; h < H; ++h) {
    pair4(k[h], chain[h], m.chain_begin.data(), begin[h], end[h]);
    t[h] = gather4(k[h], sector[h], l.f.sector_t);
    ok[h] = k[h] & ~eq_i(begin[h], end[h]);
    at[h] = gather4(ok[h], begin[h], m.corner_t.data());
    ok[h] &= bits(_mm256_cmp_pd(t[h], at[h], _CMP_NLT_UQ));
    j[h] = begin[h];
    past[h] = _mm256_setzero_pd();
    walking[h] = ok[h];
    any |= ok[h];
  }
  while (any) {
    any = 0;
    for (int h = 0; h < H; ++h) {
      const __m128i next = _mm_add_epi32(j[h], one);
      const unsigned more = walking[h] & lt_i(next, end[h]);
      const __m256d nt = gather4(more, next, m.corner_t.data());
      const unsigned step = more & bits(_mm256_cmp_pd(nt, t[h], _CMP_LE_OQ));
      past[h] = blend4(more & ~step, past[h], nt);
      at[h] = blend4(step, at[h], nt);
      j[h] = blendi4(step, j[h], next);
      walking[h] = step;
      any |= step;
    }
  }
  for (int h = 0; h < H; ++h) {
    const __m128i next = _mm_add_epi32(j[h], one);
    const unsigned ray = ok[h] & eq_i(next, end[h]);
    const unsigned segment = ok[h] & ~ray;
    const __m256d az = gather4(ok[h], j[h], m.corner_z.data());
    const __m256d ray_height =
        _mm256_add_pd(az, _mm256_mul_pd(gather4(ray, chain[h], m.chain_slope.data()), _mm256_sub_pd(t[h], at[h])));
    const __m256d nz = gather4(segment, next, m.corner_z.data());
    const __m256d segment_height =
        _mm256_add_pd(az, _mm256_mul_pd(_mm256_sub_pd(nz, az), _mm256_div_pd(_mm256_sub_pd(t[h], at[h]),
                                                                             _mm256_sub_pd(past[h], at[h]))));
    const __m256d height = blend4(ray, segment_height, ray_height);
    hidden[h] = ok[h] & bits(_mm256_cmp_pd(set4(l.f.camera.z), height, _CMP_LE_OQ));
  }
}

struct Centres4 {
  __m128i g;
  __m256d dx, dy, d2, r;
  unsigned out;
};

template <int H>
HORIZON_AVX2 void hidden4(const Lanes4& l, const unsigned* k, const Centres4* c, unsigned* hid) {
  const __m128i vs = seti4(l.m.sectors);
  __m128i count[H], sector[H], base[H];
  for (int h = 0; h < H; ++h) {
    const __m256d d = _mm256_sqrt_pd(c[h].d2);
    const __m256d sine = _mm256_add_pd(_mm256_mul_pd(_mm256_div_pd(c[h].r, d), set4(1 + 1e-9)), set4(1e-12));
    const unsigned wide = c[h].out & bits(_mm256_cmp_pd(sine, set4(1.0), _CMP_LT_OQ));
    sector[h] = _mm_setzero_si128();
    count[h] = vs;
    if (wide) {
      const __m256d cosine = _mm256_sqrt_pd(_mm256_sub_pd(set4(1.0), _mm256_mul_pd(sine, sine)));
      const __m256d ux = _mm256_div_pd(c[h].dx, d), uy = _mm256_div_pd(c[h].dy, d);
      const __m128i a = sector_of4(l.m, _mm256_add_pd(_mm256_mul_pd(ux, cosine), _mm256_mul_pd(uy, sine)),
                                   _mm256_sub_pd(_mm256_mul_pd(uy, cosine), _mm256_mul_pd(ux, sine)));
      const __m128i b = sector_of4(l.m, _mm256_sub_pd(_mm256_mul_pd(ux, cosine), _mm256_mul_pd(uy, sine)),
                                   _mm256_add_pd(_mm256_mul_pd(uy, cosine), _mm256_mul_pd(ux, sine)));
      const __m128i span = wrap_i(_mm_add_epi32(_mm_sub_epi32(b, a), vs), vs);
      sector[h] = blendi4(wide, sector[h], a);
      count[h] = blendi4(wide, count[h], _mm_add_epi32(span, seti4(1)));
    }
    base[h] = _mm_mullo_epi32(c[h].g, vs);
    hid[h] = k[h];
  }
  for (int i = 0;; ++i) {
    unsigned lanes[H], in[H], any = 0;
    __m128i chain[H];
    for (int h = 0; h < H; ++h) {
      lanes[h] = hid[h] & lt_i(seti4(i), count[h]);
      chain[h] = _mm_add_epi32(base[h], sector[h]);
      any |= lanes[h];
    }
    if (!any) break;
    hidden_in4<H>(l, lanes, chain, sector, in);
    for (int h = 0; h < H; ++h) {
      hid[h] &= ~(lanes[h] & ~in[h]);
      sector[h] = wrap_i(_mm_add_epi32(sector[h], seti4(1)), vs);
    }
  }
}

template <int H>
HORIZON_AVX2 void walled4(const Lanes4& l, const unsigned* k, const Centres4* c, unsigned* culled) {
  const PreparedMesh& m = l.m;
  const __m128i one = seti4(1);
  __m256d d[H];
  __m128i best[H], end[H];
  unsigned ok[H], walking[H], any = 0;
  for (int h = 0; h < H; ++h) {
    d[h] = _mm256_sqrt_pd(c[h].d2);
    ok[h] = k[h] & c[h].out & bits(_mm256_cmp_pd(d[h], c[h].r, _CMP_NLE_UQ));
    const __m128i chain = _mm_add_epi32(_mm_mullo_epi32(c[h].g, seti4(m.sectors)), sector_of4(m, c[h].dx, c[h].dy));
    pair4(ok[h], chain, m.wall_begin.data(), best[h], end[h]);
    ok[h] &= ~eq_i(best[h], end[h]);
    if (ok[h]) ok[h] &= bits(_mm256_cmp_pd(gather4(ok[h], best[h], m.wall_radius.data()), d[h], _CMP_NGE_UQ));
    walking[h] = ok[h];
    any |= ok[h];
  }
  while (any) {
    any = 0;
    for (int h = 0; h < H; ++h) {
      const __m128i next = _mm_add_epi32(best[h], one);
      unsigned more = walking[h] & lt_i(next, end[h]);
      more &= bits(_mm256_cmp_pd(gather4(more, next, m.wall_radius.data()), d[h], _CMP_LT_OQ));
      best[h] = blendi4(more, best[h], next);
      walking[h] = more;
      any |= more;
    }
  }
  for (int h = 0; h < H; ++h) {
    culled[h] = 0;
    if (!ok[h]) continue;
    const __m256d bound =
        _mm256_add_pd(gather4(ok[h], c[h].g, m.group_top.data()),
                      _mm256_mul_pd(gather4(ok[h], best[h], m.wall_slope.data()), _mm256_sub_pd(d[h], c[h].r)));
    culled[h] = ok[h] & bits(_mm256_cmp_pd(set4(l.f.camera.z), bound, _CMP_LT_OQ));
  }
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
  constexpr int H = 2;
  const PreparedMesh& m = *f.mesh;
  const GroupColumns& columns = m.columns;
  const Lanes4 l{f, m};
  for (std::size_t at = 0; at < n; at += 4 * H) {
    Centres4 c[H];
    unsigned framed[H], k[H], culled[H], any = 0;
    for (int h = 0; h < H; ++h) {
      const std::uint32_t* batch = ids + at + 4 * static_cast<std::size_t>(h);
      c[h].g = _mm_loadu_si128(reinterpret_cast<const __m128i*>(batch));
      const __m256d x = gather4(0xf, c[h].g, columns.x.data()), y = gather4(0xf, c[h].g, columns.y.data());
      c[h].r = gather4(0xf, c[h].g, columns.radius.data());
      c[h].dx = _mm256_sub_pd(set4(f.camera.x), x);
      c[h].dy = _mm256_sub_pd(set4(f.camera.y), y);
      c[h].d2 = _mm256_add_pd(_mm256_mul_pd(c[h].dx, c[h].dx), _mm256_mul_pd(c[h].dy, c[h].dy));
      c[h].out = bits(_mm256_cmp_pd(c[h].d2, _mm256_mul_pd(c[h].r, c[h].r), _CMP_GT_OQ));
      framed[h] = f.frustum ? frustum4(l, batch, x, y, c[h].d2, c[h].r) : 0u;
      k[h] = 0xfu & ~framed[h];
      culled[h] = 0;
      any |= k[h];
    }
    if (any) {
      if (f.mode == CullMode::kConservative)
        walled4<H>(l, k, c, culled);
      else
        hidden4<H>(l, k, c, culled);
    }
    for (int h = 0; h < H; ++h)
      for (int i = 0; i < 4; ++i)
        verdict[at + static_cast<std::size_t>(4 * h + i)] = (framed[h] >> i & 1)   ? kFrustumCulled
                                                            : (culled[h] >> i & 1) ? kRegionCulled
                                                                                   : kOpen;
  }
}

#endif  // HORIZON_SIMD_AVX2

}  // namespace horizon::mesh
