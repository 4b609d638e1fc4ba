// horizon/terrain/pyramid.hpp — min, max or mean of a raster over rectangles
// of cells, from reduced levels built block by block on first use.
//
// Frame: the pyramid covers a window of a source HeightView; its level 0 is
// that window, in *local* cells (local (0, 0) is source cell (window.col0,
// window.row0)). Level l, for a factor f, has ceil(w / f^l) x ceil(h / f^l)
// cells; cell (i, j) of level l reduces the level-0 cells
// [i f^l, (i+1) f^l) x [j f^l, (j+1) f^l) (fewer at the raster's east and
// south edges). Values are in the source's units (metres for terrain, OHF
// metres for culling).
//
// Reductions and voids (NaN):
//   kMin   NaN reads as -infinity: a rectangle holding a void answers -inf,
//          which for occlusion culling means "nothing known to hide it".
//   kMax   NaN never wins (a void raises no horizon); a rectangle of voids
//          only answers -infinity. Exact's stretch pruning needs this: a
//          stretch with no terrain is skipped only while no slope is known.
//   kMean  the mean of the valid cells below, NaN where there are none.
// Those rules apply to what the view reads: a view that fills its voids
// (HeightView::with_void_fill) gives the fill height to every reduction.
// Level 0 is never copied: reads of it go to the source through the same
// policy.
//
// Shape: PyramidShape{factor, levels}; factor a power of two in [2, 8].
// Culling's min-pyramid is {2, kToOneCell} (2x2 reductions up to one cell,
// the hierarchical Z-buffer); exact's max-pyramid is {8, 3} (tiles of 8, 64
// and 512 cells).
//
// Blocks: level 0 is split into blocks of block_cells x block_cells cells
// (a power of two, at least the factor). The reduced levels whose cells
// divide a block (cell side f^l <= block_cells) are stored per block, in a
// PyramidBlock built on the first read that needs it: a query over a small
// part of a huge raster builds only the blocks under the cells it reads.
// Coarser levels (only with blocks smaller than the top cell) are stored
// once for the whole raster, each cell computed on first use from the level
// below. build_all(threads) builds every block up front, for a caller that
// will read everything (exact over its whole window); for kMin and kMax it
// then also lays each block level out flat over the whole raster (one
// row-major array per level, a copy of the blocks' values, with spans when
// asked for), which is what cover_built reads: one array index per read, no
// block lookup.
//
// Ownership: the pyramid keeps the view, whose cells must outlive it and
// stay unchanged while blocks are built from it (invalidate() after changing
// it), and owns its blocks until it is destroyed or invalidated: they reduce
// cells one caller holds, for that caller. Levels of a whole elevation
// source, shared by every request, are a SourcePyramid (source_pyramid.hpp),
// whose blocks (the same PyramidBlock, from reduce_block) live in the shared
// BlockCache.
//
// Thread safety: queries may run concurrently from any threads, including
// the first ones that build blocks (std::call_once per block and per upper
// cell; a built block is then found with one acquire load). build_all may
// run beside queries, but not beside another build_all or cover_built (it
// writes the flat levels they read); cover_built may run concurrently with
// queries and itself once build_all has returned. invalidate() must not run
// concurrently with anything else.
//
// Cost: building a block reads its cells once, O(block cells), and stores
// 1/(f^2 - 1) of them again (1/3 for factor 2, 1/63 for factor 8), 4 bytes
// each (plus 4 for mean's counts); build_all's flat levels (kMin, kMax)
// store them once more (times 4 with spans). min_in / max_in are
// exact and read O(1) cells for a window aligned to a level, O(log n) when
// the extremum lies inside, O(perimeter) at worst (an extremum hugging the
// window's edge); mean_in reads O(perimeter x levels) cells.
//
// Limits: the source window must fit an int per side (as Grid does).
#pragma once

#include <atomic>
#include <cassert>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <mutex>
#include <vector>

#include "horizon/terrain/grid.hpp"
#include "horizon/terrain/height_view.hpp"

namespace horizon::terrain {

enum class Reduction { kMin, kMax, kMean };

struct PyramidShape {
  static constexpr int kToOneCell = -1;
  int factor = 2;           // cells per side reduced into one, a power of two in [2, 8]
  int levels = kToOneCell;  // reduced levels above level 0; kToOneCell: until the top is 1x1
};

struct PyramidOptions {
  int block_cells = 512;  // side of a block in level-0 cells, a power of two >= factor
  // Also store, in build_all's flat levels, each cell's reduction with its
  // east neighbour, its south neighbour and the 2x2 cells it leads, so that
  // cover_built answers a range of at most 2x2 cells with one read (exact's
  // stretches). kMin and kMax only; flat levels' memory x4.
  bool spans = false;
};

// One level of one block (or an upper or flat level of the whole raster):
// row-major cells, `width` per row.
struct PyramidLevel {
  int width = 0, height = 0;
  std::vector<float> values;
  std::vector<std::uint32_t> counts;     // kMean: valid level-0 cells below each cell
  std::vector<float> east, south, quad;  // flat levels' spans (PyramidOptions::spans), clamped to the level
  std::size_t bytes() const {
    return (values.size() + east.size() + south.size() + quad.size()) * sizeof(float) +
           counts.size() * sizeof(std::uint32_t);
  }
};

// The reduced levels 1..k of one block; levels[l - 1] is level l.
struct PyramidBlock {
  std::vector<PyramidLevel> levels;
  std::size_t bytes() const {
    std::size_t n = 0;
    for (const PyramidLevel& l : levels) n += l.bytes();
    return n;
  }
};

// Levels 1..levels of `cells`, reduced by `factor` (a power of two in
// [2, 8]) under the rules above: one block of a pyramid whose level-0 frame
// starts at cells' (0, 0). Cells at the east and south edges reduce what
// is there.
PyramidBlock reduce_block(const HeightView& cells, Reduction reduction, int factor, int levels);

class Pyramid {
 public:
  // Over `window` of `source` (inside it; an empty window makes an empty
  // pyramid, width 0, that answers no query). Asserted: the shape and
  // options as documented above. Builds nothing yet.
  Pyramid(const HeightView& source, const Window& window, Reduction reduction, PyramidShape shape = {},
          PyramidOptions options = {});
  // Over all of `source`.
  Pyramid(const HeightView& source, Reduction reduction, PyramidShape shape = {}, PyramidOptions options = {})
      : Pyramid(source, Window{0, 0, source.width(), source.height()}, reduction, shape, options) {}
  Pyramid(const Pyramid&) = delete;
  Pyramid& operator=(const Pyramid&) = delete;

  Reduction reduction() const { return reduction_; }
  int factor() const { return factor_; }
  int width() const { return width_; }
  int height() const { return height_; }
  // Levels including level 0.
  int level_count() const { return level_count_; }
  int level_width(int l) const { return level_w_[static_cast<std::size_t>(l)]; }
  int level_height(int l) const { return level_h_[static_cast<std::size_t>(l)]; }
  // Level-0 cells per side of a level-l cell: factor^l.
  int cell_side(int l) const { return 1 << (l * log_factor_); }
  int start_level(const Window& window) const;  // where a query of `window` starts

  // Cell (i, j) of level l (level 0: the source cell under the NaN policy),
  // building what it needs.
  float value(int l, int i, int j) const;
  // kMean: valid level-0 cells under cell (i, j) of level l.
  std::uint32_t count(int l, int i, int j) const;

  // Exact minimum (kMin) / maximum (kMax) / mean (kMean) over the half-open
  // window of local cells; non-empty and inside the raster (asserted: callers
  // clip). `cells_read`, when given, is increased by the pyramid cells read
  // (min_in: the same count, cell for cell, as the min-pyramid culling used
  // before this module).
  float min_in(const Window& window, std::uint64_t* cells_read = nullptr) const;
  float max_in(const Window& window, std::uint64_t* cells_read = nullptr) const;
  float mean_in(const Window& window, std::uint64_t* cells_read = nullptr) const;

  // The reduction over the level-l cells (l >= 1, a block level) that cover
  // local cells [col_lo, col_hi] x [row_lo, row_hi] (inclusive, clamped to
  // the raster; the clamped range must not be empty): a bound, not exact,
  // over a superset of the cells. One read for at most 2x2 cells when built
  // with spans. Reads build_all's flat levels (asserted built): this is the
  // hot-path read, with no build check.
  float cover_built(int l, int col_lo, int col_hi, int row_lo, int row_hi) const;

  // Builds every block and upper cell, then the flat levels (kMin, kMax), on up to
  // `threads` threads (0: all cores). Again after that: nothing new.
  void build_all(unsigned threads);
  // Drops every built block and flat level, so that later reads see the source anew.
  void invalidate();

  // Blocks built so far and their storage (bytes of reduced levels: blocks, upper and flat levels).
  std::size_t blocks_built() const { return blocks_built_.load(std::memory_order_relaxed); }
  std::size_t block_count() const { return static_cast<std::size_t>(blocks_x_) * blocks_y_; }
  int block_levels() const { return block_levels_; }
  std::size_t bytes() const;

 private:
  struct Slot {
    std::once_flag once;
    std::atomic<const PyramidBlock*> ready{nullptr};
    std::unique_ptr<PyramidBlock> block;
  };
  struct UpperLevel {
    PyramidLevel cells;
    std::unique_ptr<std::once_flag[]> once;
  };

  float source_cell(int i, int j) const;
  const PyramidBlock& block(int bi, int bj) const;
  const PyramidBlock& build_block(int bi, int bj) const;
  void fill_block(int bi, int bj, PyramidBlock& out) const;
  void ensure_upper(int l, int i, int j) const;
  // Block level l (1..block_levels_) cell (i, j) in global cell indices.
  const PyramidLevel& block_level(int l, int i, int j, std::size_t& k) const;
  float built_value(int l, int i, int j) const;

  template <class Better>
  float extreme_in(const Window& window, std::uint64_t* cells_read, Better better, float worst) const;
  template <class Better>
  void descend(const Window& w, int level, int i, int j, float& best, std::uint64_t& reads, Better better) const;
  void mean_descend(const Window& w, int level, int i, int j, double& sum, double& n, std::uint64_t& reads) const;

  HeightView source_;
  Window window_;
  Reduction reduction_;
  int factor_, log_factor_;
  int width_, height_;
  int level_count_;
  std::vector<int> level_w_, level_h_;
  int block_cells_, log_block_;
  int block_levels_;  // levels 1..block_levels_ stored per block
  bool spans_;
  int blocks_x_, blocks_y_;
  std::unique_ptr<Slot[]> slots_;
  mutable std::atomic<std::size_t> blocks_built_{0};
  mutable std::vector<UpperLevel> upper_;  // levels block_levels_ + 1 .. level_count_ - 1
  std::vector<PyramidLevel> flat_;         // after build_all: levels 1..block_levels_ over the raster
};

inline const PyramidLevel& Pyramid::block_level(int l, int i, int j, std::size_t& k) const {
  const int shift = log_block_ - l * log_factor_;  // cells of level l per block side: 2^shift
  const Slot& s = slots_[static_cast<std::size_t>(j >> shift) * static_cast<std::size_t>(blocks_x_) +
                         static_cast<std::size_t>(i >> shift)];
  const PyramidBlock* b = s.ready.load(std::memory_order_acquire);
  const PyramidLevel& level = b->levels[static_cast<std::size_t>(l - 1)];
  const int mask = (1 << shift) - 1;
  k = static_cast<std::size_t>(j & mask) * static_cast<std::size_t>(level.width) + static_cast<std::size_t>(i & mask);
  return level;
}

inline float Pyramid::cover_built(int l, int col_lo, int col_hi, int row_lo, int row_hi) const {
  assert(l >= 1 && l <= block_levels_ && reduction_ != Reduction::kMean);
  assert(flat_.size() == static_cast<std::size_t>(block_levels_));
  const PyramidLevel& level = flat_[static_cast<std::size_t>(l - 1)];
  const int shift = l * log_factor_;
  const int i0 = (col_lo > 0 ? col_lo : 0) >> shift, j0 = (row_lo > 0 ? row_lo : 0) >> shift;
  const int i1 = (col_hi < width_ - 1 ? col_hi : width_ - 1) >> shift;
  const int j1 = (row_hi < height_ - 1 ? row_hi : height_ - 1) >> shift;
  const std::size_t width = static_cast<std::size_t>(level.width);
  if (spans_ && i1 - i0 <= 1 && j1 - j0 <= 1) {
    const std::size_t k = static_cast<std::size_t>(j0) * width + static_cast<std::size_t>(i0);
    if (i1 == i0) return j1 == j0 ? level.values[k] : level.south[k];
    return j1 == j0 ? level.east[k] : level.quad[k];
  }
  const bool is_max = reduction_ == Reduction::kMax;
  float m = is_max ? -std::numeric_limits<float>::infinity() : std::numeric_limits<float>::infinity();
  for (int j = j0; j <= j1; ++j) {
    const float* row = level.values.data() + static_cast<std::size_t>(j) * width;
    for (int i = i0; i <= i1; ++i) m = is_max ? (row[i] > m ? row[i] : m) : (row[i] < m ? row[i] : m);
  }
  return m;
}

inline float Pyramid::built_value(int l, int i, int j) const {
  std::size_t k;
  return block_level(l, i, j, k).values[k];
}

}  // namespace horizon::terrain
