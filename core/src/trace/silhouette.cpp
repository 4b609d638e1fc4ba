// The silhouette map, its packed partitioning tree and the per-pixel descent
// on the CPU (silhouette.hpp), after Sakalauskas, "Silhouette Partitioning
// for Height Field Ray Tracing", sections 4 and 5.
//
// Each kernel has a scalar loop and AVX2 / AVX-512 forms across the block's
// columns, giving the scalar loop's bits: the same float operations in the
// same order (this file is built with -ffp-contract=off), comparisons that
// treat NaN alike (the map never holds NaN: a void is kNoCrossing).
#include "silhouette.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace horizon::trace::detail {

namespace simd = visibility::sweep::simd;

TreeShape tree_shape(int lines) {
  TreeShape s;
  s.lines = lines;
  s.nodes.push_back(lines);
  s.offset.push_back(0);
  if (lines <= 0) return s;
  int n = lines;
  do {
    n = (n + 3) / 4;
    s.offset.push_back(s.floats);
    s.nodes.push_back(n);
    s.floats += static_cast<std::size_t>(n) * 4 * kBlock;
    ++s.levels;
  } while (n > 1);
  return s;
}

namespace {

// ---- the map ------------------------------------------------------------

void build_map_scalar(const float* data, const BlockLines& b, const FrameGeometry& g, int lines, float* map) {
  for (int k = 0; k < lines; ++k) {
    float* out = map + static_cast<std::size_t>(k) * kBlock;
    for (int x = 0; x < kBlock; ++x) {
      out[x] = k < b.count[x]
                   ? crossing_slope(data, b.eye_along, b.pos_count, b.line_stride, b.pos_stride,
                                    b.first[x] + b.step[x] * k, static_cast<float>(k) + b.t0[x], b.pos_per_t[x],
                                    b.dist_per_t[x], b.near[x], g.far, g.eye_z, g.curvature, g.fill)
                   : kNoCrossing;
    }
  }
}

#ifdef HORIZON_SIMD_AVX2

HORIZON_AVX2 void build_map_avx2(const float* data, const BlockLines& b, const FrameGeometry& g, int lines,
                                 float* map) {
  const __m256 eye_along = _mm256_set1_ps(b.eye_along), last = _mm256_set1_ps(static_cast<float>(b.pos_count - 1));
  const __m256i max_i = _mm256_set1_epi32(b.pos_count - 2);
  const __m256i line_stride = _mm256_set1_epi32(static_cast<int>(b.line_stride));
  const __m256i pos_stride = _mm256_set1_epi32(static_cast<int>(b.pos_stride));
  const __m256 far = _mm256_set1_ps(g.far), eye_z = _mm256_set1_ps(g.eye_z);
  const __m256 curvature = _mm256_set1_ps(g.curvature), fill = _mm256_set1_ps(g.fill);
  const __m256 none = _mm256_set1_ps(kNoCrossing), zero = _mm256_setzero_ps();
  for (int k = 0; k < lines; ++k) {
    float* out = map + static_cast<std::size_t>(k) * kBlock;
    const __m256i kv = _mm256_set1_epi32(k);
    const __m256 kf = _mm256_set1_ps(static_cast<float>(k));
    for (int x = 0; x < kBlock; x += 8) {
      const __m256i count = _mm256_load_si256(reinterpret_cast<const __m256i*>(b.count + x));
      const __m256 t = _mm256_add_ps(kf, _mm256_load_ps(b.t0 + x));
      const __m256 p = _mm256_add_ps(eye_along, _mm256_mul_ps(t, _mm256_load_ps(b.pos_per_t + x)));
      const __m256 d = _mm256_mul_ps(t, _mm256_load_ps(b.dist_per_t + x));
      __m256 ok = _mm256_castsi256_ps(_mm256_cmpgt_epi32(count, kv));
      ok = _mm256_and_ps(ok, _mm256_cmp_ps(d, _mm256_load_ps(b.near + x), _CMP_GE_OQ));
      ok = _mm256_and_ps(ok, _mm256_cmp_ps(d, far, _CMP_LE_OQ));
      ok = _mm256_and_ps(ok, _mm256_cmp_ps(p, zero, _CMP_GE_OQ));
      ok = _mm256_and_ps(ok, _mm256_cmp_ps(p, last, _CMP_LE_OQ));
      if (_mm256_movemask_ps(ok) == 0) {
        _mm256_storeu_ps(out + x, none);
        continue;
      }
      __m256i i = _mm256_cvttps_epi32(_mm256_floor_ps(p));
      i = simd::mini_of(i, max_i);
      const __m256 f = _mm256_sub_ps(p, _mm256_cvtepi32_ps(i));
      const __m256i line =
          _mm256_add_epi32(_mm256_load_si256(reinterpret_cast<const __m256i*>(b.first + x)),
                           _mm256_mullo_epi32(_mm256_load_si256(reinterpret_cast<const __m256i*>(b.step + x)), kv));
      const __m256i index = _mm256_add_epi32(_mm256_mullo_epi32(line, line_stride), _mm256_mullo_epi32(i, pos_stride));
      {
        // Prefetch kAhead lines on, as the AVX-512 form does (the reason is there).
        constexpr int kAhead = 8;
        const __m256 ta = _mm256_add_ps(t, _mm256_set1_ps(static_cast<float>(kAhead)));
        const __m256 pa = _mm256_add_ps(eye_along, _mm256_mul_ps(ta, _mm256_load_ps(b.pos_per_t + x)));
        __m256i ia = _mm256_cvttps_epi32(_mm256_max_ps(pa, zero));
        ia = simd::mini_of(ia, max_i);
        const __m256i la =
            _mm256_add_epi32(line, _mm256_mullo_epi32(_mm256_load_si256(reinterpret_cast<const __m256i*>(b.step + x)),
                                                      _mm256_set1_epi32(kAhead)));
        alignas(32) std::int32_t ahead[8];
        _mm256_store_si256(reinterpret_cast<__m256i*>(ahead),
                           _mm256_add_epi32(_mm256_mullo_epi32(la, line_stride), _mm256_mullo_epi32(ia, pos_stride)));
        const int valid =
            _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpgt_epi32(count, _mm256_set1_epi32(k + kAhead))));
        for (int q = 0; q < 8; ++q)
          if (valid >> q & 1) __builtin_prefetch(data + ahead[q]);
      }
      const __m256 h0 = simd::fill_voids(simd::gather_masked(data, index, ok), fill);
      const __m256 h1 = simd::fill_voids(simd::gather_masked(data, _mm256_add_epi32(index, pos_stride), ok), fill);
      const __m256 z = _mm256_add_ps(h0, _mm256_mul_ps(f, _mm256_sub_ps(h1, h0)));
      __m256 s =
          _mm256_div_ps(_mm256_sub_ps(_mm256_sub_ps(z, eye_z), _mm256_mul_ps(_mm256_mul_ps(curvature, d), d)), d);
      ok = _mm256_and_ps(ok, _mm256_cmp_ps(s, s, _CMP_ORD_Q));
      _mm256_storeu_ps(out + x, _mm256_blendv_ps(none, s, ok));
    }
  }
}

HORIZON_AVX512 void build_map_avx512(const float* data, const BlockLines& b, const FrameGeometry& g, int lines,
                                     float* map) {
  const __m512 eye_along = _mm512_set1_ps(b.eye_along), last = _mm512_set1_ps(static_cast<float>(b.pos_count - 1));
  const __m512i max_i = _mm512_set1_epi32(b.pos_count - 2);
  const __m512i line_stride = _mm512_set1_epi32(static_cast<int>(b.line_stride));
  const __m512i pos_stride = _mm512_set1_epi32(static_cast<int>(b.pos_stride));
  const __m512 far = _mm512_set1_ps(g.far), eye_z = _mm512_set1_ps(g.eye_z);
  const __m512 curvature = _mm512_set1_ps(g.curvature), fill = _mm512_set1_ps(g.fill);
  const __m512 none = _mm512_set1_ps(kNoCrossing), zero = _mm512_setzero_ps();
  for (int k = 0; k < lines; ++k) {
    float* out = map + static_cast<std::size_t>(k) * kBlock;
    const __m512i kv = _mm512_set1_epi32(k);
    const __m512 kf = _mm512_set1_ps(static_cast<float>(k));
    for (int x = 0; x < kBlock; x += 16) {
      const __m512i count = _mm512_load_si512(b.count + x);
      const __m512 t = _mm512_add_ps(kf, _mm512_load_ps(b.t0 + x));
      const __m512 p = _mm512_add_ps(eye_along, _mm512_mul_ps(t, _mm512_load_ps(b.pos_per_t + x)));
      const __m512 d = _mm512_mul_ps(t, _mm512_load_ps(b.dist_per_t + x));
      __mmask16 ok = _mm512_cmpgt_epi32_mask(count, kv);
      ok &= _mm512_cmp_ps_mask(d, _mm512_load_ps(b.near + x), _CMP_GE_OQ);
      ok &= _mm512_cmp_ps_mask(d, far, _CMP_LE_OQ);
      ok &= _mm512_cmp_ps_mask(p, zero, _CMP_GE_OQ);
      ok &= _mm512_cmp_ps_mask(p, last, _CMP_LE_OQ);
      if (ok == 0) {
        _mm512_storeu_ps(out + x, none);
        continue;
      }
      __m512i i = _mm512_cvttps_epi32(simd::floor16(p));
      i = simd::mini_of(i, max_i);
      const __m512 f = _mm512_sub_ps(p, _mm512_cvtepi32_ps(i));
      const __m512i line =
          _mm512_add_epi32(_mm512_load_si512(b.first + x), _mm512_mullo_epi32(_mm512_load_si512(b.step + x), kv));
      const __m512i index = _mm512_add_epi32(_mm512_mullo_epi32(line, line_stride), _mm512_mullo_epi32(i, pos_stride));
      {
        // Prefetch this vector's crossings kAhead lines on: successive lines
        // of a block are other DEM rows (or far apart along a column), each
        // gather misses the caches, and the out-of-order window holds too
        // few of them to hide the memory's latency (twice as fast at 512 x
        // 512 over the 12 M-cell DEM). A lane past its count prefetches
        // nothing; the address is clamped inside the line like a crossing's.
        constexpr int kAhead = 8;
        const __m512 ta = _mm512_add_ps(t, _mm512_set1_ps(static_cast<float>(kAhead)));
        const __m512 pa = _mm512_add_ps(eye_along, _mm512_mul_ps(ta, _mm512_load_ps(b.pos_per_t + x)));
        __m512i ia = _mm512_cvttps_epi32(_mm512_max_ps(pa, zero));
        ia = simd::mini_of(ia, max_i);
        const __m512i la =
            _mm512_add_epi32(line, _mm512_mullo_epi32(_mm512_load_si512(b.step + x), _mm512_set1_epi32(kAhead)));
        alignas(64) std::int32_t ahead[16];
        _mm512_store_si512(ahead,
                           _mm512_add_epi32(_mm512_mullo_epi32(la, line_stride), _mm512_mullo_epi32(ia, pos_stride)));
        const __mmask16 valid = _mm512_cmpgt_epi32_mask(count, _mm512_set1_epi32(k + kAhead));
        for (int q = 0; q < 16; ++q)
          if (valid >> q & 1) __builtin_prefetch(data + ahead[q]);
      }
      const __m512 h0 = simd::fill_voids(simd::gather_masked(data, index, ok), fill);
      const __m512 h1 = simd::fill_voids(simd::gather_masked(data, _mm512_add_epi32(index, pos_stride), ok), fill);
      const __m512 z = _mm512_add_ps(h0, _mm512_mul_ps(f, _mm512_sub_ps(h1, h0)));
      const __m512 s =
          _mm512_div_ps(_mm512_sub_ps(_mm512_sub_ps(z, eye_z), _mm512_mul_ps(_mm512_mul_ps(curvature, d), d)), d);
      ok &= _mm512_cmp_ps_mask(s, s, _CMP_ORD_Q);
      _mm512_storeu_ps(out + x, _mm512_mask_blend_ps(ok, none, s));
    }
  }
}

#endif  // HORIZON_SIMD_AVX2

// ---- the descent --------------------------------------------------------

void descend_scalar(const float* pairs, const TreeShape& shape, const float* slope, std::int32_t* leaf) {
  const float* root = pairs + shape.offset[static_cast<std::size_t>(shape.levels)];
  for (int x = 0; x < kBlock; ++x) {
    const float s = slope[x];
    if (!(s <= root[3 * kBlock + x])) {
      leaf[x] = -1;
      continue;
    }
    int node = 0;
    for (int p = shape.levels; p >= 1; --p) {
      const float* texel =
          pairs + shape.offset[static_cast<std::size_t>(p)] + static_cast<std::size_t>(node) * 4 * kBlock + x;
      const int q = s <= texel[2 * kBlock] ? (s <= texel[0] ? 0 : 1) : (s <= texel[kBlock] ? 2 : 3);
      node = node * 4 + q;
    }
    leaf[x] = node;
  }
}

#ifdef HORIZON_SIMD_AVX2

HORIZON_AVX2 void descend_avx2(const float* pairs, const TreeShape& shape, const float* slope, std::int32_t* leaf) {
  const float* root = pairs + shape.offset[static_cast<std::size_t>(shape.levels)];
  const __m256 none = _mm256_set1_ps(kNoCrossing);
  const __m256i one = _mm256_set1_epi32(1), two = _mm256_set1_epi32(2), minus = _mm256_set1_epi32(-1);
  for (int x = 0; x < kBlock; x += 8) {
    const __m256i lane = _mm256_add_epi32(_mm256_set1_epi32(x), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
    __m256 s = _mm256_loadu_ps(slope + x);
    const __m256 sky = _mm256_cmp_ps(s, _mm256_loadu_ps(root + 3 * kBlock + x), _CMP_NLE_UQ);
    s = _mm256_blendv_ps(s, none, sky);  // sky lanes walk the nearest nodes, which always exist
    __m256i node = _mm256_setzero_si256();
    for (int p = shape.levels; p >= 1; --p) {
      const __m256i base = _mm256_add_epi32(
          _mm256_add_epi32(_mm256_set1_epi32(static_cast<int>(shape.offset[static_cast<std::size_t>(p)])),
                           _mm256_slli_epi32(node, 2 + 5)),  // node * 4 * kBlock
          lane);
      const __m256 r = _mm256_i32gather_ps(pairs, base, 4);
      const __m256 gch = _mm256_i32gather_ps(pairs, _mm256_add_epi32(base, _mm256_set1_epi32(kBlock)), 4);
      const __m256 bch = _mm256_i32gather_ps(pairs, _mm256_add_epi32(base, _mm256_set1_epi32(2 * kBlock)), 4);
      const __m256i near_half = _mm256_castps_si256(_mm256_cmp_ps(s, bch, _CMP_LE_OQ));
      const __m256i in_r = _mm256_castps_si256(_mm256_cmp_ps(s, r, _CMP_LE_OQ));
      const __m256i in_g = _mm256_castps_si256(_mm256_cmp_ps(s, gch, _CMP_LE_OQ));
      // q = near half ? (in R ? 0 : 1) : (in G ? 2 : 3)
      const __m256i q_near = _mm256_andnot_si256(in_r, one);
      const __m256i q_far = _mm256_add_epi32(two, _mm256_andnot_si256(in_g, one));
      const __m256i q = _mm256_blendv_epi8(q_far, q_near, near_half);
      node = _mm256_add_epi32(_mm256_slli_epi32(node, 2), q);
    }
    node = _mm256_blendv_epi8(node, minus, _mm256_castps_si256(sky));
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(leaf + x), node);
  }
}

HORIZON_AVX512 void descend_avx512(const float* pairs, const TreeShape& shape, const float* slope, std::int32_t* leaf) {
  const float* root = pairs + shape.offset[static_cast<std::size_t>(shape.levels)];
  const __m512 none = _mm512_set1_ps(kNoCrossing);
  const __m512i one = _mm512_set1_epi32(1), two = _mm512_set1_epi32(2), minus = _mm512_set1_epi32(-1);
  for (int x = 0; x < kBlock; x += 16) {
    const __m512i lane =
        _mm512_add_epi32(_mm512_set1_epi32(x), _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15));
    __m512 s = _mm512_loadu_ps(slope + x);
    const __mmask16 sky = _mm512_cmp_ps_mask(s, _mm512_loadu_ps(root + 3 * kBlock + x), _CMP_NLE_UQ);
    s = _mm512_mask_blend_ps(sky, s, none);
    __m512i node = _mm512_setzero_si512();
    for (int p = shape.levels; p >= 1; --p) {
      const __m512i base = _mm512_add_epi32(
          _mm512_add_epi32(_mm512_set1_epi32(static_cast<int>(shape.offset[static_cast<std::size_t>(p)])),
                           _mm512_slli_epi32(node, 2 + 5)),
          lane);
      const __m512 r = _mm512_i32gather_ps(base, pairs, 4);
      const __m512 gch = _mm512_i32gather_ps(_mm512_add_epi32(base, _mm512_set1_epi32(kBlock)), pairs, 4);
      const __m512 bch = _mm512_i32gather_ps(_mm512_add_epi32(base, _mm512_set1_epi32(2 * kBlock)), pairs, 4);
      const __mmask16 near_half = _mm512_cmp_ps_mask(s, bch, _CMP_LE_OQ);
      const __mmask16 in_r = _mm512_cmp_ps_mask(s, r, _CMP_LE_OQ);
      const __mmask16 in_g = _mm512_cmp_ps_mask(s, gch, _CMP_LE_OQ);
      const __m512i q_near = _mm512_mask_blend_epi32(in_r, one, _mm512_setzero_si512());
      const __m512i q_far = _mm512_mask_blend_epi32(in_g, _mm512_add_epi32(two, one), two);
      const __m512i q = _mm512_mask_blend_epi32(near_half, q_far, q_near);
      node = _mm512_add_epi32(_mm512_slli_epi32(node, 2), q);
    }
    node = _mm512_mask_blend_epi32(sky, node, minus);
    _mm512_storeu_si512(leaf + x, node);
  }
}

#endif  // HORIZON_SIMD_AVX2

// ---- the hits -----------------------------------------------------------

void resolve_rows_scalar(const float* map, const BlockLines& b, const float* slope, const std::int32_t* leaf, int lanes,
                         float* distance, std::int32_t* line) {
  for (int x = 0; x < lanes; ++x) {
    const int k = leaf[x];
    if (k < 0) {
      distance[x] = std::numeric_limits<float>::infinity();
      line[x] = -1;
      continue;
    }
    const float d1 = (static_cast<float>(k) + b.t0[x]) * b.dist_per_t[x];
    const float s1 = map[static_cast<std::size_t>(k) * kBlock + static_cast<std::size_t>(x)];
    float d0 = 0.0f, s0 = kNoCrossing;
    if (k > 0) {
      d0 = (static_cast<float>(k - 1) + b.t0[x]) * b.dist_per_t[x];
      s0 = map[static_cast<std::size_t>(k - 1) * kBlock + static_cast<std::size_t>(x)];
    }
    distance[x] = chord_hit(slope[x], d0, s0, d1, s1);
    line[x] = b.first[x] + b.step[x] * k;
  }
}

#ifdef HORIZON_SIMD_AVX2

HORIZON_AVX2 void resolve_rows_avx2(const float* map, const BlockLines& b, const float* slope, const std::int32_t* leaf,
                                    int lanes, float* distance, std::int32_t* line) {
  const __m256 none = _mm256_set1_ps(kNoCrossing), inf = _mm256_set1_ps(std::numeric_limits<float>::infinity());
  const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.0f);
  const __m256i minus = _mm256_set1_epi32(-1), ione = _mm256_set1_epi32(1);
  for (int x = 0; x < lanes; x += 8) {
    const __m256i lane = _mm256_add_epi32(_mm256_set1_epi32(x), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
    const __m256i k = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(leaf + x));
    const __m256i sky = _mm256_cmpgt_epi32(ione, _mm256_add_epi32(k, ione));  // k < 0
    const __m256i prev = _mm256_cmpgt_epi32(k, _mm256_setzero_si256());       // k > 0
    const __m256i k1 = _mm256_max_epi32(k, _mm256_setzero_si256());
    const __m256i k0 = _mm256_max_epi32(_mm256_sub_epi32(k, ione), _mm256_setzero_si256());
    const __m256 t0 = _mm256_loadu_ps(b.t0 + x), dpt = _mm256_loadu_ps(b.dist_per_t + x);
    const __m256 d1 = _mm256_mul_ps(_mm256_add_ps(_mm256_cvtepi32_ps(k1), t0), dpt);
    const __m256 d0 = _mm256_mul_ps(_mm256_add_ps(_mm256_cvtepi32_ps(_mm256_sub_epi32(k1, ione)), t0), dpt);
    const __m256 s1 = _mm256_i32gather_ps(map, _mm256_add_epi32(_mm256_slli_epi32(k1, 5), lane), 4);
    __m256 s0 = _mm256_mask_i32gather_ps(none, map, _mm256_add_epi32(_mm256_slli_epi32(k0, 5), lane),
                                         _mm256_castsi256_ps(prev), 4);
    const __m256 s = _mm256_loadu_ps(slope + x);
    // chord_hit, lane by lane.
    const __m256 z0 = _mm256_mul_ps(s0, d0), z1 = _mm256_mul_ps(s1, d1);
    const __m256 denom = _mm256_sub_ps(_mm256_sub_ps(z1, z0), _mm256_mul_ps(s, _mm256_sub_ps(d1, d0)));
    __m256 t = _mm256_div_ps(_mm256_sub_ps(_mm256_mul_ps(s, d0), z0), denom);
    t = _mm256_blendv_ps(t, zero, _mm256_cmp_ps(t, zero, _CMP_LT_OQ));
    t = _mm256_blendv_ps(t, one, _mm256_cmp_ps(t, one, _CMP_GT_OQ));
    const __m256 chord = _mm256_add_ps(d0, _mm256_mul_ps(t, _mm256_sub_ps(d1, d0)));
    const __m256 use = _mm256_and_ps(_mm256_cmp_ps(s0, none, _CMP_GT_OQ), _mm256_cmp_ps(denom, zero, _CMP_GT_OQ));
    __m256 d = _mm256_blendv_ps(d1, chord, use);
    d = _mm256_blendv_ps(d, inf, _mm256_castsi256_ps(sky));
    const __m256i l =
        _mm256_add_epi32(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(b.first + x)),
                         _mm256_mullo_epi32(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(b.step + x)), k1));
    const __m256i out_line = _mm256_blendv_epi8(l, minus, sky);
    if (x + 8 <= lanes) {
      _mm256_storeu_ps(distance + x, d);
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(line + x), out_line);
    } else {
      const __m256i keep = _mm256_cmpgt_epi32(_mm256_set1_epi32(lanes), lane);
      _mm256_maskstore_ps(distance + x, keep, d);
      _mm256_maskstore_epi32(line + x, keep, out_line);
    }
  }
}

HORIZON_AVX512 void resolve_rows_avx512(const float* map, const BlockLines& b, const float* slope,
                                        const std::int32_t* leaf, int lanes, float* distance, std::int32_t* line) {
  const __m512 none = _mm512_set1_ps(kNoCrossing), inf = _mm512_set1_ps(std::numeric_limits<float>::infinity());
  const __m512 zero = _mm512_setzero_ps(), one = _mm512_set1_ps(1.0f);
  const __m512i ione = _mm512_set1_epi32(1), izero = _mm512_setzero_si512();
  for (int x = 0; x < lanes; x += 16) {
    const __m512i lane =
        _mm512_add_epi32(_mm512_set1_epi32(x), _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15));
    const __mmask16 in = lanes - x >= 16 ? __mmask16(0xffff) : __mmask16((1u << (lanes - x)) - 1u);
    const __m512i k = _mm512_loadu_si512(leaf + x);
    const __mmask16 sky = _mm512_cmplt_epi32_mask(k, izero);
    const __mmask16 prev = _mm512_cmpgt_epi32_mask(k, izero);
    const __m512i k1 = _mm512_max_epi32(k, izero);
    const __m512i k0 = _mm512_max_epi32(_mm512_sub_epi32(k, ione), izero);
    const __m512 t0 = _mm512_loadu_ps(b.t0 + x), dpt = _mm512_loadu_ps(b.dist_per_t + x);
    const __m512 d1 = _mm512_mul_ps(_mm512_add_ps(_mm512_cvtepi32_ps(k1), t0), dpt);
    const __m512 d0 = _mm512_mul_ps(_mm512_add_ps(_mm512_cvtepi32_ps(_mm512_sub_epi32(k1, ione)), t0), dpt);
    const __m512 s1 = _mm512_i32gather_ps(_mm512_add_epi32(_mm512_slli_epi32(k1, 5), lane), map, 4);
    const __m512 s0 = _mm512_mask_i32gather_ps(none, prev, _mm512_add_epi32(_mm512_slli_epi32(k0, 5), lane), map, 4);
    const __m512 s = _mm512_loadu_ps(slope + x);
    const __m512 z0 = _mm512_mul_ps(s0, d0), z1 = _mm512_mul_ps(s1, d1);
    const __m512 denom = _mm512_sub_ps(_mm512_sub_ps(z1, z0), _mm512_mul_ps(s, _mm512_sub_ps(d1, d0)));
    __m512 t = _mm512_div_ps(_mm512_sub_ps(_mm512_mul_ps(s, d0), z0), denom);
    t = _mm512_mask_blend_ps(_mm512_cmp_ps_mask(t, zero, _CMP_LT_OQ), t, zero);
    t = _mm512_mask_blend_ps(_mm512_cmp_ps_mask(t, one, _CMP_GT_OQ), t, one);
    const __m512 chord = _mm512_add_ps(d0, _mm512_mul_ps(t, _mm512_sub_ps(d1, d0)));
    const __mmask16 use = _mm512_cmp_ps_mask(s0, none, _CMP_GT_OQ) & _mm512_cmp_ps_mask(denom, zero, _CMP_GT_OQ);
    __m512 d = _mm512_mask_blend_ps(use, d1, chord);
    d = _mm512_mask_blend_ps(sky, d, inf);
    const __m512i l =
        _mm512_add_epi32(_mm512_loadu_si512(b.first + x), _mm512_mullo_epi32(_mm512_loadu_si512(b.step + x), k1));
    _mm512_mask_storeu_ps(distance + x, in, d);
    _mm512_mask_storeu_epi32(line + x, in, _mm512_mask_blend_epi32(sky, l, _mm512_set1_epi32(-1)));
  }
}

#endif  // HORIZON_SIMD_AVX2

}  // namespace

static_assert(kBlock == 32, "descend's SIMD forms multiply by 4 * kBlock with a shift of 7");

void build_map(Isa isa, const float* data, const BlockLines& b, const FrameGeometry& g, int lines, float* map) {
#ifdef HORIZON_SIMD_AVX2
  if (isa >= Isa::kAvx512) return build_map_avx512(data, b, g, lines, map);
  if (isa >= Isa::kAvx2) return build_map_avx2(data, b, g, lines, map);
#endif
  (void)isa;
  build_map_scalar(data, b, g, lines, map);
}

void build_tree(const float* map, const TreeShape& shape, float* pairs) {
  for (int p = 1; p <= shape.levels; ++p) {
    const int children = shape.nodes[static_cast<std::size_t>(p - 1)];
    const int nodes = shape.nodes[static_cast<std::size_t>(p)];
    float* level = pairs + shape.offset[static_cast<std::size_t>(p)];
    // A child's full-range silhouette: a map line at level 1, else channel A.
    const float* below = p == 1 ? map : pairs + shape.offset[static_cast<std::size_t>(p - 1)];
    const std::size_t child_stride = p == 1 ? kBlock : 4 * kBlock;
    const std::size_t child_a = p == 1 ? 0 : 3 * kBlock;
    for (int j = 0; j < nodes; ++j) {
      const float* q[4];
      for (int c = 0; c < 4; ++c) {
        const int child = 4 * j + c;
        q[c] = child < children ? below + static_cast<std::size_t>(child) * child_stride + child_a : nullptr;
      }
      float* out = level + static_cast<std::size_t>(j) * 4 * kBlock;
      for (int x = 0; x < kBlock; ++x) {
        const float a = q[0] ? q[0][x] : kNoCrossing, b = q[1] ? q[1][x] : kNoCrossing;
        const float c = q[2] ? q[2][x] : kNoCrossing, d = q[3] ? q[3][x] : kNoCrossing;
        const float ab = a < b ? b : a, cd = c < d ? d : c;
        out[x] = a;                               // R: the nearest quarter
        out[kBlock + x] = c;                      // G: the nearest quarter of the farther half
        out[2 * kBlock + x] = ab;                 // B: the nearer half
        out[3 * kBlock + x] = ab < cd ? cd : ab;  // A: the whole node
      }
    }
  }
}

void resolve_rows(Isa isa, const float* map, const BlockLines& b, const float* slope, const std::int32_t* leaf,
                  int lanes, float* distance, std::int32_t* line) {
#ifdef HORIZON_SIMD_AVX2
  if (isa >= Isa::kAvx512) return resolve_rows_avx512(map, b, slope, leaf, lanes, distance, line);
  if (isa >= Isa::kAvx2) return resolve_rows_avx2(map, b, slope, leaf, lanes, distance, line);
#endif
  (void)isa;
  resolve_rows_scalar(map, b, slope, leaf, lanes, distance, line);
}

void descend(Isa isa, const float* pairs, const TreeShape& shape, const float* slope, std::int32_t* leaf) {
  if (shape.levels == 0) {
    std::fill(leaf, leaf + kBlock, -1);
    return;
  }
#ifdef HORIZON_SIMD_AVX2
  if (isa >= Isa::kAvx512) return descend_avx512(pairs, shape, slope, leaf);
  if (isa >= Isa::kAvx2) return descend_avx2(pairs, shape, slope, leaf);
#endif
  (void)isa;
  descend_scalar(pairs, shape, slope, leaf);
}

}  // namespace horizon::trace::detail
