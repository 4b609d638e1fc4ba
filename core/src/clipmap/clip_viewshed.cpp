#include "horizon/clipmap/clip_viewshed.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>

#include "clip_trace.hpp"
#include "horizon/common/parallel.hpp"
#include "horizon/visibility/viewshed.hpp"

namespace horizon::clipmap {
namespace {

constexpr double kNegInf = -std::numeric_limits<double>::infinity();

// Blends two horizons; one that is -inf (nothing traced blocks) yields to the other.
double blend(double h0, double h1, double f) {
  if (h0 == kNegInf) return h1;
  if (h1 == kNegInf) return h0;
  return h0 + (h1 - h0) * f;
}

}  // namespace

Result<terrain::Window> clip_viewshed_window(const Clipmap& map, const ClipEye& eye, double radius) {
  if (!(radius > 0.0) || !std::isfinite(radius))
    return make_error(ErrorCode::kInvalidArgument, "viewshed_radius must be a positive number of metres",
                      "viewshed_radius");
  const double rc = radius / eye.metres_per_col, rr = radius / eye.metres_per_row;
  const double cells = (2.0 * rc + 1.0) * (2.0 * rr + 1.0);
  if (!(cells <= static_cast<double>(ClipViewshed::kMaxCells)))
    return make_error(ErrorCode::kInvalidArgument,
                      "viewshed_radius " + number_text(radius) + " m covers " +
                          std::to_string(static_cast<std::uint64_t>(cells)) + " cells, more than the " +
                          std::to_string(ClipViewshed::kMaxCells) + " a pose's viewshed may",
                      "viewshed_radius");
  terrain::Window w{static_cast<int>(std::max(0.0, std::ceil(eye.col - rc))),
                    static_cast<int>(std::max(0.0, std::ceil(eye.row - rr))),
                    static_cast<int>(std::min<double>(map.source_width(), std::floor(eye.col + rc) + 1)),
                    static_cast<int>(std::min<double>(map.source_height(), std::floor(eye.row + rr) + 1))};
  w.col1 = std::max(w.col1, w.col0);
  w.row1 = std::max(w.row1, w.row0);
  return w;
}

Result<ClipViewshed> viewshed_on_clipmap(const ClipmapReader& view, const ClipEye& eye,
                                         const ClipViewshedOptions& options, const RunControl* control,
                                         ClipCullScratch* scratch, gpu::Lease* gpu) {
  const auto start = std::chrono::steady_clock::now();
  ClipCullOptions cull;
  cull.mode = options.mode;
  cull.rays = options.rays;
  cull.threads = options.threads;
  HORIZON_RETURN_IF_ERROR(check_cull_inputs(view, eye, cull));
  if (!(options.target_height >= 0.0) || !std::isfinite(options.target_height))
    return make_error(ErrorCode::kInvalidArgument, "target_height must be a number of metres >= 0", "target_height");
  auto window = clip_viewshed_window(view.map(), eye, options.radius);
  if (!window.ok()) return window.error();

  ClipCullScratch local;
  ClipCullScratch& w = scratch ? *scratch : local;
  const detail::TracePlan plan = detail::plan_reach(eye, cull, view.map().shape(), options.radius, w);
  detail::prepare_horizons(plan, w);
  ClipViewshed out;
  HORIZON_RETURN_IF_ERROR(detail::trace(plan, view, eye, cull, control, gpu, w, out.stats));

  out.window = *window;
  out.mask = terrain::Grid<std::uint8_t>(window->width(), window->height(), visibility::kNoAnswer);
  const int rays = plan.rays;
  const double dtheta = plan.g.dtheta, radius2 = options.radius * options.radius;
  const auto& edges = plan.edges;
  const bool fast = options.mode == ClipMode::kFast;
  std::vector<std::uint64_t> seen(static_cast<std::size_t>(window->height()), 0), hidden(seen.size(), 0);
  std::vector<SampleStats> target_stats(seen.size());
  HORIZON_RETURN_IF_ERROR(parallel_for(seen.size(), options.threads, control, [&](std::size_t y) {
    const int row = window->row0 + static_cast<int>(y);
    const double dy = (row - eye.row) * eye.metres_per_row;
    for (int col = window->col0; col < window->col1; ++col) {
      const double dx = (col - eye.col) * eye.metres_per_col;
      const double d2 = dx * dx + dy * dy;
      if (d2 > radius2) continue;
      float z;
      if (view.resident(0, col, row)) {
        z = view.cell(0, col, row);
      } else if (fast) {
        z = view.sample(0, col, row, target_stats[y]);
      } else {
        // Conservative: no level-0 value to show it hidden with.
        out.mask.at(col - window->col0, static_cast<int>(y)) = visibility::kVisible;
        ++seen[y];
        continue;
      }
      if (z != z) continue;  // a void
      const double d = std::sqrt(d2);
      std::uint8_t code = visibility::kVisible;
      if (d >= edges.front()) {
        double theta = std::atan2(dy, dx);
        if (theta < 0.0) theta += 2.0 * std::numbers::pi;
        const double at = theta / dtheta;
        const std::size_t a = static_cast<std::size_t>(std::min<double>(std::floor(at), rays - 1));
        // The rings wholly nearer than the cell; fast mode adds the cell's own
        // ring when its sample (the ring's middle) is nearer than the cell.
        std::size_t j = plan.edges_upto(d) - 1;
        if (fast && j < plan.rings.size() && plan.rings[j].mid < d) ++j;
        double h = detail::horizon_at(w, rays, a, std::min<std::size_t>(j, w.traced[a]));
        if (fast) {
          const std::size_t b = (a + 1) % static_cast<std::size_t>(rays);
          h = blend(h, detail::horizon_at(w, rays, b, std::min<std::size_t>(j, w.traced[b])), at - std::floor(at));
        }
        if (h > kNegInf) {
          const double ohf = eye.elevation + d * h + eye.curvature * d2;
          if (z + options.target_height + visibility::kTieTolerance < ohf) code = visibility::kHidden;
        }
      }
      out.mask.at(col - window->col0, static_cast<int>(y)) = code;
      (code == visibility::kVisible ? seen : hidden)[y] += 1;
    }
  }));
  for (std::size_t y = 0; y < seen.size(); ++y) {
    out.visible_cells += seen[y];
    out.hidden_cells += hidden[y];
    w.stats[0].samples += target_stats[y].samples;
    w.stats[0].fallbacks += target_stats[y].fallbacks;
  }
  for (std::size_t a = 0; a < w.traced.size(); ++a) {
    out.stats.samples += w.stats[a].samples;
    out.stats.fallbacks += w.stats[a].fallbacks;
    ++out.stats.rays_traced;
    out.stats.rings += w.traced[a];
  }
  out.stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

}  // namespace horizon::clipmap
