// horizon/clipmap/clip_viewshed.hpp — a viewshed around the eye from the
// horizons traced over a clip-map (clip_cull.hpp's trace), for a session's
// per-pose summary.
//
//   clipmap::ClipmapReader view(*map);
//   auto seen = clipmap::viewshed_on_clipmap(view, eye, {.mode = clipmap::ClipMode::kConservative, .radius = 3000});
//   seen->visible_cells, seen->mask    // 1 visible, 0 hidden, 255 no answer
//
// Cells. Every source cell whose centre lies within `radius` metres of the
// eye, in the square window around it (ClipViewshed::window, source grid).
// Cells beyond the radius, off the source, or on a void get 255.
//
// Rule. Every column (ray in fast mode, wedge in conservative mode) is
// traced out to the radius. A cell at ground distance d and azimuth θ takes
// the horizon h of the rings before the ring holding d, and is visible when
//   z + target_height + kTieTolerance >= eye + d h + curvature d²
// (visibility/viewshed.hpp's rule), z its own value.
//   kFast: h blends the two rays bracketing θ by angle (as the radial sweep
//   blends its rays), over the mean levels; z is level 0's cell, or the mean
//   sampled at the cell from the first coarser level resident.
//   kConservative: h is the wedge holding θ (its lower bound on every sight
//   line in it, clip_cull.hpp), so a cell called hidden is hidden for R3 on
//   the full-resolution terrain; z must be level 0's own cell: where level 0
//   is not resident the cell cannot be shown hidden and is called visible.
// kExact is not a clip-map mode here (a session answers it from the source).
//
// Cost. The trace is the culling trace run on every column out to the
// radius; the cells are (2 radius / cell + 1)², at most kMaxCells.
#pragma once

#include <cstdint>

#include "horizon/clipmap/clip_cull.hpp"
#include "horizon/terrain/grid.hpp"

namespace horizon::clipmap {

struct ClipViewshedOptions {
  ClipMode mode = ClipMode::kFast;
  int rays = 1024;             // as ClipCullOptions
  unsigned threads = 1;        // 0: all cores
  double radius = 0.0;         // metres, > 0
  double target_height = 0.0;  // metres above the ground, >= 0
};

struct ClipViewshed {
  static constexpr std::uint64_t kMaxCells = std::uint64_t{1} << 24;
  terrain::Window window;            // source cells of the mask
  terrain::Grid<std::uint8_t> mask;  // window-sized: visibility::kVisible / kHidden / kNoAnswer
  std::uint64_t visible_cells = 0, hidden_cells = 0;  // within the radius
  ClipCullStats stats;               // of the trace
};

// The window a radius covers around the eye (clipped to the source) and its
// cells, or kInvalidArgument "viewshed_radius" for a radius that is not a
// positive number or covers more than kMaxCells cells.
Result<terrain::Window> clip_viewshed_window(const Clipmap& map, const ClipEye& eye, double radius);

// Errors: check_cull_inputs()'s, clip_viewshed_window()'s, and
// "target_height" when negative or not finite. Honours `control`. With
// `gpu`, the trace runs on that GL context as cull_on_clipmap's does (the
// same horizons); the cells are resolved on the CPU.
Result<ClipViewshed> viewshed_on_clipmap(const ClipmapReader& view, const ClipEye& eye,
                                         const ClipViewshedOptions& options, const RunControl* control = nullptr,
                                         ClipCullScratch* scratch = nullptr, gpu::Lease* gpu = nullptr);

}  // namespace horizon::clipmap
