// horizon/mesh/tin_from_dem.hpp — a TIN built from a DEM by greedy insertion.
//
// Garland and Heckbert's greedy insertion ("Fast polygonal approximation
// of terrains and height fields", 1995): start from the DEM's corners, then
// repeatedly add the cell centre whose height the current TIN misses by the
// most, re-triangulating (Delaunay, CGAL's Delaunay_triangulation_2) after
// each, until the TIN has `max_vertices` vertices or no cell is off by more
// than `max_error` metres. Each triangle keeps its worst cell, so an insertion
// rescans only the triangles it made. An error within a millionth of the
// cell's height is float32 rounding and counts as none: a plane stays two
// triangles.
//
// Vertices are cell centres (x, y in the DEM's CRS, z the cell's height);
// void (NaN) cells are never vertices and never measured. The corners are
// the DEM's four corner cells, or where one is void the valid cell nearest
// it (Chebyshev rings); cells outside the hull of those four are not
// represented and are counted in `outside`. Deterministic: the same DEM and
// options give the same TIN, vertex for vertex.
//
// The fit (max and RMSE of |DEM - TIN| over the valid cells the TIN covers)
// is measured anew over the finished TIN by measure_fit, which any TIN of
// the same DEM can be given.
#pragma once

#include <cstdint>

#include "horizon/common/error.hpp"
#include "horizon/mesh/tin.hpp"
#include "horizon/terrain/dem.hpp"

namespace horizon::mesh {

struct GreedyOptions {
  std::uint32_t max_vertices = 100'000;  // >= 4 (the corners); also capped by the valid cells
  double max_error = 0.0;                // metres, >= 0: stop once every cell is within it
};

// |DEM - TIN| over the DEM's valid cell centres, the TIN interpolated
// linearly in its triangles (seen from above).
struct TinFit {
  double max_error = 0.0;     // metres
  double rmse = 0.0;          // metres
  std::uint64_t cells = 0;    // valid cells inside the TIN, measured
  std::uint64_t outside = 0;  // valid cells outside it, not measured
};

struct DemTin {
  Tin tin;
  TinFit fit;
};

// kInvalidArgument for options out of range; kDataError when the DEM has
// fewer than two rows or columns, or its corners' nearest valid cells do
// not span an area.
Result<DemTin> tin_from_dem(const terrain::Dem& dem, const GreedyOptions& options);

// The fit of `tin` (in `dem`'s CRS) to `dem`. Each cell centre is measured
// once, in the first triangle (by index) that holds it; a vertex within
// 1e-9 cells of a cell centre is taken to be on it.
TinFit measure_fit(const Tin& tin, const terrain::Dem& dem);

}  // namespace horizon::mesh
