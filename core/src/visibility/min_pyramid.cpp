// Min-pyramid (hierarchical minimum map) and exact rectangle-minimum queries.
// The structure is the hierarchical Z-buffer of Greene, Kass and Miller,
// "Hierarchical Z-Buffer Visibility" (SIGGRAPH 1993), used here on the
// occlusion height field instead of a depth buffer.
#include "horizon/visibility/min_pyramid.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>
#include <utility>

namespace horizon::visibility {
namespace {

constexpr float kMinusInf = -std::numeric_limits<float>::infinity();

// A pyramid block and its minimum.
struct Block {
  float value;
  int i, j;
};

// Orders at most four blocks by value (insertion sort: std::sort on a
// four-element array trips GCC 12's -Warray-bounds).
void sort_blocks(Block* blocks, int n) {
  for (int a = 1; a < n; ++a)
    for (int b = a; b > 0 && blocks[b].value < blocks[b - 1].value; --b) std::swap(blocks[b], blocks[b - 1]);
}

// Next level: each cell is the minimum of up to 2x2 cells below it (fewer at
// an odd edge).
void reduce(const terrain::Grid<float>& below, terrain::Grid<float>& above) {
  const int w = above.width(), h = above.height();
  const int bw = below.width(), bh = below.height();
  for (int j = 0; j < h; ++j) {
    const float* r0 = below.row(2 * j);
    const float* r1 = 2 * j + 1 < bh ? below.row(2 * j + 1) : r0;
    float* out = above.row(j);
    for (int i = 0; i < w; ++i) {
      const int c0 = 2 * i;
      const int c1 = std::min(c0 + 1, bw - 1);
      out[i] = std::min(std::min(r0[c0], r0[c1]), std::min(r1[c0], r1[c1]));
    }
  }
}

}  // namespace

void MinPyramid::build(const terrain::Grid<float>& values) {
  int w = values.width(), h = values.height();
  std::size_t count = 1;
  for (int lw = w, lh = h; lw > 1 || lh > 1; lw = (lw + 1) / 2, lh = (lh + 1) / 2) ++count;
  if (w == 0 || h == 0) count = 0;
  if (levels_.size() != count || (count && (levels_[0].width() != w || levels_[0].height() != h))) {
    levels_.clear();
    levels_.reserve(count);
    for (std::size_t l = 0; l < count; ++l) {
      levels_.emplace_back(w, h);
      w = (w + 1) / 2;
      h = (h + 1) / 2;
    }
  }
  if (levels_.empty()) return;

  const auto src = values.values();
  auto dst = levels_[0].values();
  for (std::size_t i = 0; i < src.size(); ++i) dst[i] = std::isnan(src[i]) ? kMinusInf : src[i];
  for (std::size_t l = 1; l < levels_.size(); ++l) reduce(levels_[l - 1], levels_[l]);
}

// Block (i, j) of `level` covers level-0 cells [i 2^level, (i+1) 2^level) x
// [j 2^level, (j+1) 2^level). Called only for blocks that intersect `w` and
// whose minimum is below `best`.
void MinPyramid::descend(const terrain::Window& w, int level, int i, int j, float& best,
                         std::uint64_t& reads) const {
  const int size = 1 << level;
  const int c0 = i * size, r0 = j * size;
  const bool inside = c0 >= w.col0 && c0 + size <= w.col1 && r0 >= w.row0 && r0 + size <= w.row1;
  if (inside || level == 0) {
    best = std::min(best, level_cell(level, i, j));
    return;
  }
  // Children in the window, lowest first, so that the first one visited
  // tightens `best` and prunes the others.
  const terrain::Grid<float>& below = levels_[static_cast<std::size_t>(level - 1)];
  const int half = size / 2;
  Block children[4];
  int n = 0;
  for (int dj = 0; dj < 2; ++dj) {
    const int cj = 2 * j + dj;
    if (cj >= below.height() || cj * half >= w.row1 || (cj + 1) * half <= w.row0) continue;
    for (int di = 0; di < 2; ++di) {
      const int ci = 2 * i + di;
      if (ci >= below.width() || ci * half >= w.col1 || (ci + 1) * half <= w.col0) continue;
      children[n++] = {below.at(ci, cj), ci, cj};
      ++reads;
    }
  }
  sort_blocks(children, n);
  for (int k = 0; k < n; ++k)
    if (children[k].value < best) descend(w, level - 1, children[k].i, children[k].j, best, reads);
}

float MinPyramid::min_in(const terrain::Window& window, std::uint64_t* cells_read) const {
  assert(!window.empty());
  assert(window.col0 >= 0 && window.row0 >= 0 && window.col1 <= width() && window.row1 <= height());
  // The level where the window spans at most 2x2 blocks: 2^level >= its longer side.
  const int extent = std::max(window.width(), window.height());
  int level = 0;
  while ((1 << level) < extent && level + 1 < level_count()) ++level;

  const int size = 1 << level;
  float best = std::numeric_limits<float>::infinity();
  std::uint64_t reads = 0;
  Block blocks[4];
  int n = 0;
  for (int j = window.row0 / size; j <= (window.row1 - 1) / size; ++j)
    for (int i = window.col0 / size; i <= (window.col1 - 1) / size; ++i) {
      assert(n < 4);
      blocks[n++] = {level_cell(level, i, j), i, j};
      ++reads;
    }
  sort_blocks(blocks, n);
  for (int k = 0; k < n; ++k)
    if (blocks[k].value < best) descend(window, level, blocks[k].i, blocks[k].j, best, reads);
  if (cells_read) *cells_read += reads;
  return best;
}

}  // namespace horizon::visibility
