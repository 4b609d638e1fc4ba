// horizon/visibility/cull.hpp — occlusion culling of object boxes from one
// viewpoint (a simulator's "which of these 10 000 boxes can this camera see?").
//
//   auto eye = geodesy::resolve_point(dem, {.x = .., .y = .., .height = 2}, "observer");
//   std::vector<visibility::BoxSpec> boxes = ...;        // dataset CRS (or WGS84) rectangles + z range
//   auto culled = visibility::cull_boxes(dem, *eye, boxes, {.conservative = true});
//   for (auto& b : culled->boxes) ... b.state, b.ohf_min
//
// Rule. A box is the set of points (x, y, z) with (x, y) in its footprint and
// z in [z_min, z_max] (absolute metres). A point is visible when z reaches the
// occlusion height field (OHF) above it, so the box is visible iff
//   z_max >= min over the footprint of OHF    (ties within kTieTolerance count as visible),
// and that minimum, `ohf_min`, says by how much it is hidden (ohf_min - z_max).
//
// Footprints between cell centres. The OHF is known at cell centres (integer
// grid coordinates). Between them it is taken as a blend (bilinear, like the
// terrain) of the surrounding centres, which is never below their minimum. So
// a footprint spanning continuous grid columns [c0, c1] covers the centres
// floor(c0) .. ceil(c1) (likewise rows): every centre that brackets a point of
// it. This errs only towards "visible".
//
// Voids. Under NodataPolicy::kFill a void is terrain at the fill height and
// has an OHF like any cell. Under kTransparent (the default) a void cell has
// no OHF: nothing is known of a box's part over it. A footprint meeting one
// is then visible when the least OHF over its other cells lets it be seen,
// and undetermined otherwise (not hidden: the void part might be seen);
// ohf_min is that least, -inf when every cell is void.
//
// Off the map. resolve_boxes refuses a footprint not wholly inside the
// dataset; with OffMap::kAnswer it marks it instead (on_map false), and the
// box is answered kOutOfRange (nothing said of it, never culled) while the
// others are culled as usual.
//
// Work. Only the window the boxes need is computed: the OHF's max distance is
// that of the farthest covered cell centre, so a scene of nearby objects on a
// huge DEM costs a small viewshed. A min-pyramid of that OHF (terrain::Pyramid,
// Reduction::kMin, 2x2 levels) then answers each box in O(1)-O(log) cells
// whatever its footprint, building only the blocks the boxes' cells fall in
// (see terrain/pyramid.hpp).
//
// Accuracy. With `conservative`, the OHF comes from Algorithm::kConservative,
// which never reports hidden a point R3 sees, so no box R3 sees is reported
// hidden. Otherwise the OHF comes from options.algorithm and inherits its error
// (the fast radial sweep may miss a visible box whose only visible part is
// within its small angular-blend error; docs/accuracy.md quantifies it).
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "horizon/common/control.hpp"
#include "horizon/common/error.hpp"
#include "horizon/geodesy/observer.hpp"
#include "horizon/terrain/dem.hpp"
#include "horizon/terrain/pyramid.hpp"
#include "horizon/visibility/options.hpp"
#include "horizon/visibility/viewshed.hpp"

namespace horizon::visibility {

// One object box as a caller gives it.
struct BoxSpec {
  geodesy::PointFrame frame = geodesy::PointFrame::kDatasetCrs;  // of the rectangle
  // Dataset CRS x/y, or longitude/latitude in degrees for kWgs84 (then the
  // corners and edge midpoints are converted and their bounding rectangle in
  // the dataset CRS is used). x_min <= x_max, y_min <= y_max; equal = a line or point.
  double x_min = 0.0, y_min = 0.0, x_max = 0.0, y_max = 0.0;
  double z_min = 0.0, z_max = 0.0;  // absolute metres, z_min <= z_max
};

// What resolve_boxes does with a footprint not wholly inside the dataset.
enum class OffMap {
  kReject,  // kOutOfRange naming the box: the request fails
  kAnswer,  // the footprint is marked (on_map false) and answered kOutOfRange
};

// A box in grid terms: the DEM cell centres its footprint covers (half-open).
struct BoxFootprint {
  terrain::Window cells;
  double z_min = 0.0, z_max = 0.0;
  // The footprint itself, in continuous grid coordinates (inside the outer extent).
  double col_min = 0.0, col_max = 0.0, row_min = 0.0, row_max = 0.0;
  bool on_map = true;  // false: (partly) off the dataset, and the fields above unset
};

// What is known of a box from the viewpoint(s) asked about. The API words are
// "visible", "hidden", "undetermined" (visibility_name); the enumerators are
// named apart from the raster codes kVisible / kHidden (viewshed.hpp).
enum class Visibility {
  kSeen,          // visible: some point of the box is at or above the OHF (the rule above)
  kOccluded,      // hidden: every point of it is below the OHF
  kUndetermined,  // neither can be said: from a region, seen from some viewpoints and not others;
                  // from one viewpoint, hidden where the OHF is known but meeting a transparent void
  kOutOfRange,    // the footprint is not wholly on the dataset: nothing is said of it (never culled)
};

// "visible", "hidden", "undetermined".
constexpr std::string_view visibility_name(Visibility v) {
  switch (v) {
    case Visibility::kSeen:
      return "visible";
    case Visibility::kOccluded:
      return "hidden";
    case Visibility::kUndetermined:
      return "undetermined";
    case Visibility::kOutOfRange:
      return "out_of_range";
  }
  return "?";
}

struct BoxVisibility {
  Visibility state = Visibility::kSeen;
  float ohf_min = 0.0f;  // absolute metres; -inf when nothing is known to hide some point of it
};

// Whether a client may cull the box: only a hidden one.
constexpr bool may_be_seen(Visibility v) {
  return v != Visibility::kOccluded;
}

struct CullOptions {
  // OHF algorithm and knobs. max_distance and target_height are ignored: the
  // distance comes from the boxes, and boxes carry their own heights.
  ViewshedOptions viewshed;
  // Use Algorithm::kConservative whatever viewshed.algorithm says.
  bool conservative = false;
};

struct CullResult {
  std::vector<BoxVisibility> boxes;          // one per input box, same order
  std::size_t visible_count = 0;             // boxes that may be seen (not kOccluded)
  std::size_t out_of_range_count = 0;        // boxes answered kOutOfRange
  Algorithm algorithm = Algorithm::kRadial;  // the one that computed the OHF
  terrain::Window window;                    // the DEM cells the OHF covered
  WorkStats stats;                           // of the OHF computation
  std::uint64_t pyramid_cells_read = 0;      // cost of all box tests
};

// Checks and converts boxes (finite numbers, min <= max, frame conversion,
// footprint inside the DEM's outer extent). Errors name the box and field:
// kInvalidArgument "boxes[3].z_max", kOutOfRange "boxes[7]" (only with
// OffMap::kReject; a WGS84 corner the CRS cannot convert counts as off the
// map), kUnsupported for WGS84 boxes on a DEM without a CRS.
Result<std::vector<BoxFootprint>> resolve_boxes(const terrain::Dem& dem, std::span<const BoxSpec> boxes,
                                                OffMap off_map = OffMap::kReject);
// The same against a raster's georeference and size alone (a source's
// header; `source` names it in messages).
Result<std::vector<BoxFootprint>> resolve_boxes(const terrain::Georeference& georef, int width, int height,
                                                const std::string& source, std::span<const BoxSpec> boxes,
                                                OffMap off_map = OffMap::kReject);

// Ground metres from the eye to the farthest cell centre any footprint covers:
// the max distance a viewshed needs to answer these boxes.
double cull_reach(const ViewFrame& frame, std::span<const BoxFootprint> footprints);

// Tests footprints against an OHF already computed (`pyramid`: Reduction::kMin
// over all of result.ohf). Footprint cells outside result's window count as "no answer"
// (-inf, visible); voids and footprints off the map as the rules above say
// (a second min-pyramid, voids read as +inf, is built for the footprints
// that meet a void). `out` must have one element per footprint. Returns the
// number that may be seen; adds pyramid reads to *cells_read when given.
std::size_t cull_footprints(const ViewshedResult& result, const terrain::Pyramid& pyramid,
                            std::span<const BoxFootprint> footprints, std::span<BoxVisibility> out,
                            std::uint64_t* cells_read = nullptr);

// A request resolved but not yet computed: what it will cost is known
// (frame.window is the window the OHF will cover), so a server can check its
// limits and memory before any work.
struct CullPlan {
  std::vector<BoxFootprint> footprints;  // off-map boxes marked, not refused
  bool any_on_map = true;                // false: no OHF is computed, every box is kOutOfRange
  ViewshedOptions viewshed;              // algorithm chosen, max_distance = the boxes' reach
  ViewFrame frame;                       // of that viewshed
};

// Resolves the boxes (OffMap::kAnswer) and plans the OHF over the reach of
// those on the map. An empty `boxes` is kInvalidArgument ("boxes").
Result<CullPlan> plan_cull(const terrain::Dem& dem, const geodesy::GridPoint& observer, std::span<const BoxSpec> boxes,
                           const CullOptions& options);

// Computes the planned OHF, builds the pyramid and tests every box. Honours
// `control` (cancel, deadline) inside the OHF computation. `gpu` (may be
// null) and `policy` are lent to the OHF computation as compute_viewshed()
// describes: the fast algorithm may run there; the stats say where it ran.
// `storage` (viewshed.hpp) is lent to the OHF computation and given the OHF
// and terrain rasters back once the boxes are tested (for the next run).
Result<CullResult> run_cull(const terrain::Dem& dem, const geodesy::GridPoint& observer, const CullPlan& plan,
                            const RunControl* control = nullptr, gpu::ContextPool* gpu = nullptr,
                            const BackendPolicy* policy = nullptr, ResultStorage storage = {});

// plan_cull + run_cull.
Result<CullResult> cull_boxes(const terrain::Dem& dem, const geodesy::GridPoint& observer,
                              std::span<const BoxSpec> boxes, const CullOptions& options,
                              const RunControl* control = nullptr, gpu::ContextPool* gpu = nullptr,
                              const BackendPolicy* policy = nullptr);

}  // namespace horizon::visibility
