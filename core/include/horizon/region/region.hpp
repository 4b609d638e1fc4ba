// horizon/region/region.hpp — from-region ("fuzzy") visibility: what is seen
// from anywhere in a box of viewpoints (after WO 93/00650, for terrain).
//
//   region::RegionSpec from{.x_min = .., .y_min = .., .x_max = .., .y_max = .., .z_min = 2, .z_max = 50};
//   auto cells = region::classify_cells(dem, from, {.max_distance = 10000});
//   // cells->codes: 0 always hidden, 1 always visible, 2 undetermined, 255 no answer
//   auto boxes = region::classify_boxes(dem, from, object_boxes, {});
//
// Verdicts. For an item (a DEM cell's target point, or an object box) and
// every viewpoint V of the region:
//   kAlwaysHidden   R3 (visibility/r3.hpp) says the item is hidden from V;
//   kAlwaysVisible  R3 says it is visible from V;
//   kUndetermined   neither could be shown (it may still hold).
// A box is visible from V as culling defines it (visibility/cull.hpp): some
// DEM cell centre its footprint covers is seen at z_max (centres on voids
// are left out: they have no target; a box over voids alone stays
// undetermined). Both verdicts are
// sound by construction (below), never estimates: a test samples the region
// densely with exact R3 and finds no verdict wrong.
//
// Frame. Continuous grid coordinates scaled to metres at the region's centre
// (x = col * metres_per_col, y = row * metres_per_row). R3's answer without
// curvature does not depend on that scale (lines stay lines, ratios stay), so
// only curvature margins use the metres.
//
// Always hidden: the fuzzy array on the cube faces. The region is a box B.
// On each of the four side faces of a projection cube around B (east, west,
// south, north; face axis p, lateral axis l), a direction from B is (1, a, b)
// per metre along p: a = dl/dp picks a column of the face's fuzzy array
// (face_resolution columns over a in [-kFaceSpan, kFaceSpan]), b = dz/dp is
// the slope. The occluders are R3's own crossings: the DEM's grid lines
// across the face axis ("walls", at p = w * metres per cell). Every ray of
// column c leaving B crosses wall w inside a lateral interval [lo, hi] (from
// B's corners and the column's edges: the extremes of a bilinear form) and is
// strictly below the terrain there when its slope is below
//   cover(c, w) = min over V in B's top face of (L - z_max) / (p_w - V.p),
// L the lowest node of the wall over [lo, hi] (R3 interpolates a crossing
// between two of them). Terrain only ever closes a column from below, so the
// fuzzy array keeps, per column, the highest cover of the walls swept so far
// (a continuous value: no rows to snap). The walls are swept outward from B:
// an item whose directions from B's top face fall in columns c0..c1 with
// slopes up to b_max, and lies beyond the walls swept, is hidden from all of B when
// min over c0..c1 of cover > b_max: each of its rays crosses a wall between
// V and the item below the terrain. Curvature only raises occluders relative
// to a sight line (by curvature * s * (D - s), s and D the distances to the
// crossing and the target), so these verdicts need no margin. A void (NaN,
// transparent) covers nothing; with NodataPolicy::kFill it is terrain at the fill.
// Items whose footprint meets B's (seen straight down), or whose directions
// leave every face's span, are not decided hidden.
//
// The seed's array, for comparison (RegionOptions::fuzzy_rows = N > 0): the
// same occluders on a two-dimensional fuzzy array of N rows of slope over b
// in [-1, 1] per column, as WO 93/00650 tessellates a face. A row is in a
// column's umbra when all of it lies below that column's cover, and an
// item's fuzzy extent is snapped outward to whole rows, so it is hidden when
// the rows up to the one holding its steepest direction are umbra in every
// column of its extent (directions steeper than 1 leave the array:
// undetermined; those below -1 are granted, as if the bottom face's array
// hid them). Every verdict of that array is one the continuous cover gives
// too; `horizon bench --region --rows` measures what the rows lose.
//
// Always visible: every segment from B to a point q must pass at or above
// R3's terrain at every crossing. The segments fill conv(B + q); over a
// rectangle F of DEM squares its lowest point is bounded from the fractions
// of the way from q at which segments cross F (|p - q| / |V - q|, from
// distances between q, F and B's footprint), and each crossing's terrain is at
// most the highest of the square's four nodes. A max-pyramid of those squares
// is descended from the top: a tile whose rectangle misses the hull's
// footprint, or whose maximum lies below the bound less the curvature margin
// curvature * D^2 * min(1/4, fraction), is cleared whole; a single square
// that fails leaves the item undetermined. A box is always visible when one
// of a few of its covered cell centres (its nearest-the-middle and its
// corners) passes at z_max. The descent reads at most visible_test_budget
// pyramid cells per point: past that, the point is undetermined.
//
// Heights. A viewpoint h below another sees along lines that are lower all
// the way to the item, so an item hidden from the region's top face is
// hidden from all of it, and one visible from its bottom face is visible
// from all of it: the hidden test works from z_max alone, the visible test
// from z_min alone.
//
// Pieces. Both bounds weaken with the footprint's size (the hidden test
// bounds the distances to the walls and to the item apart; heights above
// ground take the footprint's lowest and highest ground). So the region is
// cut into footprint_splits x footprint_splits rectangles, each classified
// on its own (above-ground heights against its own ground); an item is
// always hidden (visible) when it is so from every piece, since every
// viewpoint lies in one. Later pieces skip the items an earlier one left
// undetermined.
//
// Cost. classify_cells: four wall sweeps, each O(walls * (lateral nodes +
// face_resolution)), then one bounded descent per cell not yet hidden, per
// piece; classify_boxes the same with boxes for cells. plan_region_cells()
// and plan_region_boxes() state both bounds before any work. Cancel and deadline are polled between walls and between
// rows of cells.
//
// Limits: the region must lie inside the DEM's outer extent. With heights
// above ground the viewpoints are those z_min..z_max above the ground at
// their own position; each piece becomes the absolute box from its lowest
// ground + z_min to its highest + z_max, which holds every such viewpoint
// over it, so its verdicts hold for them (a piece over voids alone takes the
// whole region's bounds). Over a daemon's dataset, region_plan.hpp reads only
// the window a query needs.
#pragma once

#include <cstdint>
#include <limits>
#include <span>
#include <string_view>
#include <vector>

#include "horizon/common/control.hpp"
#include "horizon/common/error.hpp"
#include "horizon/geodesy/observer.hpp"
#include "horizon/terrain/dem.hpp"
#include "horizon/terrain/grid.hpp"
#include "horizon/visibility/cull.hpp"
#include "horizon/visibility/options.hpp"

namespace horizon::region {

// The region of possible viewpoints: an axis-aligned box.
struct RegionSpec {
  geodesy::PointFrame frame = geodesy::PointFrame::kDatasetCrs;  // of the rectangle
  // Dataset CRS x/y (or longitude/latitude degrees for kWgs84: the bounding
  // rectangle of its corners and edge midpoints in the dataset CRS).
  double x_min = 0.0, y_min = 0.0, x_max = 0.0, y_max = 0.0;
  double z_min = 0.0, z_max = 0.0;  // metres, z_min <= z_max
  geodesy::HeightMode height_mode = geodesy::HeightMode::kAboveGround;
};

// The region a box of half-size (half_x, half_y) and heights [z_min, z_max]
// sweeps while its centre moves from (x0, y0) to (x1, y1): its bounding box
// (which holds the swept volume, so verdicts for it hold along the path).
RegionSpec swept_region(double x0, double y0, double x1, double y1, double half_x, double half_y, double z_min,
                        double z_max, geodesy::HeightMode height_mode);

// Half-width of each face's span of a = dl/dp (directions within
// atan(2) = 63.4 degrees of the face axis; neighbouring faces overlap).
inline constexpr double kFaceSpan = 2.0;

struct RegionOptions {
  int face_resolution = 1024;  // fuzzy-array columns per face, [8, 65536]
  // The region is answered as footprint_splits^2 pieces, [1, 16] (see
  // "Pieces" above); the cost grows with their number.
  int footprint_splits = 2;
  // GDAL's curvature coefficient (visibility/options.hpp), [0, 2].
  double curvature_coefficient = 0.85714;
  visibility::NodataPolicy nodata = visibility::NodataPolicy::kTransparent;
  double nodata_fill_height = 0.0;
  // classify_cells only: each cell's target is target_height above its
  // centre; cells farther than max_distance (ground metres) from the
  // region's footprint get no answer (and are not computed).
  double target_height = 0.0;
  double max_distance = std::numeric_limits<double>::infinity();
  // Pyramid cells one always-visible test may read, [16, 1 << 24].
  int visible_test_budget = 4096;
  // 0: the continuous cover (above). N in [2, 65536]: the seed's fuzzy
  // array of N slope rows a column, for comparison (see above).
  int fuzzy_rows = 0;
  unsigned threads = 0;  // 0: all hardware threads
};

// Field named when invalid ("face_resolution", ...), kInvalidArgument.
Status validate_region_options(const RegionOptions& options);

enum class Verdict : std::uint8_t {
  kAlwaysHidden = 0,
  kAlwaysVisible = 1,
  kUndetermined = 2,
};
inline constexpr std::uint8_t kNoAnswer = 255;  // raster code: void target, out of range

// "always_hidden", "always_visible", "undetermined".
std::string_view verdict_name(Verdict v);

// The region resolved against a DEM: grid coordinates, absolute heights and
// the metric frame.
struct RegionFrame {
  double col_min = 0.0, col_max = 0.0, row_min = 0.0, row_max = 0.0;  // continuous grid coordinates
  double z_min = 0.0, z_max = 0.0;                                    // absolute metres
  double metres_per_col = 1.0, metres_per_row = 1.0;                  // at the region's centre
  double curvature = 0.0;                                             // metres of drop per metre^2: coefficient / (2 R)
};

// Checks the region (finite, ordered, inside the DEM's outer extent; above
// ground: some valid ground under the footprint) and resolves it. Errors
// name the field: "region.x_max", "region" (outside the DEM), ...
Result<RegionFrame> resolve_region(const terrain::Dem& dem, const RegionSpec& region, const RegionOptions& options);

struct RegionStats {
  double seconds = 0.0;
  std::uint64_t walls_swept = 0;         // grid lines swept over all faces
  std::uint64_t wall_nodes_read = 0;     // DEM nodes those sweeps read
  std::uint64_t pyramid_cells_read = 0;  // by the always-visible tests
  std::uint64_t items = 0, always_hidden = 0, always_visible = 0, undetermined = 0;
};

// What a classification will cost, known before any work.
struct RegionPlan {
  RegionFrame frame;
  terrain::Window window;        // classify_cells: the cells answered
  std::uint64_t sweep_work = 0;  // bound on wall-sweep steps (nodes + columns) over all faces
  std::uint64_t test_work = 0;   // bound on pyramid reads by the visible tests
};

Result<RegionPlan> plan_region_cells(const terrain::Dem& dem, const RegionSpec& region, const RegionOptions& options);
Result<RegionPlan> plan_region_boxes(const terrain::Dem& dem, const RegionSpec& region,
                                     std::span<const visibility::BoxSpec> boxes, const RegionOptions& options);

struct RegionCellsResult {
  terrain::Grid<std::uint8_t> codes;  // plan.window's cells: Verdict values or kNoAnswer
  terrain::Window window;
  RegionFrame frame;
  RegionStats stats;
};

struct RegionBoxesResult {
  std::vector<Verdict> verdicts;  // one per box, same order
  RegionFrame frame;
  RegionStats stats;
};

// Every cell of the plan's window: its target point (centre, ground +
// target_height) classified. Void targets get kNoAnswer.
Result<RegionCellsResult> classify_cells(const terrain::Dem& dem, const RegionSpec& region,
                                         const RegionOptions& options, const RunControl* control = nullptr);

// Object boxes (visibility::BoxSpec, resolved as cull_boxes resolves them).
Result<RegionBoxesResult> classify_boxes(const terrain::Dem& dem, const RegionSpec& region,
                                         std::span<const visibility::BoxSpec> boxes, const RegionOptions& options,
                                         const RunControl* control = nullptr);

}  // namespace horizon::region
