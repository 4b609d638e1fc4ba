// The lower bound's cells: R3's samples of each cell's own sight line, as
// scalar, AVX2 and AVX-512 kernels with the same double arithmetic (see
// resample_r3.hpp).
#include "resample_r3.hpp"

#include <algorithm>
#include <limits>

#include "../common/simd_isa.hpp"
#include "crossings.hpp"

namespace horizon::visibility::sweep {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// The family of grid lines a candidate lies on: column lines x = index, or
// row lines y = index.
detail::Axis axis_of(const R3CellLine& line, bool u) {
  return (u == line.rows) ? detail::Axis::kRows : detail::Axis::kColumns;
}

}  // namespace

void resample_r3_cells_scalar(const R3CellLine& line, int count, const int* v, const double* total, const R3Line* first,
                              const R3Line* second, float* out) {
  const ViewFrame& f = *line.frame;
  for (int i = 0; i < count; ++i) {
    const double tc = line.rows ? v[i] : line.line, tr = line.rows ? line.line : v[i];
    double best = -kInf;
    auto take = [&](double t, double, double, double terrain) {
      const double slope = detail::r3_slope(f, total[i], t, terrain);
      if (slope > best) best = slope;  // NaN (void) never wins
    };
    auto sample = [&](R3Line l) {
      if (l.index >= 0)
        detail::for_each_crossing_on(axis_of(line, l.u), *line.grid, f.observer_col, f.observer_row, tc, tr, l.index,
                                     l.index, take);
    };
    sample({line.before, true});
    sample(first[i]);
    sample(second[i]);
    out[i] = best == -kInf ? -std::numeric_limits<float>::infinity()
                           : static_cast<float>(detail::r3_ohf_value(f, total[i], best));
  }
}

#ifdef HORIZON_SIMD_AVX2
namespace {

// for_each_crossing_on's constants for one family of lines: the eye's
// offsets A (across the lines) and B (along them), the eye relative to
// them, and the grid's extent and strides.
struct Family {
  double a0 = 0, b0 = 0, A = 0, B = 0;
  double line_count = 0, pos_count = 0;
  std::int64_t line_step = 0, pos_step = 0;  // cells from one line to the next, one position to the next
};

Family family_of(const R3CellLine& line, bool columns) {
  const ViewFrame& f = *line.frame;
  const terrain::HeightView& z = *line.grid;
  const double a_abs0 = columns ? f.observer_col : f.observer_row, b_abs0 = columns ? f.observer_row : f.observer_col;
  Family fam;
  fam.A = floor_to_int(a_abs0);
  fam.B = floor_to_int(b_abs0);
  fam.a0 = a_abs0 - fam.A;
  fam.b0 = b_abs0 - fam.B;
  fam.line_count = columns ? z.width() : z.height();
  fam.pos_count = columns ? z.height() : z.width();
  fam.line_step = columns ? 1 : z.stride();
  fam.pos_step = columns ? z.stride() : 1;
  return fam;
}

// Up to eight cells' candidates on one grid line each, in lanes.
struct Candidates {
  int index[8];
  bool columns[8];  // on a column line (else a row line)
};

void load_candidates(const R3CellLine& line, const R3Line* lines, int n, Candidates& c) {
  for (int i = 0; i < 8; ++i) {
    const R3Line l = i < n ? lines[i] : R3Line{};
    c.index[i] = l.index;
    c.columns[i] = axis_of(line, l.u) == detail::Axis::kColumns;
  }
}

// on_columns in the lanes of `columns`, on_rows in the others.
HORIZON_AVX512 inline __m512d pick512(__mmask8 columns, double on_columns, double on_rows) {
  return _mm512_mask_mov_pd(_mm512_set1_pd(on_rows), columns, _mm512_set1_pd(on_columns));
}

// One candidate per lane of eight cells: R3's sample on it (crossings.hpp's
// arithmetic, operation for operation), and the running maximum slope.
struct Lanes512 {
  Family fam[2];  // [0]: row lines, [1]: column lines
  const float* cells;
  __m512d eye, curvature, fill;

  HORIZON_AVX512 __m512d take(const Candidates& cand, __mmask8 active, __m512d tc, __m512d tr, __m512d total,
                              __m512d best) const {
    __mmask8 columns = 0, live = 0;
    for (int i = 0; i < 8; ++i) {
      columns |= static_cast<__mmask8>(cand.columns[i] << i);
      live |= static_cast<__mmask8>((cand.index[i] >= 0) << i);
    }
    live &= active;
    if (live == 0) return best;
    const Family &r = fam[0], &c = fam[1];
    const __m256i index32 = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(cand.index));
    const __m512d index = _mm512_cvtepi32_pd(index32);
    const __m512d a0 = pick512(columns, c.a0, r.a0), b0 = pick512(columns, c.b0, r.b0), A = pick512(columns, c.A, r.A),
                  B = pick512(columns, c.B, r.B);
    const __m512d a1 = _mm512_sub_pd(_mm512_mask_mov_pd(tr, columns, tc), A);
    const __m512d b1 = _mm512_sub_pd(_mm512_mask_mov_pd(tc, columns, tr), B);
    const __m512d da = _mm512_sub_pd(a1, a0), db = _mm512_sub_pd(b1, b0);
    const __m512d rel = _mm512_sub_pd(index, A);  // integers: exact
    // Only a line strictly between the ends is crossed.
    const __m512d zero = _mm512_setzero_pd();
    const __mmask8 up = _mm512_cmp_pd_mask(da, zero, _CMP_GT_OQ) & _mm512_cmp_pd_mask(rel, a0, _CMP_GT_OQ) &
                        _mm512_cmp_pd_mask(rel, a1, _CMP_LT_OQ);
    const __mmask8 down = _mm512_cmp_pd_mask(da, zero, _CMP_LT_OQ) & _mm512_cmp_pd_mask(rel, a0, _CMP_LT_OQ) &
                          _mm512_cmp_pd_mask(rel, a1, _CMP_GT_OQ);
    const __mmask8 crossed = live & (up | down);
    if (crossed == 0) return best;
    const __m512d t = _mm512_div_pd(_mm512_sub_pd(rel, a0), da);
    const __m512d pos_rel = _mm512_add_pd(b0, _mm512_mul_pd(t, db));
    const __m512d floor = _mm512_roundscale_pd(pos_rel, _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC);
    __m512d w = _mm512_sub_pd(pos_rel, floor);
    __m512d p0 = _mm512_add_pd(floor, B);
    // R3's clamp to the grid: [0, pos_count - 1].
    const __m512d pos_count = pick512(columns, c.pos_count, r.pos_count);
    const __m512d last = _mm512_sub_pd(pos_count, _mm512_set1_pd(1.0));
    const __mmask8 below = _mm512_cmp_pd_mask(p0, zero, _CMP_LT_OQ);
    const __mmask8 above = static_cast<__mmask8>(~below & _mm512_cmp_pd_mask(p0, last, _CMP_GE_OQ));
    p0 = _mm512_mask_mov_pd(_mm512_mask_mov_pd(p0, below, zero), above, _mm512_sub_pd(last, _mm512_set1_pd(1.0)));
    w = _mm512_mask_mov_pd(_mm512_mask_mov_pd(w, below, zero), above, _mm512_set1_pd(1.0));
    // The line inside the grid; else the sample is NaN and never wins.
    const __mmask8 on_grid = crossed & _mm512_cmp_pd_mask(index, zero, _CMP_GE_OQ) &
                             _mm512_cmp_pd_mask(index, pick512(columns, c.line_count, r.line_count), _CMP_LT_OQ);
    if (on_grid == 0) return best;
    // Cell (line, p0) at line * line_step + p0 * pos_step, in 64 bits.
    const __m512i line_step =
        _mm512_mask_mov_epi64(_mm512_set1_epi64(r.line_step), columns, _mm512_set1_epi64(c.line_step));
    const __m512i pos_step =
        _mm512_mask_mov_epi64(_mm512_set1_epi64(r.pos_step), columns, _mm512_set1_epi64(c.pos_step));
    const __m512i at = _mm512_add_epi64(_mm512_mul_epi32(_mm512_cvtepi32_epi64(index32), line_step),
                                        _mm512_mul_epi32(_mm512_cvtepi32_epi64(_mm512_cvttpd_epi32(p0)), pos_step));
    const __m256 raw_a = _mm512_mask_i64gather_ps(_mm256_setzero_ps(), on_grid, at, cells, 4);
    const __m256 raw_b =
        _mm512_mask_i64gather_ps(_mm256_setzero_ps(), on_grid, _mm512_add_epi64(at, pos_step), cells, 4);
    __m512d za = _mm512_cvtps_pd(raw_a), zb = _mm512_cvtps_pd(raw_b);
    za = _mm512_mask_mov_pd(za, _mm512_cmp_pd_mask(za, za, _CMP_UNORD_Q), fill);
    zb = _mm512_mask_mov_pd(zb, _mm512_cmp_pd_mask(zb, zb, _CMP_UNORD_Q), fill);
    const __m512d terrain = _mm512_add_pd(za, _mm512_mul_pd(w, _mm512_sub_pd(zb, za)));
    // r3_slope: (terrain - curvature d^2 - eye) / d, d = t total.
    const __m512d d = _mm512_mul_pd(t, total);
    const __m512d slope =
        _mm512_div_pd(_mm512_sub_pd(_mm512_sub_pd(terrain, _mm512_mul_pd(_mm512_mul_pd(curvature, d), d)), eye), d);
    return _mm512_mask_mov_pd(best, on_grid & _mm512_cmp_pd_mask(slope, best, _CMP_GT_OQ), slope);
  }
};

HORIZON_AVX512 void cells_avx512(const R3CellLine& line, int count, const int* v, const double* total,
                                 const R3Line* first, const R3Line* second, float* out) {
  const ViewFrame& f = *line.frame;
  Lanes512 lanes{{family_of(line, false), family_of(line, true)},
                 line.grid->data(),
                 _mm512_set1_pd(f.eye),
                 _mm512_set1_pd(f.curvature),
                 _mm512_set1_pd(line.grid->void_fill())};
  Candidates before, a, b;
  for (int i = 0; i < 8; ++i) {
    before.index[i] = line.before;
    before.columns[i] = axis_of(line, true) == detail::Axis::kColumns;
  }
  for (int i0 = 0; i0 < count; i0 += 8) {
    const int n = std::min(8, count - i0);
    const __mmask8 active = static_cast<__mmask8>((1u << n) - 1);
    int vi[8];
    for (int i = 0; i < 8; ++i) vi[i] = i < n ? v[i0 + i] : v[i0];
    const __m512d vv = _mm512_cvtepi32_pd(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(vi)));
    const __m512d here = _mm512_set1_pd(line.line);
    const __m512d tc = line.rows ? vv : here, tr = line.rows ? here : vv;
    const __m512d dist = _mm512_mask_loadu_pd(_mm512_set1_pd(1.0), active, total + i0);
    load_candidates(line, first + i0, n, a);
    load_candidates(line, second + i0, n, b);
    __m512d best = _mm512_set1_pd(-kInf);
    best = lanes.take(before, active, tc, tr, dist, best);
    best = lanes.take(a, active, tc, tr, dist, best);
    best = lanes.take(b, active, tc, tr, dist, best);
    // r3_ohf_value: eye + d horizon + curvature d^2 (-inf stays -inf).
    const __m512d ohf = _mm512_add_pd(_mm512_add_pd(lanes.eye, _mm512_mul_pd(dist, best)),
                                      _mm512_mul_pd(_mm512_mul_pd(lanes.curvature, dist), dist));
    alignas(32) float values[8];
    _mm256_store_ps(values, _mm512_cvtpd_ps(ohf));
    std::copy(values, values + n, out + i0);
  }
}

// The same, four cells at a time with AVX2: lane masks are all-ones doubles.
HORIZON_AVX2 inline __m256d pick256(__m256d columns, double on_columns, double on_rows) {
  return _mm256_blendv_pd(_mm256_set1_pd(on_rows), _mm256_set1_pd(on_columns), columns);
}

HORIZON_AVX2 inline __m256i pick256i(__m256d columns, std::int64_t on_columns, std::int64_t on_rows) {
  return _mm256_blendv_epi8(_mm256_set1_epi64x(on_rows), _mm256_set1_epi64x(on_columns), _mm256_castpd_si256(columns));
}

// The gather mask (sign bits of four floats) of four lane masks.
HORIZON_AVX2 inline __m128 float_mask(__m256d m) {
  return _mm256_castps256_ps128(
      _mm256_permutevar8x32_ps(_mm256_castpd_ps(m), _mm256_setr_epi32(0, 2, 4, 6, 0, 0, 0, 0)));
}

struct Lanes256 {
  Family fam[2];  // [0]: row lines, [1]: column lines
  const float* cells;
  __m256d eye, curvature, fill;

  HORIZON_AVX2 __m256d take(const Candidates& cand, int offset, __m256d active, __m256d tc, __m256d tr, __m256d total,
                            __m256d best) const {
    const int* idx = cand.index + offset;
    const bool* col = cand.columns + offset;
    const __m256d columns = _mm256_castsi256_pd(
        _mm256_setr_epi64x(-std::int64_t{col[0]}, -std::int64_t{col[1]}, -std::int64_t{col[2]}, -std::int64_t{col[3]}));
    const __m128i index32 = _mm_loadu_si128(reinterpret_cast<const __m128i*>(idx));
    const __m256d index = _mm256_cvtepi32_pd(index32);
    const __m256d zero = _mm256_setzero_pd();
    const __m256d live = _mm256_and_pd(active, _mm256_cmp_pd(index, zero, _CMP_GE_OQ));
    if (_mm256_movemask_pd(live) == 0) return best;
    const Family &r = fam[0], &c = fam[1];
    const __m256d a0 = pick256(columns, c.a0, r.a0), b0 = pick256(columns, c.b0, r.b0), A = pick256(columns, c.A, r.A),
                  B = pick256(columns, c.B, r.B);
    const __m256d a1 = _mm256_sub_pd(_mm256_blendv_pd(tr, tc, columns), A);
    const __m256d b1 = _mm256_sub_pd(_mm256_blendv_pd(tc, tr, columns), B);
    const __m256d da = _mm256_sub_pd(a1, a0), db = _mm256_sub_pd(b1, b0);
    const __m256d rel = _mm256_sub_pd(index, A);
    const __m256d up =
        _mm256_and_pd(_mm256_cmp_pd(da, zero, _CMP_GT_OQ),
                      _mm256_and_pd(_mm256_cmp_pd(rel, a0, _CMP_GT_OQ), _mm256_cmp_pd(rel, a1, _CMP_LT_OQ)));
    const __m256d down =
        _mm256_and_pd(_mm256_cmp_pd(da, zero, _CMP_LT_OQ),
                      _mm256_and_pd(_mm256_cmp_pd(rel, a0, _CMP_LT_OQ), _mm256_cmp_pd(rel, a1, _CMP_GT_OQ)));
    const __m256d crossed = _mm256_and_pd(live, _mm256_or_pd(up, down));
    if (_mm256_movemask_pd(crossed) == 0) return best;
    const __m256d t = _mm256_div_pd(_mm256_sub_pd(rel, a0), da);
    const __m256d pos_rel = _mm256_add_pd(b0, _mm256_mul_pd(t, db));
    const __m256d floor = _mm256_floor_pd(pos_rel);
    __m256d w = _mm256_sub_pd(pos_rel, floor);
    __m256d p0 = _mm256_add_pd(floor, B);
    const __m256d last = _mm256_sub_pd(pick256(columns, c.pos_count, r.pos_count), _mm256_set1_pd(1.0));
    const __m256d below = _mm256_cmp_pd(p0, zero, _CMP_LT_OQ);
    const __m256d above = _mm256_andnot_pd(below, _mm256_cmp_pd(p0, last, _CMP_GE_OQ));
    p0 = _mm256_blendv_pd(_mm256_blendv_pd(p0, zero, below), _mm256_sub_pd(last, _mm256_set1_pd(1.0)), above);
    w = _mm256_blendv_pd(_mm256_blendv_pd(w, zero, below), _mm256_set1_pd(1.0), above);
    const __m256d on_grid = _mm256_and_pd(
        crossed, _mm256_and_pd(_mm256_cmp_pd(index, zero, _CMP_GE_OQ),
                               _mm256_cmp_pd(index, pick256(columns, c.line_count, r.line_count), _CMP_LT_OQ)));
    if (_mm256_movemask_pd(on_grid) == 0) return best;
    const __m256i line_step = pick256i(columns, c.line_step, r.line_step);
    const __m256i pos_step = pick256i(columns, c.pos_step, r.pos_step);
    const __m256i at = _mm256_add_epi64(_mm256_mul_epi32(_mm256_cvtepi32_epi64(index32), line_step),
                                        _mm256_mul_epi32(_mm256_cvtepi32_epi64(_mm256_cvttpd_epi32(p0)), pos_step));
    const __m128 mask = float_mask(on_grid);
    const __m128 raw_a = _mm256_mask_i64gather_ps(_mm_setzero_ps(), cells, at, mask, 4);
    const __m128 raw_b = _mm256_mask_i64gather_ps(_mm_setzero_ps(), cells, _mm256_add_epi64(at, pos_step), mask, 4);
    __m256d za = _mm256_cvtps_pd(raw_a), zb = _mm256_cvtps_pd(raw_b);
    za = _mm256_blendv_pd(za, fill, _mm256_cmp_pd(za, za, _CMP_UNORD_Q));
    zb = _mm256_blendv_pd(zb, fill, _mm256_cmp_pd(zb, zb, _CMP_UNORD_Q));
    const __m256d terrain = _mm256_add_pd(za, _mm256_mul_pd(w, _mm256_sub_pd(zb, za)));
    const __m256d d = _mm256_mul_pd(t, total);
    const __m256d slope =
        _mm256_div_pd(_mm256_sub_pd(_mm256_sub_pd(terrain, _mm256_mul_pd(_mm256_mul_pd(curvature, d), d)), eye), d);
    return _mm256_blendv_pd(best, slope, _mm256_and_pd(on_grid, _mm256_cmp_pd(slope, best, _CMP_GT_OQ)));
  }
};

HORIZON_AVX2 void cells_avx2(const R3CellLine& line, int count, const int* v, const double* total, const R3Line* first,
                             const R3Line* second, float* out) {
  const ViewFrame& f = *line.frame;
  Lanes256 lanes{{family_of(line, false), family_of(line, true)},
                 line.grid->data(),
                 _mm256_set1_pd(f.eye),
                 _mm256_set1_pd(f.curvature),
                 _mm256_set1_pd(line.grid->void_fill())};
  Candidates before, a, b;
  for (int i = 0; i < 8; ++i) {
    before.index[i] = line.before;
    before.columns[i] = axis_of(line, true) == detail::Axis::kColumns;
  }
  const __m256d lane = _mm256_setr_pd(0, 1, 2, 3);
  for (int i0 = 0; i0 < count; i0 += 8) {
    const int n8 = std::min(8, count - i0);
    load_candidates(line, first + i0, n8, a);
    load_candidates(line, second + i0, n8, b);
    for (int h = 0; h < n8; h += 4) {
      const int n = std::min(4, n8 - h);
      const __m256d active = _mm256_cmp_pd(lane, _mm256_set1_pd(n), _CMP_LT_OQ);
      int vi[4];
      double di[4];
      for (int i = 0; i < 4; ++i) {
        vi[i] = i < n ? v[i0 + h + i] : v[i0 + h];
        di[i] = i < n ? total[i0 + h + i] : 1.0;
      }
      const __m256d vv = _mm256_cvtepi32_pd(_mm_loadu_si128(reinterpret_cast<const __m128i*>(vi)));
      const __m256d here = _mm256_set1_pd(line.line);
      const __m256d tc = line.rows ? vv : here, tr = line.rows ? here : vv;
      const __m256d dist = _mm256_loadu_pd(di);
      __m256d best = _mm256_set1_pd(-kInf);
      best = lanes.take(before, h, active, tc, tr, dist, best);
      best = lanes.take(a, h, active, tc, tr, dist, best);
      best = lanes.take(b, h, active, tc, tr, dist, best);
      const __m256d ohf = _mm256_add_pd(_mm256_add_pd(lanes.eye, _mm256_mul_pd(dist, best)),
                                        _mm256_mul_pd(_mm256_mul_pd(lanes.curvature, dist), dist));
      alignas(16) float values[4];
      _mm_store_ps(values, _mm256_cvtpd_ps(ohf));
      std::copy(values, values + n, out + i0 + h);
    }
  }
}

}  // namespace
#endif

void resample_r3_cells(const R3CellLine& line, int count, const int* v, const double* total, const R3Line* first,
                       const R3Line* second, float* out) {
#ifdef HORIZON_SIMD_AVX2
  if (simd_isa::kernel_isa() == simd_isa::Isa::kAvx512) {
    cells_avx512(line, count, v, total, first, second, out);
    return;
  }
  if (simd_isa::kernel_isa() == simd_isa::Isa::kAvx2) {
    cells_avx2(line, count, v, total, first, second, out);
    return;
  }
#endif
  resample_r3_cells_scalar(line, count, v, total, first, second, out);
}

}  // namespace horizon::visibility::sweep
