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

// The part of each column that the east and west sectors read: those
// sectors hold the cells nearer the eye's row than its column (|dy| < |dx|),
// and every sample they take of the column k cells from the eye (a ray's,
// its crossing's on the column before, a cell's re-sample) lies within
// k + 2 rows of the eye's (a sight line's slope is at most one, plus the
// two-cell bracket and the column before); kMargin rounds that up. The
// rest of the window, the north and south sectors', need not be copied:
// about half of it for an eye in the middle.
struct ColumnWedge {
  static constexpr int kMargin = 4;
  double eye_col = 0.0, eye_row = 0.0;  // the frame's observer_col, observer_row

  // The rows of `extent` that columns [c0, c1) need (the farthest of them
  // from the eye sets the span); row0 == row1 when none.
  terrain::Window rows_of(const terrain::Window& extent, int c0, int c1) const;
};

// Copies `extent` (inside z) of z's raw elevations transposed into
// `buffer`, which is reshaped to extent.height() x extent.width(), keeping
// its storage when that is large enough; on `threads`. With a `wedge`, only
// the rows of each column that it names are copied; the others hold
// whatever the buffer held.
ColumnLines transpose_columns(const terrain::HeightView& z, const terrain::Window& extent, unsigned threads,
                              terrain::Grid<float>& buffer, const ColumnWedge* wedge = nullptr);

}  // namespace horizon::visibility::sweep
