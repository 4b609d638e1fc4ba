// horizon/visibility/radial_sweep.hpp — the fast occlusion height field.
//
// US patent 7,027,046 (perspective modulation + orthographic propagation) done
// on the CPU. Heights relative to the eye divided by distance ("modulated"
// into slopes) turn perspective occlusion into a running maximum along radial
// lines; multiplying the maximum back by the distance gives the OHF.
//
// The plane is split into four sectors around the observer (north, south:
// |dx| <= |dy|; east, west: |dy| < |dx|). In each sector rays leave the eye
// with evenly spaced slopes so that neighbouring rays are at most
// `ray_spacing` cells apart at the sector's far edge. Each ray is marched one
// grid line at a time along the sector's major axis and takes, at every grid
// row and column crossing, exactly the terrain sample R3 takes, so along a ray
// the running maximum is R3's horizon exactly. A cell centre lies between two
// neighbouring rays; its horizon comes from theirs at the step that reaches
// the cell's line (RayBlend). The default, kResample, takes the cell's own
// sight line's R3 samples where the two rays found their maxima (each ray
// records where), so every value is a real sample: the result can only err
// towards "visible", when the cell's maximum lies where neither ray's did.
// kLinear / kMin blend the rays' horizons by angle instead.
//
// Work: ~2 ray steps per cell of the max-distance window at ray_spacing 1
// (rays are denser near the eye; RadialOptions::thinning_levels trades that
// for accuracy), plus up to 3 re-samples per cell; no allocation per cell,
// O(rays) scratch per sector.
// Sectors split into ray chunks run in parallel.
#pragma once

#include "horizon/common/control.hpp"
#include "horizon/common/error.hpp"
#include "horizon/terrain/grid.hpp"
#include "horizon/terrain/height_view.hpp"
#include "horizon/visibility/options.hpp"
#include "horizon/visibility/view_frame.hpp"
#include "horizon/visibility/viewshed.hpp"
#include "horizon/visibility/work_stats.hpp"

namespace horizon::visibility {

enum class RadialBound {
  kNone,        // the options' blend, in float: fastest
  kLowerBound,  // RayBlend::kResample in double, OHF rounded down: never above R3's OHF (no missed-visible)
};

// Same contract as r3_ohf(): fills `ohf` (sized frame.window) with the OHF of
// every in-range cell, NaN out of range or on a transparent void.
//
// `column_buffer`, when given, is a float grid the sweep may reshape and
// fill with a transposed copy of the window's part the east and west
// sectors read (their columns as contiguous lines; sized to the window and
// a few cells more, of which only that part is written), so that those sectors read
// their terrain as the north and south ones do: a caller's kept buffer that
// the run does not otherwise use while it sweeps (a workspace's terrain
// raster, or its OHF raster when only a mask is made), so that the copy
// takes no new pages. The answer is the same bits with it or without it;
// it only goes faster (the kLowerBound sweep does not use it). Without it
// those sectors read the elevation in place.
Status radial_ohf(const terrain::HeightView& elevation, const ViewFrame& frame, const RadialOptions& options,
                  unsigned threads, const RunControl* control, terrain::Grid<float>& ohf, WorkStats& stats,
                  RadialBound bound = RadialBound::kNone, terrain::Grid<float>* column_buffer = nullptr);

// The visibility mask that visibility_mask() would make at `target_height`
// from radial_ohf()'s OHF, byte for byte, and its counts, without the OHF:
// each cell is coded in the sweep from the height it would have had, by
// min_target_height_at's rule. `mask` is sized to frame.window; 1 visible,
// 0 hidden, 255 out of range or a void target. The code rasters of the CLI
// and the daemon, and many observers' sites, take this road: a 12 M-cell
// run writes 12 MB of codes instead of 48 MB of heights, and makes no pass
// over them afterwards. The re-sampling blend
// only (options.blend == kResample, the default; kInvalidArgument else).
// The field of view is not applied (compute_viewshed falls back to the OHF
// when one limits it). `column_buffer`: as radial_ohf's.
Status radial_mask(const terrain::HeightView& elevation, const ViewFrame& frame, const RadialOptions& options,
                   double target_height, unsigned threads, const RunControl* control, terrain::Grid<std::uint8_t>& mask,
                   AnswerCounts& counts, WorkStats& stats, terrain::Grid<float>* column_buffer = nullptr);

}  // namespace horizon::visibility
