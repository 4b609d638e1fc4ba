// horizon/visibility/min_pyramid.hpp — minimum of a raster over any rectangle
// of cells, without reading the rectangle.
//
// A min-pyramid (a "min mip-map", the hierarchical Z-buffer of occlusion
// culling) stores the raster (level 0) and successive 2x2 reductions: cell
// (i, j) of level l holds the minimum of the level-0 cells
// [i 2^l, (i+1) 2^l) x [j 2^l, (j+1) 2^l). Level l has ceil(w / 2^l) x
// ceil(h / 2^l) cells; the top level is 1x1. Memory: about 4/3 of the raster.
//
// Query: min_in(window) starts at the level where the window spans at most
// 2x2 blocks, and descends only into blocks that straddle the window's edge
// and could still lower the answer (a block whose minimum is not below the
// best found so far is skipped). The answer is exact. Cost: O(1) blocks for a
// window aligned to its level, O(log n) when the minimum lies inside; the
// worst case (a minimum hugging the window's edge) reads O(perimeter) cells,
// far below the window's area.
//
// NaN cells ("no answer") are stored as -infinity: a query touching one
// answers -inf, which for occlusion culling means "nothing known to hide
// it", never "hidden" (see cull.hpp).
#pragma once

#include <cstdint>
#include <vector>

#include "horizon/terrain/grid.hpp"

namespace horizon::visibility {

class MinPyramid {
 public:
  MinPyramid() = default;
  explicit MinPyramid(const terrain::Grid<float>& values) { build(values); }

  // (Re)builds over `values`, reusing storage when the size is unchanged. O(cells).
  void build(const terrain::Grid<float>& values);

  int width() const { return levels_.empty() ? 0 : levels_.front().width(); }
  int height() const { return levels_.empty() ? 0 : levels_.front().height(); }
  int level_count() const { return static_cast<int>(levels_.size()); }
  // Level l; level 0 is the raster with NaN replaced by -inf.
  const terrain::Grid<float>& level(int l) const { return levels_[static_cast<std::size_t>(l)]; }

  // Exact minimum over the half-open window of cells; the window must be
  // non-empty and inside the raster (asserted: callers clip). `cells_read`,
  // when given, is increased by the number of pyramid cells read.
  float min_in(const terrain::Window& window, std::uint64_t* cells_read = nullptr) const;

 private:
  float level_cell(int l, int i, int j) const { return levels_[static_cast<std::size_t>(l)].at(i, j); }
  void descend(const terrain::Window& w, int level, int i, int j, float& best, std::uint64_t& reads) const;

  std::vector<terrain::Grid<float>> levels_;
};

}  // namespace horizon::visibility
