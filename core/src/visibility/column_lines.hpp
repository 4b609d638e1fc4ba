// Private to the radial sweep: the east and west sectors' lines as rows.
//
// The east and west sectors march the elevation's columns. Read in place,
// each lane of a group lands on another row: hardware gathers for the rays,
// and a cache line of every row a task's rays cross (hundreds of rows at a
// time), which the rays' reads, the cells' re-samples and the codes they
// write keep evicting from one another; per ray step those sectors cost two
// to three times the north and south ones. A transposed copy of the columns
// they read makes their lines contiguous like the rows: the rays then read
// runs of each line (ray_steps.hpp, LineStep::run_last) and the cells their
// targets as plain loads. The copy is a blocked transpose (eight by eight
// floats in registers where the CPU has AVX2) on the engine's threads, into
// a buffer the caller keeps (a workspace's raster that the run does not
// otherwise fill while it sweeps), so a daemon pays no page faults for it.
//
// The copy holds raw elevations (voids stay NaN; the sweep's HeightView
// fill is applied where it reads them, as in place), so the sweep's every
// sample is the same float either way and its answers are the same bits.
#pragma once

#include <cstddef>

#include "horizon/terrain/grid.hpp"
#include "horizon/terrain/height_view.hpp"
#include "horizon/visibility/view_frame.hpp"

namespace horizon::visibility::sweep {

// Columns [extent.col0, extent.col1) and rows [extent.row0, extent.row1) of
// an elevation, transposed: the height at (column c, row r) is
// lines[(c - extent.col0) * pitch + (r - extent.row0)].
struct ColumnLines {
  const float* lines = nullptr;
  std::ptrdiff_t pitch = 0;  // floats per column: extent.height()
  terrain::Window extent;
};

// The cells the east and west sectors of `frame` may read: the frame's
// window and the eye's column, one more cell on every side where `z` has
// it (the line behind a sector's first, a two-cell bracket on a one-cell
// window), inside z.
terrain::Window column_lines_extent(const terrain::HeightView& z, const ViewFrame& frame);

// Copies `extent` (inside z) of z's raw elevations transposed into
// `buffer`, which is reshaped to extent.height() x extent.width(), keeping
// its storage when that is large enough; on `threads`.
ColumnLines transpose_columns(const terrain::HeightView& z, const terrain::Window& extent, unsigned threads,
                              terrain::Grid<float>& buffer);

}  // namespace horizon::visibility::sweep
