// Private: enumeration of R3's terrain samples along a segment.
//
// The terrain samples R3 takes for the segment (c0, r0) -> (c1, r1) in grid
// coordinates are its crossings with column lines x = integer and row lines
// y = integer strictly between the endpoints. On a column line the terrain is
// the linear interpolation between the two cell centres above and below the
// crossing; on a row line, between the two left and right of it.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>

#include "horizon/terrain/grid.hpp"

namespace horizon::visibility::detail {

// Calls visit(t, col, row, terrain) for every crossing, where t in (0, 1) is
// the fraction of the segment. Column crossings come first, in order of t,
// then row crossings, in order of t. terrain is NaN where a void is involved.
// Positions are clamped to the grid (they leave it only within the outer
// half-cell margin an endpoint may sit in).
template <class Visit>
void for_each_crossing(const terrain::Grid<float>& z, double c0, double r0, double c1, double r1, Visit&& visit) {
  const int w = z.width(), h = z.height();
  // Walk the integers strictly between a0 and a1 along one axis; `sample`
  // reads the grid given the integer line and the continuous cross position.
  auto walk = [&](double a0, double a1, double b0, double b1, int line_count, int pos_count, auto&& sample,
                  bool along_columns) {
    const double da = a1 - a0, db = b1 - b0;
    if (da == 0) return;
    const int step = da > 0 ? 1 : -1;
    const int first = da > 0 ? static_cast<int>(std::floor(a0)) + 1 : static_cast<int>(std::ceil(a0)) - 1;
    const int last = da > 0 ? static_cast<int>(std::ceil(a1)) - 1 : static_cast<int>(std::floor(a1)) + 1;
    for (int line = first; step > 0 ? line <= last : line >= last; line += step) {
      const double t = (line - a0) / da;
      const double pos = std::clamp(b0 + t * db, 0.0, double(pos_count - 1));
      const int p0 = std::min(static_cast<int>(pos), pos_count - 2);
      const double terrain = (line < 0 || line >= line_count) ? std::numeric_limits<double>::quiet_NaN()
                                                               : sample(line, p0, pos - p0);
      if (along_columns)
        visit(t, double(line), pos, terrain);
      else
        visit(t, pos, double(line), terrain);
    }
  };
  walk(c0, c1, r0, r1, w, h,
       [&](int c, int p0, double f) { return z.at(c, p0) + f * (double(z.at(c, p0 + 1)) - z.at(c, p0)); }, true);
  walk(r0, r1, c0, c1, h, w,
       [&](int r, int p0, double f) { return z.at(p0, r) + f * (double(z.at(p0 + 1, r)) - z.at(p0, r)); }, false);
}

}  // namespace horizon::visibility::detail
