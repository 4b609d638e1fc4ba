#include "horizon/clipmap/clip_cull.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "clip_trace.hpp"
#include "horizon/common/parallel.hpp"

namespace horizon::clipmap {
namespace {

constexpr double kNegInf = -std::numeric_limits<double>::infinity();
constexpr std::size_t kBlockColumns = 32;  // neighbouring columns traced together, ring by ring

// Where a block tracer writes: column a's horizon over the rings before
// ring j goes to out[j * stride + (a - first)].
struct HorizonRows {
  double* out;
  std::size_t stride;
};

// Fast mode over columns [first, last): ring by ring, one blended sample
// per column at the ring's middle. The columns are ordered by reach,
// farthest first, so those still going at a ring are a prefix and each
// ring's loops run over plain arrays.
void trace_fast_block(const detail::TracePlan& plan, const ClipmapReader& view, const ClipEye& eye,
                      std::size_t first, std::size_t last, ClipCullScratch& w, HorizonRows rows) {
  const std::size_t count_all = last - first;
  std::size_t column[kBlockColumns];
  double reach[kBlockColumns], cx[kBlockColumns], cy[kBlockColumns], horizon[kBlockColumns];
  for (std::size_t i = 0; i < count_all; ++i) {
    // Insertion by reach, farthest first (ties keep column order).
    const std::size_t a = first + i;
    std::size_t at = i;
    while (at > 0 && reach[at - 1] < w.reach[a]) {
      column[at] = column[at - 1];
      reach[at] = reach[at - 1];
      --at;
    }
    column[at] = a - first;
    reach[at] = w.reach[a];
    rows.out[i] = kNegInf;
  }
  for (std::size_t i = 0; i < count_all; ++i) {
    const detail::ColumnRays c = detail::column_rays(first + column[i], plan.g.dtheta, eye);
    cx[i] = c.cx0;
    cy[i] = c.cy0;
    horizon[i] = kNegInf;
  }
  SampleStats& stats = w.stats[first];
  const double eye_col = eye.col, eye_row = eye.row, eye_z = eye.elevation;
  double xs[kBlockColumns], ys[kBlockColumns];
  float z[kBlockColumns], z1[kBlockColumns];
  std::size_t count = count_all;
  std::size_t j = 0;
  for (; j < plan.rings.size(); ++j) {
    const detail::Ring& ring = plan.rings[j];
    while (count > 0 && !(ring.near < reach[count - 1])) --count;
    if (count == 0) break;
    const double mid = ring.mid, inv_mid = ring.inv_mid, drop = ring.mid_drop;
    const float blend = ring.blend;
    for (std::size_t i = 0; i < count; ++i) {
      xs[i] = eye_col + mid * cx[i];
      ys[i] = eye_row + mid * cy[i];
    }
    view.sample_many(ring.k, count, xs, ys, z, stats);
    if (blend > 0.0f) {
      view.sample_many(ring.k + 1, count, xs, ys, z1, stats);
      for (std::size_t i = 0; i < count; ++i) z[i] += blend * (z1[i] - z[i]);
    }
    double* row = rows.out + (j + 1) * rows.stride;
    for (std::size_t i = 0; i < count; ++i) {
      if (z[i] == z[i]) horizon[i] = std::max(horizon[i], (z[i] - drop - eye_z) * inv_mid);
      row[column[i]] = horizon[i];
    }
  }
  // Column a went on while ring.near < its reach: over the rings before
  // the first ring at or beyond it.
  for (std::size_t i = 0; i < count_all; ++i)
    w.traced[first + column[i]] = static_cast<std::uint32_t>(std::min(plan.edges_below(reach[i]), j));
}

// Conservative mode over columns [first, last): each wedge's piece of each
// ring bounded below by the min levels.
void trace_conservative_block(const detail::TracePlan& plan, const ClipmapReader& view, const ClipEye& eye,
                              std::size_t first, std::size_t last, ClipCullScratch& w, HorizonRows rows) {
  const double tangent = 1.0 / std::cos(plan.g.dtheta / 2);
  const auto& rings = plan.rings;
  struct Column : detail::ColumnRays {
    double horizon;
  };
  Column cols[kBlockColumns];
  double block_reach = 0.0;
  for (std::size_t a = first; a < last; ++a) {
    cols[a - first] = {detail::column_rays(a, plan.g.dtheta, eye), kNegInf};
    rows.out[a - first] = kNegInf;
    block_reach = std::max(block_reach, w.reach[a]);
  }
  SampleStats& stats = w.stats[first];
  for (std::size_t j = 0; j < rings.size() && rings[j].near < block_reach; ++j) {
    const detail::Ring& ring = rings[j];
    for (std::size_t a = first; a < last; ++a) {
      if (!(ring.near < w.reach[a])) continue;
      Column& c = cols[a - first];
      double slope = kNegInf;
      {
        // The wedge's piece of ring j: the rays' end points and the outer arc's tangent point.
        const double b0 = ring.near, b1 = ring.far;
        const double xs[5] = {b0 * c.cx0, b1 * c.cx0, b0 * c.cx1, b1 * c.cx1, b1 * tangent * c.cxm};
        const double ys[5] = {b0 * c.cy0, b1 * c.cy0, b0 * c.cy1, b1 * c.cy1, b1 * tangent * c.cym};
        const auto [xmin, xmax] = std::minmax_element(xs, xs + 5);
        const auto [ymin, ymax] = std::minmax_element(ys, ys + 5);
        const float low = view.lowest(ring.lowest_level, static_cast<int>(std::floor(eye.col + *xmin)),
                                      static_cast<int>(std::floor(eye.row + *ymin)),
                                      static_cast<int>(std::ceil(eye.col + *xmax)),
                                      static_cast<int>(std::ceil(eye.row + *ymax)), stats);
        if (low > -std::numeric_limits<float>::infinity() && low < std::numeric_limits<float>::infinity()) {
          const double rise = low - ring.far_drop - eye.elevation;
          slope = rise / (rise > 0.0 ? b1 : b0);
        }
      }
      c.horizon = std::max(c.horizon, slope);
      rows.out[(j + 1) * rows.stride + (a - first)] = c.horizon;
      w.traced[a] = static_cast<std::uint32_t>(j + 1);
    }
  }
}

void trace_block(const detail::TracePlan& plan, const ClipmapReader& view, const ClipEye& eye, ClipMode mode,
                 std::size_t first, std::size_t last, ClipCullScratch& w, HorizonRows rows) {
  if (mode == ClipMode::kFast) {
    trace_fast_block(plan, view, eye, first, last, w, rows);
  } else {
    trace_conservative_block(plan, view, eye, first, last, w, rows);
  }
}

std::size_t block_count(int rays) { return (static_cast<std::size_t>(rays) + kBlockColumns - 1) / kBlockColumns; }

// Cuts each tested box's columns at block boundaries (a box's columns on
// one block are contiguous, a box may wrap through column 0) and groups
// the pieces by block: counted, then placed.
// Returns false, placing nothing, when they would be more than
// kPiecesPerBox a box (boxes over many blocks).
bool place_pieces(const detail::TracePlan& plan, ClipCullScratch& w) {
  const std::size_t rays = static_cast<std::size_t>(plan.rays), blocks = block_count(plan.rays);
  auto for_each_piece = [&](auto&& piece) {
    for (std::size_t i = 0; i < w.spans.size(); ++i) {
      const ClipCullScratch::BoxSpan& s = w.spans[i];
      if (!detail::testable(s, plan)) continue;
      const long last = std::min(s.a1, s.a0 + plan.rays - 1);
      for (long a = s.a0; a <= last;) {
        const std::size_t c = detail::column_of(a, plan.rays);
        const std::size_t block_end = std::min((c / kBlockColumns + 1) * kBlockColumns, rays);
        const std::size_t run = std::min(static_cast<std::size_t>(last - a + 1), block_end - c);
        piece(c / kBlockColumns, ClipCullScratch::BoxPiece{static_cast<std::uint32_t>(i),
                                                           static_cast<std::uint32_t>(c),
                                                           static_cast<std::uint32_t>(c + run - 1)});
        a += static_cast<long>(run);
      }
    }
  };
  w.block_first.assign(blocks + 1, 0);
  for_each_piece([&](std::size_t b, const ClipCullScratch::BoxPiece&) { ++w.block_first[b + 1]; });
  for (std::size_t b = 0; b < blocks; ++b) w.block_first[b + 1] += w.block_first[b];
  if (w.block_first[blocks] > detail::kPiecesPerBox * w.spans.size()) return false;
  w.pieces.resize(w.block_first[blocks]);
  w.piece_least.resize(w.pieces.size());
  w.piece_tests.resize(w.pieces.size());
  w.block_fill.assign(w.block_first.begin(), w.block_first.end() - 1);
  for_each_piece([&](std::size_t b, const ClipCullScratch::BoxPiece& p) { w.pieces[w.block_fill[b]++] = p; });
  return true;
}

}  // namespace

// The CPU trace: ring by ring across a block of neighbouring columns (one
// block a task), each column carrying its running maximum.
Status detail::trace_cpu(const detail::TracePlan& plan, const ClipmapReader& view, const ClipEye& eye,
                         const ClipCullOptions& options, const RunControl* control, ClipCullScratch& w) {
  const std::size_t rays = static_cast<std::size_t>(plan.rays);
  return parallel_for(block_count(plan.rays), options.threads, control, [&](std::size_t b) {
    const std::size_t first = b * kBlockColumns;
    trace_block(plan, view, eye, options.mode, first, std::min(rays, first + kBlockColumns), w,
                {&w.horizons[first], rays});
  });
}

// The CPU trace and box tests fused: each block's boxes are tested as soon
// as the block is traced, against horizons the task keeps in a table of its
// own (the block's columns only, still in cache), never the whole
// rings x rays table. The answers are trace_cpu + test_boxes' exactly.
Status detail::trace_and_test_cpu(const detail::TracePlan& plan, const ClipmapReader& view, const ClipEye& eye,
                                  std::span<const visibility::BoxFootprint> footprints,
                                  const ClipCullOptions& options, const RunControl* control, ClipCullScratch& w,
                                  ClipCullResult& result) {
  const std::size_t rays = static_cast<std::size_t>(plan.rays);
  if (!place_pieces(plan, w)) {
    // Boxes over many blocks: the whole table, whose bytes a session reserves.
    detail::prepare_horizons(plan, w);
    HORIZON_RETURN_IF_ERROR(detail::trace_cpu(plan, view, eye, options, control, w));
    return detail::test_boxes(plan, eye, footprints, options, control, w, result);
  }
  w.traced.assign(rays, 0);
  w.stats.assign(rays, SampleStats{});
  HORIZON_RETURN_IF_ERROR(parallel_for(block_count(plan.rays), options.threads, control, [&](std::size_t b) {
    thread_local std::vector<double> table;
    if (table.size() < plan.edges.size() * kBlockColumns) table.resize(plan.edges.size() * kBlockColumns);
    const std::size_t first = b * kBlockColumns;
    trace_block(plan, view, eye, options.mode, first, std::min(rays, first + kBlockColumns), w,
                {table.data(), kBlockColumns});
    for (std::size_t e = w.block_first[b]; e < w.block_first[b + 1]; ++e) {
      const ClipCullScratch::BoxPiece& p = w.pieces[e];
      const ClipCullScratch::BoxSpan& s = w.spans[p.box];
      double least = std::numeric_limits<double>::infinity();
      std::uint64_t tests = 0;
      for (std::size_t c = p.col0; c <= p.col1; ++c)
        least = std::min(least, detail::least_on_column(plan, eye, s, &table[c - first], kBlockColumns,
                                                        w.traced[c], tests));
      w.piece_least[e] = least;
      w.piece_tests[e] = tests;
    }
  }));
  // Each box's least over its pieces; boxes without a test are visible.
  w.least.resize(footprints.size());
  for (std::size_t i = 0; i < footprints.size(); ++i)
    w.least[i] = detail::testable(w.spans[i], plan) ? std::numeric_limits<double>::infinity() : kNegInf;
  std::uint64_t tests = 0;
  for (std::size_t e = 0; e < w.pieces.size(); ++e) {
    double& least = w.least[w.pieces[e].box];
    least = std::min(least, w.piece_least[e]);
    tests += w.piece_tests[e];
  }
  result.boxes.resize(footprints.size());
  for (std::size_t i = 0; i < footprints.size(); ++i) detail::set_answer(result.boxes[i], w.least[i], footprints[i]);
  detail::summarize(w, tests, result);
  return Status::Ok();
}

Status check_cull_inputs(const ClipmapReader& view, const ClipEye& eye, const ClipCullOptions& options) {
  if (options.mode == ClipMode::kExact)
    return make_error(ErrorCode::kInvalidArgument, "exact answers come from the source, not a clip-map", "mode");
  if (view.map().shape().reduction != reduction_for(options.mode))
    return make_error(ErrorCode::kInvalidArgument,
                      options.mode == ClipMode::kConservative ? "conservative culling needs a min clip-map"
                                                              : "fast culling needs a mean clip-map",
                      "mode");
  HORIZON_RETURN_IF_ERROR(check_rays(options.rays));
  if (!std::isfinite(eye.col) || !std::isfinite(eye.row) || !std::isfinite(eye.elevation))
    return make_error(ErrorCode::kInvalidArgument, "eye: position or elevation is not a finite number", "eye");
  return Status::Ok();
}

Result<ClipCullResult> cull_on_clipmap(const ClipmapReader& view, const ClipEye& eye,
                                       std::span<const visibility::BoxFootprint> footprints,
                                       const ClipCullOptions& options, const RunControl* control,
                                       ClipCullScratch* scratch, gpu::Lease* gpu) {
  const auto start = std::chrono::steady_clock::now();
  HORIZON_RETURN_IF_ERROR(check_cull_inputs(view, eye, options));
  ClipCullScratch local;
  ClipCullScratch& w = scratch ? *scratch : local;
  auto planned = detail::plan_trace(eye, footprints, options, view.map().shape(), w);
  if (!planned.ok()) return planned.error();
  const detail::TracePlan& plan = *planned;
  ClipCullResult result;
  if (gpu) {
    detail::prepare_horizons(plan, w);
    HORIZON_RETURN_IF_ERROR(detail::trace(plan, view, eye, options, control, gpu, w, result.stats));
    HORIZON_RETURN_IF_ERROR(detail::test_boxes(plan, eye, footprints, options, control, w, result));
  } else {
    HORIZON_RETURN_IF_ERROR(detail::trace_and_test_cpu(plan, view, eye, footprints, options, control, w, result));
  }
  result.stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace horizon::clipmap
