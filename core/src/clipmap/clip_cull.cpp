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

}  // namespace

// The CPU trace: ring by ring across a block of neighbouring columns (one
// block a task), each column carrying its running maximum.
Status detail::trace_cpu(const detail::TracePlan& plan, const ClipmapReader& view, const ClipEye& eye,
                 const ClipCullOptions& options, const RunControl* control, ClipCullScratch& w) {
  const int rays = plan.rays;
  const double dtheta = plan.g.dtheta;
  const double tangent = 1.0 / std::cos(dtheta / 2);
  const auto& rings = plan.rings;
  struct Column : detail::ColumnRays {
    double horizon;
  };
  auto trace_block = [&](std::size_t first, std::size_t last) {
    Column cols[kBlockColumns];
    double block_reach = 0.0;
    for (std::size_t a = first; a < last; ++a) {
      cols[a - first] = {detail::column_rays(a, dtheta, eye), kNegInf};
      detail::horizon_at(w, rays, a, 0) = kNegInf;
      block_reach = std::max(block_reach, w.reach[a]);
    }
    SampleStats& stats = w.stats[first];
    for (std::size_t j = 0; j < rings.size() && rings[j].near < block_reach; ++j) {
      const detail::Ring& ring = rings[j];
      if (options.mode == ClipMode::kFast) {
        // The block's columns still going, sampled together.
        std::size_t active[kBlockColumns], count = 0;
        double xs[kBlockColumns], ys[kBlockColumns];
        float z[kBlockColumns], z1[kBlockColumns];
        for (std::size_t a = first; a < last; ++a) {
          if (!(ring.near < w.reach[a])) continue;
          const Column& c = cols[a - first];
          xs[count] = eye.col + ring.mid * c.cx0;
          ys[count] = eye.row + ring.mid * c.cy0;
          active[count++] = a;
        }
        view.sample_many(ring.k, count, xs, ys, z, stats);
        if (ring.blend > 0.0f) {
          view.sample_many(ring.k + 1, count, xs, ys, z1, stats);
          for (std::size_t i = 0; i < count; ++i) z[i] += ring.blend * (z1[i] - z[i]);
        }
        for (std::size_t i = 0; i < count; ++i) {
          const std::size_t a = active[i];
          Column& c = cols[a - first];
          if (z[i] == z[i]) c.horizon = std::max(c.horizon, (z[i] - ring.mid_drop - eye.elevation) * ring.inv_mid);
          detail::horizon_at(w, rays, a, j + 1) = c.horizon;
          w.traced[a] = static_cast<std::uint32_t>(j + 1);
        }
        continue;
      }
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
        detail::horizon_at(w, rays, a, j + 1) = c.horizon;
        w.traced[a] = static_cast<std::uint32_t>(j + 1);
      }
    }
  };
  const std::size_t blocks = (static_cast<std::size_t>(rays) + kBlockColumns - 1) / kBlockColumns;
  return parallel_for(blocks, options.threads, control, [&](std::size_t b) {
    trace_block(b * kBlockColumns, std::min(static_cast<std::size_t>(rays), (b + 1) * kBlockColumns));
  });
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
  detail::prepare_horizons(plan, w);
  ClipCullResult result;
  HORIZON_RETURN_IF_ERROR(detail::trace(plan, view, eye, options, control, gpu, w, result.stats));
  HORIZON_RETURN_IF_ERROR(detail::test_boxes(plan, eye, footprints, options, control, w, result));
  result.stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace horizon::clipmap
