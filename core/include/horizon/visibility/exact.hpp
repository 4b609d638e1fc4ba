// horizon/visibility/exact.hpp — R3's answers, fast (Algorithm::kExact).
//
// The exact OHF of every target, bit-identical to r3_ohf(), at a fraction of
// its cost. Brute-force R3 walks every target's whole sight line. This walk
// skips the stretches that provably cannot hold the maximum:
//
//  1. A lower bound per target: the radial sweep with RadialBound::kLowerBound
//     (re-sampled R3 samples of each cell's own sight line), usually equal to
//     the exact horizon or just below it.
//  2. A max-pyramid of the terrain (tiles of 8, 64 and 512 cells;
//     terrain/pyramid.hpp, built whole before the search). A stretch
//     of a sight line is bounded by the highest vertex of the tiles around
//     it; its samples' slopes cannot exceed (zmax - eye) / d - curvature d
//     over its distance range. A stretch whose bound is below the best slope
//     known (the lower bound, then the samples found) is skipped whole;
//     otherwise it is split 8 ways, down to stretches of 64 cells (8 when
//     deciding visibility only) whose crossings are screened with cheap
//     vector arithmetic against the height the best slope needs there
//     (exact_screen.hpp); the few that may reach it are taken exactly as
//     R3 takes them (crossings.hpp).
//
//  3. Near the eye (out to 768 cells): bounds by direction sector and grid
//     line (sector_bounds.hpp). Directions are cut into 1024 narrow
//     sectors; for each sector and each grid line near the eye the table
//     bounds the slope of any crossing of that line by a sight line in the
//     sector (the highest terrain between the sector's two edges' crossings
//     over the nearer distance). A sight line screens only the lines whose
//     bound reaches the best slope known, found through block and span
//     maxima of the table: usually a few lines around the ridge that hides
//     it. Beyond the table's reach a coarse bound per sector and band of
//     distance (tiles of 64 cells) skips the far part of most sight lines
//     at once; the pyramid prunes the rest as above. The
//     pyramid's square tiles span wide angles near the eye, where every
//     sight line passes; the sectors follow the sight line (on the 12 M-cell
//     Everest case the search screens 47 M crossings for R3's whole OHF,
//     against 2.28 G with the pyramid alone).
//
// Targets are searched in square tiles of 64 cells, so that neighbouring
// sight lines share the table's sectors and the terrain around them in the
// caches.
//
// The line or stretch holding R3's maximum is never skipped (its bounds,
// tile and sector, are at least that maximum, which is at least the lower
// bound), so the maximum found is R3's, computed by the same arithmetic.
// Cost: O(cells * log) when the lower bound is tight; never more than R3's
// samples plus the bound lookups, and the table's build (about 1.6 M
// entries).
#pragma once

#include <optional>

#include "horizon/common/control.hpp"
#include "horizon/common/error.hpp"
#include "horizon/terrain/grid.hpp"
#include "horizon/terrain/height_view.hpp"
#include "horizon/visibility/options.hpp"
#include "horizon/visibility/view_frame.hpp"
#include "horizon/visibility/work_stats.hpp"

namespace horizon::visibility {

// Same contract and same values as r3_ohf(). `radial` tunes step 1 only.
//
// With `visibility_only_at` (a target height, ViewshedOptions::visibility_only)
// only the visible/hidden answer is exact: a target the lower bound already
// hides is not searched at all, and the search of the others prunes against
// the sight line to the target itself (far tighter than the bound) and stops
// at the first crossing that hides it. Each OHF value is then one that gives
// R3's answer under the viewshed's rule (visibility_mask at that target
// height): R3's own value, or a lower bound of it that hides or shows the
// target as R3's does; min_target_height() of it is not R3's.
Status exact_ohf(const terrain::HeightView& elevation, const ViewFrame& frame, const RadialOptions& radial,
                 unsigned threads, const RunControl* control, terrain::Grid<float>& ohf, WorkStats& stats,
                 std::optional<double> visibility_only_at = std::nullopt);

}  // namespace horizon::visibility
