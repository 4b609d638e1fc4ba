// horizon/evaluation/mesh_r3.hpp — a TIN's cull read against R3's viewshed
// of the DEM the TIN was made from.
//
// The mesh bench (mesh_bench.hpp) checks the cull against exact sight lines
// over the TIN itself: what the renderer draws. This is the other reference
// issue #19 asks for: the terrain the TIN approximates. For one camera:
//
//  1. R3's viewshed of the source DEM (visibility/viewshed.hpp, algorithm
//     "exact": R3's visible/hidden answer bit for bit, test_modes.cpp), the
//     eye at the camera's place in the DEM's CRS and its absolute height,
//     targets on the ground, the whole DEM, voids transparent and a flat
//     earth (curvature coefficient 0): the TIN's local frame models no
//     curvature (local_frame.hpp), so both references see the same geometry
//     up to the TIN's vertical error and, for a geographic DEM, the frames'
//     metres (R3 takes the cell size at the eye, the TIN a tangent plane).
//  2. Each DEM cell under a triangle (tin_raster.hpp) is one cell-view;
//     counted: those R3 hides ("truly hidden"), those whose triangle the
//     cull dropped, and those dropped that R3 sees. Cells outside the TIN
//     and voids (no R3 answer) are not counted.
//
// The two references differ for a reason: the TIN misses the DEM by up to
// its fit's max error (tin_from_dem.hpp), so a ridge the TIN shaves lower
// lets a sight line through that R3 stops, and a valley it fills hides what
// R3 sees; a conservative cull is sound against the TIN, not the DEM.
//
// Cost: one exact viewshed per camera, O(cells log) typical; counting is
// one pass over the cells.
#pragma once

#include <cstdint>
#include <vector>

#include "horizon/common/control.hpp"
#include "horizon/common/error.hpp"
#include "horizon/mesh/tin.hpp"
#include "horizon/terrain/dem.hpp"
#include "horizon/terrain/grid.hpp"

namespace horizon::evaluation {

// Cell-views over the DEM cells a TIN covers.
struct R3CellCounts {
  std::uint64_t cells = 0;              // under a triangle, with an R3 answer
  std::uint64_t r3_hidden = 0;          // of them, R3 hides ("truly hidden")
  std::uint64_t culled = 0;             // of them, their triangle was culled
  std::uint64_t culled_r3_visible = 0;  // culled, yet R3 sees the cell
  R3CellCounts& operator+=(const R3CellCounts& o) {
    cells += o.cells, r3_hidden += o.r3_hidden, culled += o.culled, culled_r3_visible += o.culled_r3_visible;
    return *this;
  }
};

// R3's viewshed of the whole of `dem` from `eye` (x, y in the DEM's CRS;
// z absolute metres, the DEM's vertical datum), as above: a dem-sized grid,
// 1 visible, 0 hidden, 255 no answer (a void). kOutOfRange when the eye is
// off the DEM; a viewshed's error (cancelled, ...) as it is.
Result<terrain::Grid<std::uint8_t>> r3_ground_viewshed(const terrain::Dem& dem, const mesh::TinVertex& eye,
                                                       unsigned threads = 0, const RunControl* control = nullptr);

// The counts for one camera: `cell_triangle` from mesh::cell_triangles over
// the DEM's grid (indices of the TIN's triangles), `r3` from
// r3_ground_viewshed (the same size), `culled[t]` nonzero when triangle t
// (the same numbering) was culled.
R3CellCounts count_cells(const terrain::Grid<std::uint32_t>& cell_triangle, const terrain::Grid<std::uint8_t>& r3,
                         const std::vector<std::uint8_t>& culled);

}  // namespace horizon::evaluation
