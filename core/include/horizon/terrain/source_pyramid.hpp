// horizon/terrain/source_pyramid.hpp — min, max or mean levels of a whole
// elevation source, block by block, kept in the shared block cache.
//
//   terrain::BlockCache cache({.budget_bytes = 128 << 20});
//   auto source = terrain::ElevationSource::open("srtm/", {});
//   terrain::SourcePyramid means(*source, cache, terrain::Reduction::kMean);
//   auto coarse = means.read(4, {0, 0, 64, 64}, &control);  // 64 x 64 cells of level 4
//
// Where Pyramid (pyramid.hpp) reduces cells a caller already holds (exact's
// window of terrain, culling's OHF), a SourcePyramid reduces a source that
// may not fit in memory, for readers that want the same coarse cells again
// and again (clip-map levels, overviews): its blocks live in the BlockCache
// every request shares, next to the elevation blocks they are built from.
//
// Frame: level l has ceil(W / f^l) x ceil(H / f^l) cells over the source's
// W x H grid, aligned to its cell (0, 0): cell (i, j) of level l reduces the
// source cells [i f^l, (i+1) f^l) x [j f^l, (j+1) f^l) (fewer at the east
// and south edges). Level 0 is the source itself. Reductions and voids follow
// Pyramid's rules: kMin reads a void as -infinity, kMax never lets one win
// (a cell of voids only is -infinity), kMean averages the valid cells and is
// NaN where there are none. Voids are the source's (nodata, and missing tiles
// under SourceOptions::missing_as_nodata).
//
// Blocks: the source grid is cut into blocks of block_cells x block_cells
// cells; a block holds levels 1..levels() of its cells (a PyramidBlock). A
// read builds, on the calling thread, the blocks under its window that the
// cache does not hold, each from the elevation blocks under it (fetched
// through the same cache, decoded on its I/O pool), and keeps them in the
// cache under (id(), block index), where LRU eviction may drop them like any
// other block; a later read builds them again, to the same values. Two
// readers that need one block build it once. A read touches only the blocks
// under its window. Levels are those that divide a block: at most
// log_f(block_cells) (9 for factor 2 and 512-cell blocks, 512 source cells
// per level-9 cell).
//
// Errors: a read fails where the source's read of a block's cells fails (a
// missing tile names its position, a corrupt file its file and block), and
// keeps nothing for that block; other blocks are unaffected.
//
// Immutable after construction and safe to share between threads; it holds
// the source, and refers to the cache, which must outlive it.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "horizon/common/control.hpp"
#include "horizon/common/error.hpp"
#include "horizon/terrain/block_cache.hpp"
#include "horizon/terrain/grid.hpp"
#include "horizon/terrain/pyramid.hpp"
#include "horizon/terrain/source.hpp"

namespace horizon::terrain {

struct SourcePyramidOptions {
  int factor = 2;                         // a power of two in [2, 8]
  int levels = PyramidShape::kToOneCell;  // kToOneCell: every level that divides a block
  int block_cells = 512;                  // a power of two >= factor; the side of a block in source cells
};

// What one read() did.
struct SourcePyramidStats {
  std::uint64_t blocks = 0;                    // pyramid blocks under the window
  std::uint64_t hits = 0;                      // found in the cache
  std::uint64_t joins = 0;                     // being built by another reader, waited for
  std::uint64_t builds = 0;                    // built by this read
  std::uint64_t elevation_blocks_decoded = 0;  // source blocks its builds decoded (cache misses)
  double seconds = 0.0;
};

class SourcePyramid {
 public:
  // Checks the options: an error names the first one out of range.
  static Result<std::shared_ptr<const SourcePyramid>> make(std::shared_ptr<const ElevationSource> source,
                                                           BlockCache& cache, Reduction reduction,
                                                           SourcePyramidOptions options = {});

  Reduction reduction() const { return reduction_; }
  int factor() const { return factor_; }
  int levels() const { return levels_; }  // reduced levels, 1..levels()
  int level_width(int l) const { return ((source_->width() - 1) >> (l * log_factor_)) + 1; }
  int level_height(int l) const { return ((source_->height() - 1) >> (l * log_factor_)) + 1; }
  int cell_side(int l) const { return 1 << (l * log_factor_); }  // source cells per side of a level-l cell
  int block_cells() const { return block_cells_; }
  std::uint64_t block_count() const { return static_cast<std::uint64_t>(blocks_x_) * blocks_y_; }
  std::uint64_t id() const { return id_; }  // namespace of its keys in the cache

  // The blocks whose cells meet `window` of level `level`, row by row.
  std::vector<std::uint64_t> blocks_in(int level, const Window& window) const;

  // The cells of `window` (level-`level` cells, clipped to the level;
  // kOutOfRange when nothing is inside, kInvalidArgument for a level
  // outside 0..levels()) as a grid, building the blocks it needs.
  // `control` (may be null) is polled between blocks and while waiting.
  Result<Grid<float>> read(int level, const Window& window, const RunControl* control = nullptr,
                           SourcePyramidStats* stats = nullptr) const;

 private:
  SourcePyramid(std::shared_ptr<const ElevationSource> source, BlockCache& cache, Reduction reduction,
                const SourcePyramidOptions& options);
  Result<std::shared_ptr<const PyramidBlock>> block(std::uint64_t index, const RunControl* control,
                                                    SourcePyramidStats& stats) const;

  std::shared_ptr<const ElevationSource> source_;
  BlockCache& cache_;
  Reduction reduction_;
  int factor_, log_factor_, levels_;
  int block_cells_, log_block_;
  int blocks_x_, blocks_y_;
  std::uint64_t id_;
};

}  // namespace horizon::terrain
