// horizon/trace/trace.hpp — what a camera sees, per pixel: silhouette-
// partitioning ray tracing of a height field, with no preprocessing.
//
// After T. Sakalauskas, "Silhouette Partitioning for Height Field Ray
// Tracing" (Vilnius University). Every frame, from nothing but the cells:
//
//  1. The silhouette map. Each screen column is a vertical half-plane
//     through the eye (camera.hpp); its ray crosses the DEM's row lines one
//     after another, front to back. For every column and every row line
//     ahead of the eye the map holds the crossing's slope: the terrain's
//     height there (linear between the two cells the crossing falls
//     between, as R3 samples it), seen from the eye, curvature-lowered, per
//     ground metre. The paper finds each crossing by a binary search over
//     the row's projection; here the column's azimuth gives it directly
//     (frustum.hpp), and the two cells around it are the map's only reads.
//  2. The silhouette partitioning tree. Rows are the leaves of a binary
//     tree of nested row ranges; a range's silhouette is the pointwise
//     maximum of its rows' (the paper's Eq. 3-4). Packed two levels per
//     RGBA texel as the paper packs them: a texel of pair level p covers four
//     consecutive ranges q0..q3 of level p - 1 (q0 nearest) and holds
//       R = max(q0), G = max(q2), B = max(q0, q1), A = max(q0..q3).
//  3. The trace. A pixel whose ray climbs s per ground metre hits the first
//     row whose slope reaches s (the paper's Eq. 1 and 2, stated here in one
//     direction: y grows up, the combine is max). From the root texel: when
//     s <= B the hit is in the nearer half, then q0 if s <= R else q1;
//     otherwise q2 if s <= G else q3. One texel read resolves two levels,
//     so a pixel reads ceil(log2(rows) / 2) texels and two map entries (the
//     hit row and the one before it), whatever the terrain: the cost per
//     frame is fixed, and the terrain may change between frames with
//     nothing to rebuild. s above the root's A is sky.
//     The paper's pseudo-code says this with screen y growing downward in
//     its Trace branch ("sil_y < x", read "< y") and upward in its Eq. 2-4
//     (max = higher); here y grows up and everything is a slope: a line
//     whose slope reaches the ray's stops it, ranges combine by max, and
//     the nearer half is taken whenever its maximum reaches the ray.
//  4. The hit: the ray meets the chord between the crossing before the hit
//     and the hit crossing, perspective-correct (the paper blends in screen
//     space); the pixel gets that point's ground distance.
//
// Where it can err. The paper tests row crossings only: a ridge that only a
// column line's crossing would catch can be missed, and the pixel then sees
// farther (never nearer) than R3 along its plane. column_crossings adds the
// exact extension: a second silhouette map and tree over the column lines
// the ray crosses, the nearer hit winning; a pixel then meets exactly R3's
// crossings along its vertical plane. Between columns nothing is sampled: a
// peak narrower than a pixel column can be missed by both modes.
//
// Sub-frusta. The row family must be the one the ray crosses most squarely,
// so columns looking within 45 degrees of east or west use column lines as
// their "rows" (the grid transposed), and the screen is cut where the
// azimuth crosses a diagonal: up to three sub-frusta for a pinhole, five
// for a 360 degree panorama. Lines behind the eye are never visited; the
// eye may stand anywhere inside the DEM.
//
// Defined answers. Sky: no crossing within [near, max_distance] reaches
// the ray (distance +inf, line -1). Voids are transparent (they never stop
// a ray; nodata kFill makes them terrain at the fill height). A ray leaving
// the DEM's side or far edge without a hit is sky. Crossings nearer than
// the near plane (or farther than max_distance, in ground metres) are not
// terrain.
//
// Cost: per sub-frustum of X columns and V rows, X * V map entries (two
// cell reads each), X * V / 3 tree texels, and per pixel
// ceil(log2(V) / 2) + 2 reads; twice that with column_crossings. Memory per
// worker thread: 32 columns' map and tree, ~ 32 * V * 10 bytes. The CPU
// form runs blocks of 32 columns in parallel, 16 or 8 columns at a time in
// AVX-512 or AVX2 registers, with a scalar twin giving the same bits.
#pragma once

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "horizon/common/control.hpp"
#include "horizon/common/error.hpp"
#include "horizon/gpu/context_pool.hpp"
#include "horizon/terrain/height_view.hpp"
#include "horizon/trace/camera.hpp"
#include "horizon/visibility/options.hpp"

namespace horizon::trace {

struct TraceOptions {
  // Ground metres in front of the eye within which nothing is terrain (the
  // pinhole's near plane: a forward distance, so ground metres / cos of the
  // column's angle off the view axis). >= 0; 0 still skips the line through
  // the eye itself.
  double near = 1.0;
  // Ground metres beyond which nothing is terrain; +inf: the DEM's edges.
  double max_distance = std::numeric_limits<double>::infinity();
  double curvature_coefficient = 0.85714;  // as visibility::ViewshedOptions
  visibility::NodataPolicy nodata = visibility::NodataPolicy::kTransparent;
  double nodata_fill_height = 0.0;
  // The exact extension: column-line crossings too (second tree, nearer hit
  // wins). Off: the paper's rows only.
  bool column_crossings = false;
  unsigned threads = 0;  // 0 = every core
};

// "max_distance", "near", ... named as the field. Checks ranges and finiteness.
Status validate_trace_options(const TraceOptions& options);

// Which family of grid lines a hit crossing lies on.
enum class LineAxis : std::uint8_t {
  kRows = 0,     // a row line (constant row)
  kColumns = 1,  // a column line (constant column)
};

// Per pixel, row-major from the top-left (index j * width + x).
struct TraceImage {
  int width = 0, height = 0;
  // Ground metres from the eye to the hit; +inf for sky.
  std::vector<float> distance;
  // The grid line of the hit crossing (a row or column number of the view
  // traced), -1 for sky, and its family.
  std::vector<std::int32_t> line;
  std::vector<LineAxis> axis;
};

// Work done, per frame.
struct TraceStats {
  int sub_frusta = 0;
  std::uint64_t pixels = 0;
  std::uint64_t sky_pixels = 0;
  std::uint64_t crossings = 0;    // silhouette-map entries computed (each two cell reads)
  std::uint64_t tree_texels = 0;  // RGBA texels built
  int max_lines = 0;              // rows of the largest sub-frustum's map (primary family)
  int reads_per_pixel = 0;        // texel and map reads per pixel in that sub-frustum
  double seconds = 0.0;
  std::string backend = "cpu";  // "cpu", or "gpu" when a GL context traced it
  std::string gpu_fallback;     // why a trace asked of the GPU ran on the CPU; empty otherwise
};

// One pixel's hit in world terms.
struct Hit {
  bool sky = true;
  double distance = std::numeric_limits<double>::infinity();  // ground metres
  double range = std::numeric_limits<double>::infinity();     // metres along the ray, eye to hit
  double col = 0.0, row = 0.0;  // continuous grid coordinates of the hit (the view's grid)
  double elevation = 0.0;       // metres, absolute (the curvature lowering undone)
};

struct TraceResult {
  TraceImage image;
  TraceStats stats;
  Camera camera;           // as traced (its eye in the view's grid)
  double curvature = 0.0;  // metres of drop per square metre, as traced

  // The hit of pixel (x, j) in world terms, from its distance and ray.
  Hit hit(int x, int j) const;
};

// Traces one frame of `camera` over `view` (whose grid the camera's eye is
// in; at least 2 x 2 cells). Polls `control` between blocks. With `gpu` (a
// borrowed context) the map, tree and trace run as the paper's GL passes
// (trace_gl.cpp): DEM lines drawn as line strips into the silhouette map,
// a fragment pass a pair level, one full-screen trace pass. The GL form
// does the pinhole and rows; a cylindrical camera, column crossings, a
// frame beyond the device's textures or a GL failure are traced on the CPU,
// with stats.gpu_fallback saying why. The shaders repeat the CPU's float
// operations in its order (`precise`): on Mesa's llvmpipe every pixel is
// the CPU's, bit for bit; a device whose arithmetic differs (a division by
// reciprocal) may stop a grazing ray one line apart (tests/gpu/
// test_gpu_trace.cpp states the tolerance: 99 % of pixels on the same
// line, those within 1e-3 of the CPU's distance).
Result<TraceResult> trace_frame(const terrain::HeightView& view, const Camera& camera, const TraceOptions& options,
                                const RunControl* control = nullptr, gpu::Lease* gpu = nullptr);
// The same into `result`, whose image storage is reused when it is large
// enough: a caller tracing frame after frame (a camera path, a simulator)
// then pays no allocation or page fault per frame. On an error `result`
// holds nothing of use.
Status trace_frame(const terrain::HeightView& view, const Camera& camera, const TraceOptions& options,
                   TraceResult& result, const RunControl* control = nullptr, gpu::Lease* gpu = nullptr);

// The reference the tests and benchmarks hold the trace to: every pixel's
// ray walked through every crossing in order of distance (rows only, or
// rows and columns with column_crossings), with the same per-crossing
// arithmetic, no tree. O(pixels x lines); for checks, not for serving.
TraceImage trace_reference(const terrain::HeightView& view, const Camera& camera, const TraceOptions& options);

}  // namespace horizon::trace
