// horizon/visibility/cull_index.hpp — box culling at simulator scale: many
// boxes, exactly, against one OHF that stays warm between calls.
//
//   auto ohf = visibility::compute_viewshed(dem, eye, options);       // once per viewpoint
//   visibility::CullIndex index(ohf->ohf, ohf->frame.window, visibility::CullIndex::levels_for(footprints));
//   visibility::BoxBatch batch(footprints);                           // once per box set
//   std::vector<visibility::BoxVisibility> out(batch.size());
//   std::size_t seen = visibility::cull_batch(index, batch, out);     // every frame
//
// Same rule, same answers. A box is visible when z_max + kTieTolerance
// reaches the least OHF over the cell centres its footprint covers
// (cull.hpp). cull_batch gives, box for box, the state and the ohf_min bits
// that cull_footprints gives with the min-pyramid: both are exact minima of
// the same cells. Voids follow cull.hpp's rule (decided on the cells that
// have an OHF, else undetermined): when the OHF has any, a second set of
// levels with voids read as +inf answers the boxes whose first read is -inf.
//
// The index. Level k (0 <= k <= levels - 1) holds, for every OHF cell, the
// least OHF over the 2^k x 2^k square of cells whose north-west corner it is
// (clipped at the raster's east and south edges): a min-pyramid kept at full
// resolution rather than decimated, so that squares may start anywhere.
// A footprint of w x h cells, with s = 2^k the largest power of two not
// above min(w, h) (and k below `levels`), is the union of
// ceil(w / s) x ceil(h / s) such squares, the last of each row and column
// pulled back inside it: its minimum is the least of those reads, exact,
// since the squares may overlap but never leave it. A box whose longer side
// is at most 2s (every square box, and any whose two sides fall in one
// octave [2^k, 2^(k+1)]) takes four reads, the vector kernel's case; the
// others take more and are tested by the scalar loop after the vector pass.
//
// The batch. The boxes in structure-of-arrays form (cells and thresholds as
// 32-bit lanes), sorted along a Z-order (Morton) curve of their footprints'
// corners, so that boxes near one another on the ground are tested one after
// the other and their reads share cache lines; `order` maps the sorted
// position back to the caller's index, and answers come back in the
// caller's order. A batch holds DEM cells, not index cells: one batch serves
// every OHF computed for those boxes, whatever its window.
//
// Kernels. cull_batch tests eight boxes at a time with AVX2 gathers, or
// sixteen with AVX-512, when the CPU has them (sweep::simd::kernel_isa, the
// cap the tests and benchmarks set), and box by box otherwise; each form
// gives the scalar loop's bits (tests/visibility/test_cull_index.cpp checks
// all three against cull_footprints and brute force).
//
// Groups, when only the states are wanted (CullBatchOptions::exact_minimum
// false). The batch also keeps, for each run of kGroup boxes in Z order,
// the rectangle bounding their footprints and the highest of their
// thresholds; the index keeps the least OHF over each aligned block of
// kBlock x kBlock cells (voids -inf). When a group's rectangle is at most
// kGroupSpan cells a side and the least over the blocks that cover it lies
// above the group's highest threshold, every box of the group is hidden
// (each box's minimum is at least that least, above its threshold): the
// group is answered kOccluded from a few block reads (at most 25) without
// testing its boxes, each box's ohf_min then that least, a lower bound on
// its own. Otherwise its boxes are tested one by one as above. Clustered
// boxes make small rectangles, and more boxes in the same clusters make
// them smaller, so the cost of a hidden cluster grows slower than its box
// count; scattered boxes make wide rectangles, which are never tried.
// States are always the exact ones.
//
// Cost: the index stores levels x the OHF's cells, 4 bytes each (twice that
// when the OHF has voids), and one block value per 64 cells, built in
// O(levels x cells); a test reads 4 index cells for a box of aspect up to 2
// and ceil(w / s) x ceil(h / s) for others. levels_for() picks the fewest
// levels that give every box of the set the largest square fitting it, at
// most kMaxLevels (16 x 16 cells); index_bytes() says what that will take
// before it is built.
//
// Thread safety: an index and a batch are immutable once built; any number
// of cull_batch calls may read them at once.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "horizon/common/large_allocator.hpp"
#include "horizon/terrain/grid.hpp"
#include "horizon/visibility/cull.hpp"

namespace horizon::visibility {

class CullIndex {
 public:
  static constexpr int kMaxLevels = 5;  // squares of 1, 2, 4, 8 and 16 cells
  static constexpr int kBlock = 8;      // side of the blocks of block_min_over, cells

  // Over `ohf`, whose cell (0, 0) is DEM cell (window.col0, window.row0)
  // (a ViewshedResult's ohf and frame.window). `levels` is clamped to
  // [1, kMaxLevels]. NaN cells (no answer) read as -inf. Builds every level
  // on up to `threads` threads (0: all cores).
  CullIndex(const terrain::Grid<float>& ohf, const terrain::Window& window, int levels = kMaxLevels,
            unsigned threads = 1);

  // The fewest levels giving every footprint the largest square that fits
  // it (side 2^floor(log2 min(w, h))), capped at kMaxLevels; 1 for none.
  static int levels_for(std::span<const BoxFootprint> footprints);
  // Bytes an index of `levels` levels over a width x height OHF stores.
  // `voids`: the OHF has NaN cells, and a second set of levels is kept.
  static std::uint64_t index_bytes(int width, int height, int levels, bool voids = false);

  int levels() const { return levels_; }
  int width() const { return width_; }
  int height() const { return height_; }
  const terrain::Window& window() const { return window_; }
  bool has_voids() const { return !known_.empty(); }
  std::uint64_t bytes() const {
    return static_cast<std::uint64_t>(values_.size() + known_.size() + blocks_.size()) * sizeof(float);
  }

  // Least OHF over the local cells [col0, col1) x [row0, row1): non-empty
  // and inside the raster (asserted). Adds the index cells read to *reads.
  float min_in(int col0, int row0, int col1, int row1, std::uint64_t* reads = nullptr) const;
  // The same with voids read as +inf: the least over the cells that have an
  // OHF (+inf when none has). min_in when the OHF has no voids.
  float known_min_in(int col0, int row0, int col1, int row1, std::uint64_t* reads = nullptr) const;

  // Least OHF (voids -inf) over the aligned kBlock x kBlock blocks that
  // cover the local cells [col0, col1) x [row0, row1) (non-empty, inside):
  // at most the least over the rectangle itself. Adds the blocks read to *reads.
  float block_min_over(int col0, int row0, int col1, int row1, std::uint64_t* reads = nullptr) const;

  // Level k's cells, row-major, width() per row; level k + 1 follows level
  // k, plane() cells on.
  const float* level(int k) const { return values_.data() + static_cast<std::size_t>(k) * plane_; }
  std::size_t plane() const { return plane_; }

 private:
  terrain::Window window_;
  int width_ = 0, height_ = 0, levels_ = 1;
  std::size_t plane_ = 0;  // cells per level
  float least_in(const float* levels, int col0, int row0, int col1, int row1, std::uint64_t* reads) const;

  std::vector<float, LargeAllocator<float>> values_;  // mapped and populated up front, not zeroed
  std::vector<float, LargeAllocator<float>> known_;   // voids as +inf; empty when the OHF has none
  std::vector<float> blocks_;                         // least over each kBlock x kBlock block, voids -inf
  int block_cols_ = 0;
};

// Boxes as the kernels read them (see the header comment).
struct BoxBatch {
  static constexpr std::size_t kGroup = 16;  // boxes a group, consecutive in Z order
  static constexpr int kGroupSpan = 32;      // the widest group rectangle tried, cells

  BoxBatch() = default;
  explicit BoxBatch(std::span<const BoxFootprint> footprints);

  std::size_t size() const { return order.size(); }

  // DEM cells covered, half-open, in sorted order.
  std::vector<std::int32_t> col0, row0, col1, row1;
  // The largest float t with t <= z_max + kTieTolerance (in double): a box
  // is visible iff ohf_min <= threshold, the rule of cull.hpp in float.
  std::vector<float> threshold;
  std::vector<std::uint8_t> on_map;  // 0: the box is off the map (BoxFootprint::on_map), answered kOutOfRange
  std::vector<std::uint32_t> order;  // sorted position -> caller's index
  // Group g (sorted boxes g * kGroup .. + kGroup): the DEM cells bounding
  // their footprints and their highest threshold; only groups of kGroup
  // boxes on the map whose rectangle is at most kGroupSpan a side are kept
  // (group_first: their first sorted position).
  std::vector<std::uint32_t> group_first;
  std::vector<std::int32_t> group_col0, group_row0, group_col1, group_row1;
  std::vector<float> group_threshold;
};

struct CullBatchOptions {
  // true: every box's ohf_min is its exact least OHF (as cull_footprints).
  // false: a group shown hidden as a whole gives its boxes a lower bound
  // (above their thresholds) instead; the states are the same.
  bool exact_minimum = true;
};

struct BatchStats {
  std::uint64_t reads = 0;         // index cells read
  std::uint64_t vector_boxes = 0;  // boxes answered by the vector kernel (four reads each)
  std::uint64_t outside = 0;       // boxes (partly) outside the index's window, off-map ones included
  std::uint64_t groups_tried = 0, groups_hidden = 0;  // whole groups tested, and answered hidden at once
};

// Tests every box of `batch` against `index`; out[i] answers the caller's
// box i (out.size() == batch.size(), asserted). As cull_footprints: a box
// off the map is kOutOfRange; a footprint not wholly inside the index's
// window has no answer for part of it (-inf, visible); one meeting a void is
// decided on its other cells, or undetermined. Returns the number that may
// be seen (not kOccluded).
std::size_t cull_batch(const CullIndex& index, const BoxBatch& batch, std::span<BoxVisibility> out,
                       BatchStats* stats = nullptr, const CullBatchOptions& options = {});

}  // namespace horizon::visibility
