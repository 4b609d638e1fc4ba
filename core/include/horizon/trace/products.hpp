// horizon/trace/products.hpp — what a traced frame gives a person or a
// program: the picture, the depth image, the per-pixel hits, the DEM cells
// the camera sees, and how much of each object box it sees.
//
// All take a TraceResult and the view it was traced over (the same cells,
// the same grid). Images are row-major from the top-left, as the frame.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "horizon/common/control.hpp"
#include "horizon/common/error.hpp"
#include "horizon/terrain/grid.hpp"
#include "horizon/terrain/height_view.hpp"
#include "horizon/trace/trace.hpp"

namespace horizon::trace {

// Range in metres along each pixel's ray from the eye to its hit; NaN for
// sky. What a depth sensor or a z-buffer in metres would give.
terrain::Grid<float> depth_image(const TraceResult& frame);

// Per pixel, the hit's continuous grid coordinates in `col_offset`,
// `row_offset`-shifted cells (pass the view's corner in the source's grid
// to name source cells) and its elevation in metres; NaN for sky. Three
// images of the frame's size.
struct HitImages {
  terrain::Grid<float> col, row, elevation;
};
HitImages hit_images(const TraceResult& frame, int col_offset = 0, int row_offset = 0);

// The terrain as the camera sees it, RGB 8-bit: elevation tinted (green
// lowlands through brown to white peaks, over the frame's own elevation
// range), lit by a sun from the north-west 45 degrees up (slopes from the
// view's cells around each hit, true metric cell sizes), fading into haze
// with distance; sky a gradient from the horizon's haze to blue overhead.
std::vector<std::uint8_t> shaded_view(const TraceResult& frame, const terrain::HeightView& view);

// Writes shaded_view as a PNG, atomically (temporary name + rename).
Status write_shaded_png(const std::string& path, const TraceResult& frame, const terrain::HeightView& view);

// The camera's footprint over the view: 1 where some pixel's hit lies in
// the cell (the cell nearest the hit point), 0 where none does, 255 on
// voids. The view's size and grid.
terrain::Grid<std::uint8_t> footprint(const TraceResult& frame, const terrain::HeightView& view);

// An object box in the view's grid: its footprint (continuous grid
// coordinates, as visibility::BoxFootprint) and its absolute heights.
struct ViewBox {
  double col_min = 0, col_max = 0, row_min = 0, row_max = 0;
  double z_min = 0, z_max = 0;
};

// How much of a box the camera sees.
struct BoxView {
  std::uint64_t pixels = 0;   // pixels whose ray passes through the box (0: out of the frame)
  std::uint64_t visible = 0;  // of those, the ones that reach the box before the terrain
  double fraction() const { return pixels ? static_cast<double>(visible) / static_cast<double>(pixels) : 0.0; }
};

// Per box, the pixels whose ray meets it (ground footprint within
// [near, max_distance], height within the box at the ray's entry, the box
// lowered by curvature at its mid-depth) and which of them meet it before
// their terrain hit. Cost: each box's columns times the rows its slope
// range spans, at most boxes x pixels: box_pixel_bound() gives the bound
// before any work. Boxes are answered on options.threads threads, `control`
// (may be null) polled between boxes: kCancelled / kDeadlineExceeded.
Result<std::vector<BoxView>> box_views(const TraceResult& frame, std::span<const ViewBox> boxes,
                                       const TraceOptions& options, const RunControl* control = nullptr);

// An upper bound on the pixel tests box_views makes for these boxes with
// this camera (each box's column span times the frame's height), from the
// camera alone: what a request's cost is checked against.
std::uint64_t box_pixel_bound(const Camera& camera, std::span<const ViewBox> boxes);

}  // namespace horizon::trace
