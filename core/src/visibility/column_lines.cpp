#include "column_lines.hpp"

#include <algorithm>
#include <cmath>

#include "horizon/common/parallel.hpp"
#include "simd.hpp"

namespace horizon::visibility::sweep {
namespace {

// Columns per task: a task writes this many whole lines of the copy, and
// reads a strip this wide down every row (64 floats: four cache lines a row).
constexpr int kColumnsPerTask = 64;

// The scalar copy of columns [c0, c1) x rows [r0, r1) (view coordinates),
// for the edges of the blocked form and CPUs without AVX2.
void copy_scalar(const terrain::HeightView& z, const terrain::Window& extent, int c0, int c1, int r0, int r1,
                 float* out, std::ptrdiff_t pitch) {
  for (int r = r0; r < r1; ++r) {
    const float* row = z.row(r);
    for (int c = c0; c < c1; ++c) out[(c - extent.col0) * pitch + (r - extent.row0)] = row[c];
  }
}

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

// Columns [c0, c1) of every row of the extent by 8 x 8 blocks; the rows and
// columns left over by the scalar copy.
HORIZON_AVX2 void copy_blocked(const terrain::HeightView& z, const terrain::Window& extent, int c0, int c1, float* out,
                               std::ptrdiff_t pitch) {
  const int r0 = extent.row0, r1 = extent.row1;
  const int rows8 = r0 + (r1 - r0) / 8 * 8, cols8 = c0 + (c1 - c0) / 8 * 8;
  for (int r = r0; r < rows8; r += 8)
    for (int c = c0; c < cols8; c += 8)
      transpose8(z.row(r) + c, z.stride(), out + (c - extent.col0) * pitch + (r - extent.row0), pitch);
  copy_scalar(z, extent, cols8, c1, r0, r1, out, pitch);
  copy_scalar(z, extent, c0, cols8, rows8, r1, out, pitch);
}
#endif

}  // namespace

terrain::Window column_lines_extent(const terrain::HeightView& z, const ViewFrame& frame) {
  const terrain::Window& w = frame.window;
  const int eye_col = static_cast<int>(std::floor(frame.observer_col));
  return {std::max(0, std::min(w.col0, eye_col) - 1), std::max(0, w.row0 - 1),
          std::min(z.width(), std::max(w.col1, eye_col + 1) + 1), std::min(z.height(), w.row1 + 1)};
}

ColumnLines transpose_columns(const terrain::HeightView& z, const terrain::Window& extent, unsigned threads,
                              terrain::Grid<float>& buffer) {
  const int lines = extent.width(), pitch = extent.height();
  if (buffer.capacity() >= static_cast<std::size_t>(lines) * static_cast<std::size_t>(pitch))
    buffer.reshape(pitch, lines);
  else
    buffer = terrain::Grid<float>(pitch, lines, terrain::kUninitialized);
  float* out = buffer.data();
  const int tasks = (lines + kColumnsPerTask - 1) / kColumnsPerTask;
  parallel_for(static_cast<std::size_t>(tasks), threads, [&](std::size_t t) {
    const int c0 = extent.col0 + static_cast<int>(t) * kColumnsPerTask;
    const int c1 = std::min(extent.col1, c0 + kColumnsPerTask);
#ifdef HORIZON_SIMD_AVX2
    if (simd::has_avx2()) {
      copy_blocked(z, extent, c0, c1, out, pitch);
      return;
    }
#endif
    copy_scalar(z, extent, c0, c1, extent.row0, extent.row1, out, pitch);
  });
  return {buffer.data(), pitch, extent};
}

}  // namespace horizon::visibility::sweep
