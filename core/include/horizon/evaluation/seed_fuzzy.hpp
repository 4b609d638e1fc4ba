// horizon/evaluation/seed_fuzzy.hpp — WO 93/00650's own construction of the
// always-hidden cells, built beside region::classify_cells (the walls) to
// show which does better: not a product path.
//
//   auto walls = region::classify_cells(dem, spec, options);          // the product
//   auto seed = evaluation::seed_fuzzy_hidden(dem, *walls, {});      // the same cells, the seed's way
//
// The construction, per side face of the projection cube around the region
// (east, west, south, north; directions (1, a, b) per metre along the face
// axis p, a = dl/dp, b = dz/dp), on a fuzzy array of `columns` x `rows`
// elements over a in [-2, 2] and b in [-1, 1]:
//   1. Patches: the DEM's triangles beyond the region on that face, two a
//      DEM square (the diagonal that makes the square's surface convex,
//      the lower of the two, so that a sight line below a triangle is below
//      R3's terrain at one of the square's edge crossings: a convex
//      function lies under its chord), lowered by kLowering so that it is
//      below by a margin R3's float32 answer cannot round away.
//   2. Front-facing: a patch faces every viewpoint (the region's top face,
//      whose four corners suffice: a viewpoint lower than another at the
//      same place is hidden wherever that one is, as region.hpp says).
//   3. Sub-surfaces: front-facing patches joined across shared edges
//      (union-find); boundary edges: their edges whose other side is not
//      front-facing (or missing, a void, outside the window).
//   4. The patches rendered from one viewpoint v0 (the top face's centre):
//      each element's centre takes the nearest patch containing it, and
//      keeps its sub-surface when that patch is front-facing (farther
//      sub-surfaces behind an element are given up, the "1 = nearest"
//      choice).
//   5. Each boundary edge's fuzzy extent (the rectangle of elements holding
//      its projections from every viewpoint: 2 endpoints x 4 corners, a
//      linear-fractional map over a polytope taking its extremes at the
//      vertices) takes the elements marked with its own sub-surface out of
//      it. An element still marked is in that sub-surface's non-fuzzy
//      (umbra) region: inside its projection from every viewpoint (the
//      seed's single-viewpoint rule: no projection of its boundary from
//      any viewpoint meets the element, and its centre is inside from v0).
//   6. Depths: for every front-facing patch, its fuzzy extent (3 vertices x
//      4 corners) raises D(e) to its farthest p in the elements e whose
//      sub-surface is its own: the farthest any ray of e from the region
//      can meet that sub-surface.
//   7. An item (a cell's target) is always hidden when, on some face, every
//      element of its fuzzy extent (4 projections) is umbra with D(e)
//      nearer than the item: the depth rule the seed prints backwards,
//      corrected (the occluder's farthest against the item's nearest).
// Curvature only raises occluders relative to a sight line (region.hpp), so
// no margin is taken for it.
//
// Cost: per face, every window triangle beyond the region is tested, joined,
// rendered (its projection's elements) and spread over its fuzzy extent; the
// array holds columns x rows x 17 bytes (17 MiB at 1024 x 1024, 272 MiB at
// 4096 x 4096), and the patches 10 bytes a triangle.
//
// One piece: the region's footprint as one box (RegionOptions::footprint_splits
// is not applied), heights as the frame resolved them; compare it with
// classify_cells at footprint_splits = 1.
#pragma once

#include <cstdint>

#include "horizon/common/control.hpp"
#include "horizon/common/error.hpp"
#include "horizon/region/region.hpp"
#include "horizon/terrain/dem.hpp"
#include "horizon/terrain/grid.hpp"

namespace horizon::evaluation {

struct SeedFuzzyOptions {
  int columns = 1024;          // fuzzy-array elements along a, [8, 8192]
  int rows = 1024;             // and along b, [8, 8192]
  double target_height = 0.0;  // metres above each cell, as the region options said
};

struct SeedFuzzyStats {
  double seconds = 0.0;
  std::uint64_t patches = 0, front_facing = 0, sub_surfaces = 0, boundary_edges = 0;  // summed over faces
  std::uint64_t items = 0, always_hidden = 0;
  // Why the others were not: per item, on the last face that held its
  // extent, the first element that failed was outside every umbra (no
  // front-facing sub-surface nearest there, or in a boundary extent), or
  // umbra with its sub-surface reaching as far as the item; or no face's
  // array held its extent.
  std::uint64_t not_umbra = 0, too_deep = 0, off_array = 0;
  std::uint64_t elements = 0, umbra_elements = 0;  // over the faces with front-facing patches
};

struct SeedFuzzyResult {
  // The walls' window: 0 always hidden, 2 not decided, region::kNoAnswer
  // where the walls' answer has none.
  terrain::Grid<std::uint8_t> codes;
  terrain::Window window;
  SeedFuzzyStats stats;
};

// The seed's always-hidden cells over `walls`' window and frame (the same
// cells and targets; `walls` from classify_cells). Errors: kInvalidArgument
// "columns" / "rows" outside [8, 8192]. Honours `control` between faces and
// every 4096 DEM rows of patches.
Result<SeedFuzzyResult> seed_fuzzy_hidden(const terrain::Dem& dem, const region::RegionCellsResult& walls,
                                          const SeedFuzzyOptions& options, const RunControl* control = nullptr);

}  // namespace horizon::evaluation
