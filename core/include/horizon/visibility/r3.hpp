// horizon/visibility/r3.hpp — the exact "R3" line-of-sight reference.
//
// Definition (Franklin & Ray's R3, as in ../shared/DESIGN.md): a point above
// target cell T is visible from the eye E when, at every crossing of the
// segment E->T with a grid row line or grid column line (the lines joining
// cell centres), strictly between E and T, the segment is at or above the
// terrain. Terrain on a grid line is the linear interpolation of the two cell
// centres it lies between (the bilinear surface restricted to that line);
// curvature lowers both terrain and target by curvature * d^2.
//
// In slope form, with s(p) = (z(p) - curvature*d(p)^2 - eye) / d(p):
//   horizon(T) = max over crossings p of s(p)       (-inf when there are none)
//   OHF(T)     = eye + d(T) * horizon(T) + curvature * d(T)^2
// OHF(T) is the lowest absolute elevation visible above T's centre. A crossing
// whose interpolation touches a void is skipped (NodataPolicy::kTransparent) or
// uses the fill height (kFill).
//
// Cost: O(distance) per target, O(cells * distance) in all; multi-threaded by
// rows. This is ground truth for tests and accuracy reports, not a fast path.
#pragma once

#include "horizon/common/control.hpp"
#include "horizon/common/error.hpp"
#include "horizon/terrain/grid.hpp"
#include "horizon/terrain/height_view.hpp"
#include "horizon/visibility/view_frame.hpp"
#include "horizon/visibility/work_stats.hpp"

namespace horizon::visibility {

// Fills `ohf` (sized frame.window, cell (0,0) = window corner) with the exact
// OHF of every in-range cell; NaN for cells out of range or on a void (when
// voids are transparent). `ohf`'s storage is reused when it already has the
// window's size (see reset_output()). `elevation` already has voids filled or NaN per
// policy.
Status r3_ohf(const terrain::HeightView& elevation, const ViewFrame& frame, unsigned threads,
              const RunControl* control, terrain::Grid<float>& ohf, WorkStats& stats);

// The exact horizon slope (see above) for one target at continuous grid
// coordinates, for tests and line-of-sight queries.
double r3_horizon(const terrain::HeightView& elevation, const ViewFrame& frame, double target_col,
                  double target_row);

// The OHF r3_ohf() stores for the target cell (col, row) of `elevation`
// (-inf when no crossing lies between it and the eye), for checks that need
// R3's answer at a few cells only. The cell must be in range.
float r3_ohf_at(const terrain::HeightView& elevation, const ViewFrame& frame, int col, int row);

}  // namespace horizon::visibility
