// Private to the radial sweep: the cells of one line re-sampled through R3's
// own arithmetic (RadialBound::kLowerBound: the conservative OHF, and the
// exact sweep's lower bound).
//
// Each cell takes R3's samples of its own sight line (crossings.hpp, bit for
// bit) on the line before it and on the lines where its two bracketing rays
// found their horizons, keeps the highest slope and turns it into R3's OHF
// value. That value is never above R3's, since R3 takes the same samples
// and more. It is most of the conservative sweep's time, so it has three
// kernels with the same double arithmetic: a scalar one (crossings.hpp
// itself), an AVX2 one (four cells at once, hardware gathers) and an
// AVX-512 one (eight), chosen at run time (simd_isa::kernel_isa()). All give
// the same bits (tests/visibility/test_resample_r3.cpp); the file is built
// without fused multiply-adds.
#pragma once

#include <cstdint>

#include "horizon/terrain/height_view.hpp"
#include "horizon/visibility/view_frame.hpp"

namespace horizon::visibility::sweep {

// A grid line to sample a cell's sight line on: line `index` of the u family
// (the sector's lines) or of the v family; index < 0: none.
struct R3Line {
  int index = -1;
  bool u = true;
};

// The cells of one line of a sector.
struct R3CellLine {
  const terrain::HeightView* grid = nullptr;  // the whole DEM (voids read as its fill)
  const ViewFrame* frame = nullptr;           // the eye (observer_col, observer_row, eye) and curvature
  bool rows = true;                           // u runs along rows: u lines are rows, v lines columns
  int line = 0;                               // this line's u index (DEM)
  int before = -1;                            // the u line before it (DEM index), -1: none
};

// For cells i in [0, count) (count <= 64): the cell at v index v[i] (DEM) of
// `line`, ViewFrame::distance total[i] > 0 from the eye, sampled on
// line.before, first[i] and second[i] (in that order; a line the segment does
// not cross strictly between its ends gives no sample). Writes out[i]:
// r3_ohf_value of the highest slope, rounded to float, or -inf when no
// sample was taken or all read voids.
void resample_r3_cells(const R3CellLine& line, int count, const int* v, const double* total, const R3Line* first,
                       const R3Line* second, float* out);

// The same with the scalar kernel whatever the CPU, for the tests.
void resample_r3_cells_scalar(const R3CellLine& line, int count, const int* v, const double* total, const R3Line* first,
                              const R3Line* second, float* out);

}  // namespace horizon::visibility::sweep
