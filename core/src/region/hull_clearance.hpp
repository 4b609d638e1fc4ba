// region/hull_clearance.hpp — the always-visible half of from-region
// visibility: does every segment from the region to a point clear R3's
// terrain? (The rule is in horizon/region/region.hpp.)
#pragma once

#include <cstdint>

#include "horizon/region/region.hpp"
#include "horizon/terrain/grid.hpp"
#include "horizon/terrain/height_view.hpp"
#include "horizon/terrain/pyramid.hpp"

namespace horizon::region {

class HullClearance {
 public:
  // Over the DEM nodes of `nodes` (a window of `terrain`, the DEM under the
  // request's void policy), which must hold every region footprint and
  // every point tested. Builds the grid of square maxima (one per 2x2 nodes)
  // on `threads` threads; the pyramid over it is built as descents reach it.
  // One clearance serves every piece of a region: the terrain is the same.
  HullClearance(const terrain::HeightView& terrain, const terrain::Window& nodes, unsigned threads);
  HullClearance(const HullClearance&) = delete;
  HullClearance& operator=(const HullClearance&) = delete;

  // True when every segment from the region `frame` to the point (col, row, z) (a
  // cell centre inside the node window; absolute metres) is at or above
  // R3's terrain at every crossing, with the curvature margin; false when
  // that could not be shown within `budget` pyramid reads. Adds the reads
  // to *reads. Thread-safe.
  bool clear(const RegionFrame& frame, double col, double row, double z, int budget, std::uint64_t* reads) const;

 private:
  terrain::Window nodes_;
  terrain::Grid<float> squares_;  // max of each square's four nodes; -inf when all are voids
  terrain::Pyramid pyramid_;      // kMax, 2x2 up to one cell, over squares_
};

}  // namespace horizon::region
