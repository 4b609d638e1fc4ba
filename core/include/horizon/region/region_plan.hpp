// horizon/region/region_plan.hpp — from-region visibility over a terrain
// source (a daemon's dataset): the window a classification needs, its cost
// known from the header before any cell is read, then the run.
//
//   region::RegionQuery q{.region = from, .boxes = boxes};            // or .cells = true
//   auto plan = region::plan_region(source, q);                        // window, cells, bytes
//   // check plan->cells and plan->bytes against the caller's limits
//   auto run = region::run_region(*plan, source, &cache, &control);
//
// The window. Every sight line between a viewpoint of the region and an item
// lies in the rectangle bounding both (segments stay in the convex hull of
// their ends), so the terrain outside the rectangle bounding the region and
// every item cannot change a verdict: the plan reads that rectangle (cell
// centres bracketing it, plus one cell) and the run classifies on it alone,
// with the verdicts classify_boxes / classify_cells give on the whole DEM.
// For cells the items are every cell within options.max_distance ground
// metres of the region's footprint, which must then be finite or the whole
// dataset is read.
//
// Cost: `cells` is the window's cell count and `bytes` what the run holds
// (elevations, the answer raster, the fuzzy faces and pyramids the
// classification builds); the classification's own work bound
// (plan_region_cells / plan_region_boxes) is known once the window is read.
#pragma once

#include <cstdint>
#include <vector>

#include "horizon/common/control.hpp"
#include "horizon/common/error.hpp"
#include "horizon/region/region.hpp"
#include "horizon/terrain/block_cache.hpp"
#include "horizon/terrain/source.hpp"

namespace horizon::region {

struct RegionQuery {
  RegionSpec region;
  std::vector<visibility::BoxSpec> boxes;  // the items, unless `cells`
  bool cells = false;                      // classify every DEM cell within options.max_distance instead
  RegionOptions options;
};

struct RegionSourcePlan {
  RegionQuery query;
  terrain::Window window;   // the cells read, in the source's grid
  std::uint64_t cells = 0;  // window.cell_count()
  std::uint64_t bytes = 0;  // held by the run, bound
};

// The bytes each item box holds from its conversion to the end of its run:
// its spec, its footprint and its verdict (part of a plan's `bytes`). A
// caller can hold `boxes * kBytesPerBox` before it converts a request's
// boxes, so that the conversion is paid for before it is made.
inline constexpr std::uint64_t kBytesPerBox =
    sizeof(visibility::BoxSpec) + sizeof(visibility::BoxFootprint) + sizeof(Verdict);

// Checks the query (options, region and boxes finite and on the dataset:
// kOutOfRange "region" / "boxes[3]", an empty box list without `cells`:
// kInvalidArgument "boxes") and sizes the window.
Result<RegionSourcePlan> plan_region(const terrain::ElevationSource& source, RegionQuery query);

struct RegionRun {
  // Boxes: one verdict per query box. Cells: the codes over `window`
  // (Verdict values, kNoAnswer), in the source's grid.
  std::vector<Verdict> verdicts;
  terrain::Grid<std::uint8_t> codes;
  terrain::Window window;
  RegionStats stats;
  terrain::SourceReadStats read;
};

Result<RegionRun> run_region(const RegionSourcePlan& plan, const terrain::ElevationSource& source,
                             terrain::BlockCache* cache, const RunControl* control = nullptr);

}  // namespace horizon::region
