#include "column_lines.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <utility>

#include "horizon/common/parallel.hpp"
#include "simd.hpp"

namespace horizon::visibility::sweep {
namespace {

// Columns per task: a task writes this many whole lines of the copy, and
// reads a strip this wide down every row (64 floats: four cache lines a row).
constexpr int kColumnsPerTask = 64;
static_assert(kColumnsPerTask % 8 == 0, "a task is whole spans of eight columns");

// The scalar copy of columns [c0, c1) x rows [r0, r1) (view coordinates),
// for the edges of the blocked form and CPUs without AVX2.
void copy_scalar(const terrain::HeightView& z, const terrain::Window& extent, int c0, int c1, int r0, int r1,
                 float* out, std::ptrdiff_t pitch) {
  for (int r = r0; r < r1; ++r) {
    const float* row = z.row(r);
    for (int c = c0; c < c1; ++c) out[(c - extent.col0) * pitch + (r - extent.row0)] = row[c];
  }
}

// The rows [r0, r1) that columns [c0, c1) (at most eight) are copied over.
struct ColumnSpan {
  int c0, c1, r0, r1;
};

// A task's spans, eight columns each.
struct TaskSpans {
  std::array<ColumnSpan, kColumnsPerTask / 8> span;
  int count = 0;

  const ColumnSpan* begin() const { return span.data(); }
  const ColumnSpan* end() const { return span.data() + count; }
};

#ifdef HORIZON_SIMD_AVX2
// An 8 x 8 block: eight rows of eight floats from `from` (rows `stride`
// apart) written as eight columns of eight to `to` (`pitch` apart).
HORIZON_AVX2 inline void transpose8(const float* from, std::ptrdiff_t stride, float* to, std::ptrdiff_t pitch) {
  __m256 r[8];
  for (int i = 0; i < 8; ++i) r[i] = _mm256_loadu_ps(from + i * stride);
  __m256 t[8];
  for (int i = 0; i < 4; ++i) {
    t[2 * i] = _mm256_unpacklo_ps(r[2 * i], r[2 * i + 1]);
    t[2 * i + 1] = _mm256_unpackhi_ps(r[2 * i], r[2 * i + 1]);
  }
  __m256 u[8];
  for (int i = 0; i < 2; ++i) {
    u[4 * i] = _mm256_shuffle_ps(t[4 * i], t[4 * i + 2], _MM_SHUFFLE(1, 0, 1, 0));
    u[4 * i + 1] = _mm256_shuffle_ps(t[4 * i], t[4 * i + 2], _MM_SHUFFLE(3, 2, 3, 2));
    u[4 * i + 2] = _mm256_shuffle_ps(t[4 * i + 1], t[4 * i + 3], _MM_SHUFFLE(1, 0, 1, 0));
    u[4 * i + 3] = _mm256_shuffle_ps(t[4 * i + 1], t[4 * i + 3], _MM_SHUFFLE(3, 2, 3, 2));
  }
  for (int i = 0; i < 4; ++i) {
    _mm256_storeu_ps(to + i * pitch, _mm256_permute2f128_ps(u[i], u[i + 4], 0x20));
    _mm256_storeu_ps(to + (i + 4) * pitch, _mm256_permute2f128_ps(u[i], u[i + 4], 0x31));
  }
}

// A task's spans of eight columns by 8 x 8 blocks, row band by row band
// (each band reads a few cache lines of eight rows, and writes a run of
// eight floats to each of the task's lines); the blocks are counted from the
// extent's first row. The rows above and below a span's blocks, and a span
// narrower than eight columns, by the scalar copy.
HORIZON_AVX2 void copy_blocked(const terrain::HeightView& z, const terrain::Window& extent, const TaskSpans& spans,
                               float* out, std::ptrdiff_t pitch) {
  const auto block_rows = [&](const ColumnSpan& s) {  // [first, last) of whole blocks inside the span's rows
    const int first = extent.row0 + (s.r0 - extent.row0 + 7) / 8 * 8;
    const int last = extent.row0 + (s.r1 - extent.row0) / 8 * 8;
    return std::pair<int, int>{first, std::max(first, last)};
  };
  int band0 = extent.row1, band1 = extent.row0;
  for (const ColumnSpan& s : spans) {
    if (s.c1 - s.c0 < 8) {
      copy_scalar(z, extent, s.c0, s.c1, s.r0, s.r1, out, pitch);
      continue;
    }
    const auto [first, last] = block_rows(s);
    copy_scalar(z, extent, s.c0, s.c1, s.r0, std::min(first, s.r1), out, pitch);
    copy_scalar(z, extent, s.c0, s.c1, std::max(last, s.r0), s.r1, out, pitch);
    if (first < last) band0 = std::min(band0, first), band1 = std::max(band1, last);
  }
  for (int r = band0; r < band1; r += 8)
    for (const ColumnSpan& s : spans) {
      if (s.c1 - s.c0 < 8) continue;
      const auto [first, last] = block_rows(s);
      if (r >= first && r < last)
        transpose8(z.row(r) + s.c0, z.stride(), out + (s.c0 - extent.col0) * pitch + (r - extent.row0), pitch);
    }
}
#endif

}  // namespace

terrain::Window column_lines_extent(const terrain::HeightView& z, const ViewFrame& frame) {
  const terrain::Window& w = frame.window;
  const int eye_col = static_cast<int>(std::floor(frame.observer_col));
  return {std::max(0, std::min(w.col0, eye_col) - 1), std::max(0, w.row0 - 1),
          std::min(z.width(), std::max(w.col1, eye_col + 1) + 1), std::min(z.height(), w.row1 + 1)};
}

terrain::Window ColumnWedge::rows_of(const terrain::Window& extent, int c0, int c1) const {
  // The farthest of the columns from the eye sets the span.
  const double k = std::max(std::abs(c0 - eye_col), std::abs(c1 - 1 - eye_col));
  const double lo = std::floor(eye_row - k) - kMargin, hi = std::ceil(eye_row + k) + kMargin + 1;
  terrain::Window rows = extent;
  rows.row0 = static_cast<int>(std::clamp(lo, double(extent.row0), double(extent.row1)));
  rows.row1 = static_cast<int>(std::clamp(hi, double(rows.row0), double(extent.row1)));
  return rows;
}

ColumnLines transpose_columns(const terrain::HeightView& z, const terrain::Window& extent, unsigned threads,
                              terrain::Grid<float>& buffer, const ColumnWedge* wedge) {
  const int lines = extent.width(), pitch = extent.height();
  if (buffer.capacity() >= static_cast<std::size_t>(lines) * static_cast<std::size_t>(pitch))
    buffer.reshape(pitch, lines);
  else
    buffer = terrain::Grid<float>(pitch, lines, terrain::kUninitialized);
  float* out = buffer.data();
  const int tasks = (lines + kColumnsPerTask - 1) / kColumnsPerTask;
  parallel_for(static_cast<std::size_t>(tasks), threads, [&](std::size_t t) {
    const int task_c0 = extent.col0 + static_cast<int>(t) * kColumnsPerTask;
    const int task_c1 = std::min(extent.col1, task_c0 + kColumnsPerTask);
    // Eight columns at a time, each over the rows it needs.
    TaskSpans spans;
    for (int c0 = task_c0; c0 < task_c1; c0 += 8) {
      const int c1 = std::min(task_c1, c0 + 8);
      const terrain::Window rows = wedge ? wedge->rows_of(extent, c0, c1) : extent;
      if (rows.row0 < rows.row1) spans.span[spans.count++] = {c0, c1, rows.row0, rows.row1};
    }
#ifdef HORIZON_SIMD_AVX2
    if (simd::has_avx2()) {
      copy_blocked(z, extent, spans, out, pitch);
      return;
    }
#endif
    for (const ColumnSpan& s : spans) copy_scalar(z, extent, s.c0, s.c1, s.r0, s.r1, out, pitch);
  });
  return {buffer.data(), pitch, extent};
}

}  // namespace horizon::visibility::sweep
