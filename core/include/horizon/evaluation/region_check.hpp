// horizon/evaluation/region_check.hpp — checking from-region verdicts
// (region/region.hpp) against exact R3 from viewpoints sampled densely in
// the region: its 8 corners, its 12 edge midpoints, points on its 6 faces and
// points inside it. A verdict is wrong when one sampled viewpoint sees an
// "always hidden" item, or fails to see an "always visible" one. Sound
// verdicts give zero wrong ones however many viewpoints are sampled.
#pragma once

#include <cstdint>
#include <vector>

#include "horizon/geodesy/observer.hpp"
#include "horizon/region/region.hpp"
#include "horizon/terrain/dem.hpp"

namespace horizon::evaluation {

struct RegionSampling {
  int face_points = 8;     // per face, uniform on it
  int interior_points = 1000;
  unsigned seed = 1;
};

// The sampled viewpoints (grid coordinates and absolute elevation) of
// `region` as resolved in `frame`: heights above ground are taken above the
// ground at each sampled position (positions over a void are left out).
std::vector<geodesy::GridPoint> sample_region(const terrain::Dem& dem, const region::RegionSpec& region,
                                              const region::RegionFrame& frame, const RegionSampling& sampling);

struct RegionCheck {
  std::uint64_t viewpoints = 0;
  std::uint64_t hidden_checked = 0, visible_checked = 0;  // decided items checked
  std::uint64_t wrong_hidden = 0, wrong_visible = 0;      // (item, viewpoint) pairs that contradict
  // R3 from the samples alone: items hidden from every sampled viewpoint
  // (an upper bound on the truly always-hidden ones), and the same for visible.
  std::uint64_t sampled_hidden = 0, sampled_visible = 0;
  std::uint64_t items_checked = 0;
  double seconds = 0.0;
};

// Checks up to `max_cells` answered cells of `result` (evenly strided over
// the window), each against every viewpoint, on `threads` threads.
RegionCheck check_cells(const terrain::Dem& dem, const region::RegionCellsResult& result,
                        const region::RegionOptions& options, const std::vector<geodesy::GridPoint>& viewpoints,
                        std::size_t max_cells, unsigned threads);

// Checks every box verdict (box visible from V as culling defines it, void
// centres left out).
RegionCheck check_boxes(const terrain::Dem& dem, const region::RegionBoxesResult& result,
                        std::span<const visibility::BoxSpec> boxes, const region::RegionOptions& options,
                        const std::vector<geodesy::GridPoint>& viewpoints, unsigned threads);

}  // namespace horizon::evaluation
