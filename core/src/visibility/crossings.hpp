// Private: enumeration of R3's terrain samples along a segment.
//
// The terrain samples R3 takes for the segment (c0, r0) -> (c1, r1) in grid
// coordinates are its crossings with column lines x = integer and row lines
// y = integer strictly between the endpoints. On a column line the terrain is
// the linear interpolation between the two cell centres above and below the
// crossing; on a row line, between the two left and right of it.
//
// R3 (r3.cpp) and the exact sweep (exact.cpp) both take their samples through
// this file, so the same crossing always gives the same double.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>

#include "../common/int_floor.hpp"
#include "horizon/terrain/grid.hpp"
#include "horizon/terrain/height_view.hpp"
#include "horizon/visibility/view_frame.hpp"

namespace horizon::visibility::detail {

enum class Axis { kColumns, kRows };

using ::horizon::ceil_to_int;
using ::horizon::floor_to_int;

// Visits, for one family of grid lines, the crossings strictly between the
// segment's endpoints whose line index lies in [line_lo, line_hi]:
// visit(t, col, row, terrain), t in (0, 1) the fraction of the segment, in
// order of t. terrain is NaN where a void is involved. Positions along the
// line are clamped to the grid (they leave it only within the outer half-cell
// margin an endpoint may sit in).
//
// The arithmetic runs in coordinates relative to the first endpoint's cell, so
// the samples are the same doubles wherever the segment sits in the grid: a
// DEM shifted by whole cells, or cropped around the segment, gives bit-for-bit
// the same answers.
template <class Visit>
void for_each_crossing_on(Axis axis, const terrain::HeightView& z, double c0, double r0, double c1, double r1,
                          int line_lo, int line_hi, Visit&& visit) {
  const bool columns = axis == Axis::kColumns;
  const int line_count = columns ? z.width() : z.height();
  const int pos_count = columns ? z.height() : z.width();
  // Integer offsets along the line family (A) and along the lines (B).
  const double a_abs0 = columns ? c0 : r0, b_abs0 = columns ? r0 : c0;
  const int A = floor_to_int(a_abs0), B = floor_to_int(b_abs0);
  const double a0 = a_abs0 - A, a1 = (columns ? c1 : r1) - A;
  const double b0 = b_abs0 - B, b1 = (columns ? r1 : c1) - B;
  const double da = a1 - a0, db = b1 - b0;
  if (da == 0) return;
  const int step = da > 0 ? 1 : -1;
  int first = da > 0 ? floor_to_int(a0) + 1 : ceil_to_int(a0) - 1;
  int last = da > 0 ? ceil_to_int(a1) - 1 : floor_to_int(a1) + 1;
  // The caller's line range, relative (the full range needs no clamping).
  const int lo = line_lo == std::numeric_limits<int>::min() ? std::numeric_limits<int>::min() : line_lo - A;
  const int hi = line_hi == std::numeric_limits<int>::max() ? std::numeric_limits<int>::max() : line_hi - A;
  if (step > 0) {
    first = std::max(first, lo);
    last = std::min(last, hi);
  } else {
    first = std::min(first, hi);
    last = std::max(last, lo);
  }
  for (int rel = first; step > 0 ? rel <= last : rel >= last; rel += step) {
    const int line = rel + A;
    const double t = (rel - a0) / da;
    const double pos_rel = b0 + t * db;
    // R3's clamp of the position to [0, pos_count - 1], bracket [p0, p0 + 1] and weight f.
    int p0 = floor_to_int(pos_rel);
    double f = pos_rel - p0;
    p0 += B;
    if (p0 < 0) {
      p0 = 0;
      f = 0.0;
    } else if (p0 >= pos_count - 1) {
      p0 = pos_count - 2;
      f = 1.0;
    }
    double terrain = std::numeric_limits<double>::quiet_NaN();
    if (line >= 0 && line < line_count) {
      terrain = columns ? z.at(line, p0) + f * (double(z.at(line, p0 + 1)) - z.at(line, p0))
                        : z.at(p0, line) + f * (double(z.at(p0 + 1, line)) - z.at(p0, line));
    }
    const double pos = p0 + f;
    if (columns)
      visit(t, double(line), pos, terrain);
    else
      visit(t, pos, double(line), terrain);
  }
}

// Every crossing: column crossings first, in order of t, then row crossings.
template <class Visit>
void for_each_crossing(const terrain::HeightView& z, double c0, double r0, double c1, double r1, Visit&& visit) {
  constexpr int kLo = std::numeric_limits<int>::min(), kHi = std::numeric_limits<int>::max();
  for_each_crossing_on(Axis::kColumns, z, c0, r0, c1, r1, kLo, kHi, visit);
  for_each_crossing_on(Axis::kRows, z, c0, r0, c1, r1, kLo, kHi, visit);
}

// R3's slope of a sample at fraction t of a sight line `total` metres long:
// (terrain - curvature d^2 - eye) / d with d = t * total.
inline double r3_slope(const ViewFrame& f, double total, double t, double terrain) {
  const double d = t * total;
  return (terrain - f.curvature * d * d - f.eye) / d;
}

// R3's OHF from the horizon slope of a target `d` metres away.
inline double r3_ohf_value(const ViewFrame& f, double d, double horizon) {
  return f.eye + d * horizon + f.curvature * d * d;
}

}  // namespace horizon::visibility::detail
