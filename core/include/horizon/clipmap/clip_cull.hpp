// horizon/clipmap/clip_cull.hpp — culling object boxes against a horizon
// traced over a clip-map, with the level chosen by distance.
//
//   clipmap::ClipmapReader view(*map);                  // one snapshot
//   auto culled = clipmap::cull_on_clipmap(view, eye, footprints, {.mode = clipmap::ClipMode::kConservative});
//
// Trace. From the eye, `rays` azimuths θ_a = 2π a / rays (Δθ = 2π / rays,
// metric x east, y south as grid rows run) are marched in rings: ring j spans
// ground distances [b_j, b_j+1) with b_0 = half a cell and width 2^k cells,
// k = floor(λ(b_j)), where
//   λ(d) = max(log2 ρ, ceil(log2(d / r0))),  ρ = max(d Δθ / cell, 1),
// clamped to the clip-map's levels: log2 ρ is the distance analogue of the
// patent's log2 of the screen-space derivative (neighbouring rays are ρ
// cells apart at d), and r0 = (n/2 - t) cells is how far level 0's window
// surely reaches from the clip centre (level k's: 2^k r0), so a ring never
// asks a level for terrain beyond its window. A level's rings sample it at
// its own resolution, and the work per ray grows with the log of the reach,
// not the reach. Samples fall back to a coarser level (and are counted) only
// where a level lags behind the eye or is not loaded.
//
// Modes.
//   kFast: along ray a, ring j samples the mean clip-map at its middle,
//   blending the two bounding levels by the fractional part of λ
//   (continuous LOD); horizon_a(j) is the running maximum of the slopes of
//   the rings before j. A box is tested against the rays bracketing it.
//   kConservative (a min clip-map, Reduction::kMin): wedge a is the sector
//   [θ_a, θ_a+1]; ring j of it takes the least min-level cell meeting the
//   wedge's piece of the ring grown by a cell (ClipmapReader::lowest), which
//   no terrain R3 interpolates there is below, and turns it into the least
//   slope any sight line could have there (divided by the ring's near or far
//   edge, with the far edge's curvature). A box is tested against every wedge
//   it meets. The horizon can only be lower than R3's, so a box reported
//   hidden is hidden for R3 on the full-resolution terrain, whatever levels
//   were resident (fallbacks read coarser min cells, still bounds).
//
// Rule (as cull.hpp): a box is visible when z_max + kTieTolerance reaches
// the least OHF over its footprint's cell-centre hull. For each ray or wedge
// the box meets and each ring its distance range meets, the OHF there is
// eye + d·horizon + curvature·d² (convex in d), minimised over the part of
// the ring inside the box's range. A hull that holds the eye is visible. A
// footprint off the map (BoxFootprint::on_map false, resolved with
// visibility::OffMap::kAnswer) is answered kOutOfRange and costs nothing.
//
// Work: only the rays or wedges some box meets are traced, each only as far
// as the farthest box on it; the stats say how many rings and samples that
// took, and how many samples fell back to a coarser level than asked.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "horizon/clipmap/clipmap.hpp"
#include "horizon/common/control.hpp"
#include "horizon/gpu/context_pool.hpp"
#include "horizon/visibility/cull.hpp"

namespace horizon::clipmap {

// kExact is a session mode only (session.hpp): its answers come from R3 on
// the full-resolution source, not from a clip-map; cull_on_clipmap refuses it.
enum class ClipMode { kFast, kConservative, kExact };

// "fast", "conservative", "exact".
constexpr const char* mode_name(ClipMode mode) {
  return mode == ClipMode::kFast ? "fast" : mode == ClipMode::kConservative ? "conservative" : "exact";
}

// The levels a mode reads: mean for fast, min for conservative (and exact,
// whose session keeps no clip-map but checks voids on the min pyramid).
constexpr terrain::Reduction reduction_for(ClipMode mode) {
  return mode == ClipMode::kFast ? terrain::Reduction::kMean : terrain::Reduction::kMin;
}

// Ok, or kInvalidArgument "rays" outside [64, 65536].
Status check_rays(int rays);

// The eye in the clip-map's source grid.
struct ClipEye {
  double col = 0.0, row = 0.0;  // source grid coordinates
  double elevation = 0.0;       // absolute metres
  double metres_per_col = 1.0, metres_per_row = 1.0;
  double curvature = 0.0;  // metres of drop per metre² (visibility::ViewFrame::curvature)
};

struct ClipCullOptions {
  ClipMode mode = ClipMode::kFast;
  int rays = 1024;       // azimuths around the eye, in [64, 65536]
  unsigned threads = 1;  // 0: all cores
  // The most (ray or wedge, ring) pairs the boxes may need tested: a call
  // whose boxes would need more is refused before any tracing
  // (kResourceExhausted "boxes"). A box costs the rays it spans times the
  // rings its distance range meets, so a few boxes as large as the dataset
  // can cost more than every small box of a scene.
  std::uint64_t max_box_tests = std::uint64_t{1} << 28;
};

struct ClipCullStats {
  std::uint64_t rays_traced = 0;     // rays (fast) or wedges (conservative) some box needed
  std::uint64_t rings = 0;           // ring steps over all of them
  std::uint64_t samples = 0;         // clip-map reads (bilinear samples or lowest() calls)
  std::uint64_t fallbacks = 0;       // of which read a coarser level than asked
  std::uint64_t box_tests = 0;       // (ray or wedge, ring) pairs tested against boxes
  bool gpu = false;                  // traced on a GL context
  std::uint64_t bytes_uploaded = 0;  // GL: level bytes copied to the context (only levels changed since its last trace)
  double seconds = 0.0;
};

struct ClipCullResult {
  std::vector<visibility::BoxVisibility> boxes;  // one per footprint, same order
  std::size_t visible_count = 0;                 // boxes that may be seen (visibility::may_be_seen: not kOccluded)
  ClipCullStats stats;
};

// Buffers a caller keeps between calls (a session keeps one), so that a
// call 60 times a second allocates nothing once warm. Their contents are
// the call's working data, of no use after it.
struct ClipCullScratch {
  struct BoxSpan {
    long a0 = 0, a1 = -1;          // the box's columns (rays or wedges), unwrapped
    double near = 0.0, far = 0.0;  // its ground distance range, metres
    std::uint32_t first_ring = 0;  // the ring holding `near`
    bool eye_inside = false;       // its hull holds the eye
    bool off_map = false;          // not on the dataset: answered out of range, never traced
  };
  std::vector<BoxSpan> spans;
  std::vector<double> reach;          // per column: the farthest box on it
  std::vector<double> horizons;       // per column, its horizons ring by ring
  std::vector<std::uint32_t> traced;  // per column: rings traced
  std::vector<SampleStats> stats;
  std::vector<std::uint64_t> tests;
  // The CPU's fused trace and tests: each box's columns cut at the trace's
  // block boundaries, grouped by block, with each piece's least OHF.
  struct BoxPiece {
    std::uint32_t box, col0, col1;  // columns col0..col1 of one block
  };
  std::vector<BoxPiece> pieces;
  std::vector<std::uint32_t> block_first, block_fill;  // block b's pieces: [block_first[b], block_first[b + 1])
  std::vector<double> piece_least, least;
  std::vector<std::uint64_t> piece_tests;
};

// Ring j's inner edge in metres for a reach of `reach` metres: the ring
// edges the trace uses (the last is >= reach). Exposed for tests and plans.
std::vector<double> ring_edges(double reach, double cell_metres, int rays, const ClipmapShape& shape);

// The checks a cull makes before it plans: a clip-map mode whose reduction
// the clip-map has ("mode"), the rays ("rays"), a finite eye ("eye").
Status check_cull_inputs(const ClipmapReader& view, const ClipEye& eye, const ClipCullOptions& options);

// Culls `footprints` (visibility::resolve_boxes over the clip-map's source)
// from `eye`. kConservative needs a min clip-map and kFast a mean one
// (kInvalidArgument "mode" otherwise). Honours `control` between rays.
// `scratch` (may be null) lends the call its buffers.
//
// GPU. With `gpu` (a context borrowed from gpu::ContextPool, current on
// this thread), the trace runs there: the levels are copied into one R32F
// texture array (layer k = level k, toroidally addressed: level cell (i, j)
// is texel (i mod n, j mod n)) with an R8UI array of sub-tile residency,
// only the levels whose version changed since that context last traced
// this clip-map, and a compute shader marches each column's rings with the
// CPU trace's arithmetic (fallbacks included); the box tests are the CPU's.
// On an IEEE device (Mesa llvmpipe in the tests) the answers are the CPU's
// exactly; a GL failure is an error (kInternal or kResourceExhausted, field
// "gpu") and marks the lease failed, and the caller may run the CPU form.
Result<ClipCullResult> cull_on_clipmap(const ClipmapReader& view, const ClipEye& eye,
                                       std::span<const visibility::BoxFootprint> footprints,
                                       const ClipCullOptions& options, const RunControl* control = nullptr,
                                       ClipCullScratch* scratch = nullptr, gpu::Lease* gpu = nullptr);

}  // namespace horizon::clipmap
