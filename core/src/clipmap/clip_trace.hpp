// clip_trace.hpp (internal) — the stages of clip_cull.hpp's culling that
// every backend shares: the plan (which columns, how far, the rings and
// their levels), and the box tests against the traced horizons. A backend
// (the CPU trace in clip_cull.cpp, the GL one in clip_trace_gl.cpp) only
// fills ClipCullScratch::horizons and ::traced from the plan; culling on
// the CPU fuses trace and tests block by block (trace_and_test_cpu) and
// never fills the whole table.
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include "horizon/clipmap/clip_cull.hpp"
#include "horizon/gpu/context_pool.hpp"

namespace horizon::clipmap::detail {

struct Geometry {
  double cell;    // metres of the finer cell side
  double dtheta;  // radians between rays
  int levels;
  double reach0;  // metres level 0's window reaches from its clip centre in every direction
  // The fractional level to read at distance d: the one whose samples are as
  // far apart as neighbouring rays there (fractional: fast mode blends the
  // two around it), but never finer than the finest level whose window
  // reaches that far (whole: blending never crosses a level's edge).
  double lod(double d) const {
    const double rays_apart = std::log2(std::max(d * dtheta / cell, 1.0));
    const double window = std::ceil(std::log2(std::max(d / reach0, 1.0)));
    return std::min(std::max(rays_apart, window), static_cast<double>(levels - 1));
  }
  int level_at(double d) const { return static_cast<int>(lod(d)); }
};

Geometry geometry_of(double cell, int rays, const ClipmapShape& shape);

// std::atan2(y, x) to within kAngleError radians (range reduction and a
// series, several times cheaper), for the plan's box columns: 10 000
// boxes a pose, two corners each; where the error could change a column
// the plan asks std::atan2 itself. atan2(±0, x < 0) is +π here.
double angle_of(double y, double x);
constexpr double kAngleError = 1e-9;

// One ring, shared by every ray: its edges and middle, the level it reads
// and the blend towards the next, the curvature drop at its middle and far
// edge.
struct Ring {
  double near, far, mid, inv_mid, mid_drop, far_drop;
  int k;             // fast mode: the level read, and k + 1 blended in
  int lowest_level;  // conservative mode: the level lowest() reads
  float blend;       // weight of level k + 1
};

// What a call traces: columns are rays (fast) or wedges (conservative);
// column a is traced over rings [0, traced) while ring.near < reach[a].
struct TracePlan {
  Geometry g;
  int rays = 0;
  std::vector<double> edges;    // ring edges, metres (ring_edges())
  std::vector<Ring> rings;      // edges.size() - 1 of them
  std::uint64_t box_tests = 0;  // planned (ray or wedge, ring) pairs

  // How many edges are <= d (std::upper_bound's index) and < d
  // (std::lower_bound's), in constant time: a table gives the first edge
  // beyond each bucket of distance and a comparison or two with the edges
  // themselves settles the rest, so the answers are the searches' exactly.
  std::size_t edges_upto(double d) const;
  std::size_t edges_below(double d) const;

  std::vector<std::uint32_t> bucket_first;  // bucket b: the first edge > b * bucket_width
  double inv_bucket_width = 0.0;
};

// Column a's rays in grid steps per metre: the ray at θ_a, the one at
// θ_a+1 (the wedge's other side) and the one between them.
struct ColumnRays {
  double cx0, cy0, cx1, cy1, cxm, cym;
};
inline ColumnRays column_rays(std::size_t a, double dtheta, const ClipEye& eye) {
  const double t0 = static_cast<double>(a) * dtheta, t1 = t0 + dtheta, tm = t0 + dtheta / 2;
  return {std::cos(t0) / eye.metres_per_col, std::sin(t0) / eye.metres_per_row, std::cos(t1) / eye.metres_per_col,
          std::sin(t1) / eye.metres_per_row, std::cos(tm) / eye.metres_per_col, std::sin(tm) / eye.metres_per_row};
}

// Fills scratch.spans and scratch.reach for `footprints` and returns the
// plan, or kResourceExhausted "boxes" when the boxes would need more than
// options.max_box_tests tests: nothing is traced before this says yes.
Result<TracePlan> plan_trace(const ClipEye& eye, std::span<const visibility::BoxFootprint> footprints,
                             const ClipCullOptions& options, const ClipmapShape& shape, ClipCullScratch& scratch);

// The plan of a trace whose every column runs out to `reach` metres (a
// viewshed's): scratch.spans emptied, scratch.reach set.
TracePlan plan_reach(const ClipEye& eye, const ClipCullOptions& options, const ClipmapShape& shape, double reach,
                     ClipCullScratch& scratch);

// The CPU trace of a plan (clip_cull.cpp): fills scratch.horizons, .traced
// and .stats after prepare_horizons().
Status trace_cpu(const TracePlan& plan, const ClipmapReader& view, const ClipEye& eye, const ClipCullOptions& options,
                 const RunControl* control, ClipCullScratch& scratch);

// trace_cpu and test_boxes in one pass over the columns (clip_cull.cpp):
// each block of columns is tested against its boxes while its horizons are
// in cache. Fills what the two fill, except scratch.horizons, with the
// same values. Its buffers: kPiecesPerBox pieces a box at most (a box
// meets one or two blocks of 32 columns unless it is wide; past that it
// runs trace_cpu and test_boxes themselves), and a table of 32 columns'
// horizons per worker thread.
constexpr std::size_t kPiecesPerBox = 2;
Status trace_and_test_cpu(const TracePlan& plan, const ClipmapReader& view, const ClipEye& eye,
                          std::span<const visibility::BoxFootprint> footprints, const ClipCullOptions& options,
                          const RunControl* control, ClipCullScratch& scratch, ClipCullResult& result);

// The GL trace of a plan on `lease`'s context (clip_trace_gl.cpp): fills the
// same buffers with the same values as trace_cpu (the shader repeats its
// arithmetic), after bringing the context's copy of the levels up to the
// view's snapshot; `uploaded` gets the bytes that copy took (0 when no
// level changed since the context last traced this clip-map). A GL failure
// marks the lease failed.
Status trace_gl(const TracePlan& plan, const ClipmapReader& view, const ClipEye& eye, const ClipCullOptions& options,
                const RunControl* control, gpu::Lease& lease, ClipCullScratch& scratch, std::uint64_t& uploaded);

// trace_gl on `gpu` when given, trace_cpu otherwise; stats.gpu and
// .bytes_uploaded say which ran and what it copied.
inline Status trace(const TracePlan& plan, const ClipmapReader& view, const ClipEye& eye,
                    const ClipCullOptions& options, const RunControl* control, gpu::Lease* gpu,
                    ClipCullScratch& scratch, ClipCullStats& stats) {
  stats.gpu = gpu != nullptr;
  if (gpu) return trace_gl(plan, view, eye, options, control, *gpu, scratch, stats.bytes_uploaded);
  return trace_cpu(plan, view, eye, options, control, scratch);
}

// Column a of `rays`, for an unwrapped a.
inline std::size_t column_of(long a, int rays) {
  return static_cast<std::size_t>(((a % rays) + rays) % rays);
}

// The horizon slope of column a over the rings before ring j (j in
// [0, traced[a]]), stored ring by ring.
inline double& horizon_at(ClipCullScratch& w, int rays, std::size_t a, std::size_t j) {
  return w.horizons[j * static_cast<std::size_t>(rays) + a];
}
// Sizes scratch.horizons, .traced and .stats for the plan (traced all 0).
// A backend may count a block's samples on any one column of it: only
// their sum is reported.
void prepare_horizons(const TracePlan& plan, ClipCullScratch& scratch);

// True when span s is tested against horizons; a hull holding the eye, or
// nearer than the first ring, is visible without a test (least OHF -inf),
// and a box off the map is out of range.
inline bool testable(const ClipCullScratch::BoxSpan& s, const TracePlan& plan) {
  return !s.eye_inside && !s.off_map && s.near >= plan.edges.front();
}

// The least OHF over span s's part of one column: `horizons[j * stride]` is
// the column's horizon over the rings before ring j, for j <= traced. Adds
// the (column, ring) pairs tested to `tests`.
double least_on_column(const TracePlan& plan, const ClipEye& eye, const ClipCullScratch::BoxSpan& s,
                       const double* horizons, std::size_t stride, std::size_t traced, std::uint64_t& tests);

// Sets a box's answer from its least OHF (out of range off the map).
inline void set_answer(visibility::BoxVisibility& out, double least, const visibility::BoxFootprint& box) {
  if (!box.on_map) {
    out = {visibility::Visibility::kOutOfRange, -std::numeric_limits<float>::infinity()};
    return;
  }
  out.ohf_min = static_cast<float>(least);
  out.state = box.z_max + visibility::kTieTolerance >= least ? visibility::Visibility::kSeen
                                                             : visibility::Visibility::kOccluded;
}

// Tests every footprint against the horizons, fills result.boxes,
// visible_count and the stats (summarize).
Status test_boxes(const TracePlan& plan, const ClipEye& eye, std::span<const visibility::BoxFootprint> footprints,
                  const ClipCullOptions& options, const RunControl* control, ClipCullScratch& scratch,
                  ClipCullResult& result);

// Fills result.visible_count and the stats' rays, rings, samples and
// fallbacks (from scratch) and box tests (`box_tests`).
void summarize(const ClipCullScratch& scratch, std::uint64_t box_tests, ClipCullResult& result);

}  // namespace horizon::clipmap::detail
