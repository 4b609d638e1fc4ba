// horizon/trace/trace_plan.hpp — a camera trace planned on a source's
// header, its cells and cost known before anything is read, then run.
//
//   auto plan = trace::plan_trace(**source, {.camera = spec, .options = options});
//   if (plan->cost.bytes > budget) ...                          // refuse before any work
//   auto run = trace::run_trace(*plan, **source, &cache, &control);
//   trace::write_shaded_png("view.png", run->frame, run->view());
//
// Planning reads no pixel: it checks the camera and options, places the
// eye in the source's grid, and finds the cells the frame can see: the
// bounding box of the ground wedge between the first and last columns'
// azimuths out to max_distance (to the source's far corner without one),
// with a 2-cell margin, clipped to the source. A 60 degree camera reads
// about a sixth of what a viewshed of the same reach would. Running reads
// exactly those cells (through the block cache when one is given), applies
// the request's height edits to its own copy, puts the eye on the ground
// and traces (trace.hpp).
#pragma once

#include <cstdint>
#include <vector>

#include "horizon/common/control.hpp"
#include "horizon/common/error.hpp"
#include "horizon/geodesy/observer.hpp"
#include "horizon/gpu/context_pool.hpp"
#include "horizon/terrain/block_cache.hpp"
#include "horizon/terrain/height_edit.hpp"
#include "horizon/terrain/source.hpp"
#include "horizon/trace/camera.hpp"
#include "horizon/trace/products.hpp"
#include "horizon/trace/trace.hpp"
#include "horizon/visibility/cull.hpp"

namespace horizon::trace {

struct TraceQuery {
  CameraSpec camera;
  TraceOptions options;
  // Object boxes whose visible share of pixels the run reports (box_views);
  // a box off the dataset is answered with no pixels.
  std::vector<visibility::BoxSpec> boxes;
  // Height edits applied, in order, to the cells this frame reads.
  std::vector<terrain::HeightEdit> edits;
};

// What a trace will cost, known before it runs.
struct TraceCost {
  std::uint64_t pixels = 0;
  std::uint64_t read_cells = 0;       // source cells read
  std::uint64_t blocks = 0;           // source blocks under them
  std::uint64_t block_bytes = 0;      // their decoded size
  std::uint64_t lines = 0;            // grid lines a column can cross (the read window's longer side)
  std::uint64_t crossings = 0;        // silhouette-map entries, at most
  std::uint64_t box_pixel_tests = 0;  // box_pixel_bound of the boxes
  std::uint64_t edit_cells = 0;
  // Working memory: the cells read, the per-pixel image, the kernels'
  // per-thread maps and trees for `threads` threads, the depth image and the
  // footprint a caller may draw from it.
  std::uint64_t bytes = 0;
  double seconds = 0.0;  // rough, one core (measured costs per crossing and per pixel read)
};

struct TracePlan {
  TraceQuery query;
  geodesy::GridPoint eye;  // located in the source's grid (ground and elevation not yet known)
  terrain::Window read;    // the cells the run reads, in the source's grid
  std::vector<std::uint64_t> blocks;
  std::vector<visibility::BoxFootprint> boxes;  // in the source's grid (on_map false: off the dataset)
  TraceCost cost;
};

// The most box-pixel tests one frame may make (2^30).
inline constexpr std::uint64_t kMaxBoxPixelTests = std::uint64_t{1} << 30;

// Errors: the camera's (validate_camera, "camera.yaw"...; the position as
// "camera.position.lon" through geodesy::locate_point, kOutOfRange off the
// source), the options' (validate_trace_options), the boxes' (as
// visibility::resolve_boxes: "boxes[3].z_max"), the edits'
// (terrain::validate_edits), and kResourceExhausted naming "boxes" past
// kMaxBoxPixelTests.
Result<TracePlan> plan_trace(const terrain::ElevationSource& source, const TraceQuery& query, unsigned threads = 0);

struct TraceRun {
  terrain::Dem dem;              // the cells read, edits applied: the view traced
  terrain::Window window;        // dem's cells in the source's grid
  terrain::Georeference georef;  // of `window` (the source's transform shifted to its corner)
  geodesy::GridPoint eye;        // on the ground, in the source's grid
  TraceResult frame;             // the camera's eye in dem's grid
  std::vector<BoxView> boxes;    // per query box
  std::uint64_t edited_cells = 0;
  terrain::SourceReadStats read;

  terrain::HeightView view() const { return terrain::HeightView(dem.elevation); }
};

// Reads the planned cells (`cache` may be null: read the files directly),
// applies the edits, places the eye (kDataError on a void under an
// above-ground eye, naming "camera"), traces (on `gpu`'s context when one
// is lent, as trace_frame), and answers the boxes. `previous` (may be
// null): a finished run whose frame storage this one takes over, so that a
// camera path allocates no image per frame.
Result<TraceRun> run_trace(const TracePlan& plan, const terrain::ElevationSource& source, terrain::BlockCache* cache,
                           const RunControl* control = nullptr, gpu::Lease* gpu = nullptr,
                           TraceRun* previous = nullptr);

}  // namespace horizon::trace
