#include "horizon/clipmap/clip_cull.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>

#include "horizon/common/parallel.hpp"
#include "horizon/visibility/viewshed.hpp"

namespace horizon::clipmap {
namespace {

constexpr double kNegInf = -std::numeric_limits<double>::infinity();
constexpr double kTwoPi = 2.0 * std::numbers::pi;
constexpr std::size_t kBlockColumns = 32;  // neighbouring columns traced together, ring by ring

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

Geometry geometry_of(double cell, int rays, const ClipmapShape& shape) {
  // A level's origin is snapped to its sub-tile grid: its window reaches
  // n/2 - t cells from the clip centre at least.
  return {cell, kTwoPi / rays, shape.levels, cell * (shape.level_size / 2 - shape.subtile)};
}

using BoxSpan = ClipCullScratch::BoxSpan;

BoxSpan span_of(const visibility::BoxFootprint& box, const ClipEye& eye, const Geometry& g, ClipMode mode) {
  BoxSpan s;
  const double c0 = box.cells.col0, c1 = box.cells.col1 - 1, r0 = box.cells.row0, r1 = box.cells.row1 - 1;
  if (eye.col >= c0 && eye.col <= c1 && eye.row >= r0 && eye.row <= r1) {
    s.eye_inside = true;
    return s;
  }
  auto mx = [&](double c) { return (c - eye.col) * eye.metres_per_col; };
  auto my = [&](double r) { return (r - eye.row) * eye.metres_per_row; };
  const double nx = mx(std::clamp(eye.col, c0, c1)), ny = my(std::clamp(eye.row, r0, r1));
  s.near = std::hypot(nx, ny);
  const double centre = std::atan2(my((r0 + r1) / 2), mx((c0 + c1) / 2));
  double lo = 0.0, hi = 0.0;
  for (double c : {c0, c1})
    for (double r : {r0, r1}) {
      s.far = std::max(s.far, std::hypot(mx(c), my(r)));
      double delta = std::atan2(my(r), mx(c)) - centre;
      if (delta > std::numbers::pi) delta -= kTwoPi;
      if (delta < -std::numbers::pi) delta += kTwoPi;
      lo = std::min(lo, delta);
      hi = std::max(hi, delta);
    }
  s.a0 = static_cast<long>(std::floor((centre + lo) / g.dtheta));
  s.a1 = mode == ClipMode::kFast ? static_cast<long>(std::ceil((centre + hi) / g.dtheta))
                                 : static_cast<long>(std::floor((centre + hi) / g.dtheta));
  return s;
}

std::size_t column_of(long a, int rays) { return static_cast<std::size_t>(((a % rays) + rays) % rays); }

// The least of eye + d h + curvature d² over d in [lo, hi].
double least_ohf(double eye, double h, double curvature, double lo, double hi) {
  if (h == kNegInf) return kNegInf;
  auto ohf = [&](double d) { return eye + d * h + curvature * d * d; };
  const double ends = std::min(ohf(lo), ohf(hi));
  return curvature > 0.0 ? std::min(ends, ohf(std::clamp(-h / (2.0 * curvature), lo, hi))) : ends;
}

}  // namespace

Status check_rays(int rays) {
  if (rays < 64 || rays > 65536)
    return make_error(ErrorCode::kInvalidArgument, "rays must be in [64, 65536], got " + std::to_string(rays), "rays");
  return Status::Ok();
}

std::vector<double> ring_edges(double reach, double cell_metres, int rays, const ClipmapShape& shape) {
  const Geometry g = geometry_of(cell_metres, rays, shape);
  std::vector<double> edges{0.5 * cell_metres};
  while (edges.back() < reach) edges.push_back(edges.back() + std::ldexp(cell_metres, g.level_at(edges.back())));
  return edges;
}

Result<ClipCullResult> cull_on_clipmap(const ClipmapReader& view, const ClipEye& eye,
                                       std::span<const visibility::BoxFootprint> footprints,
                                       const ClipCullOptions& options, const RunControl* control,
                                       ClipCullScratch* scratch) {
  const auto start = std::chrono::steady_clock::now();
  const Clipmap& map = view.map();
  if (map.shape().reduction != reduction_for(options.mode))
    return make_error(ErrorCode::kInvalidArgument,
                      options.mode == ClipMode::kConservative ? "conservative culling needs a min clip-map"
                                                              : "fast culling needs a mean clip-map",
                      "mode");
  HORIZON_RETURN_IF_ERROR(check_rays(options.rays));
  if (!std::isfinite(eye.col) || !std::isfinite(eye.row) || !std::isfinite(eye.elevation))
    return make_error(ErrorCode::kInvalidArgument, "eye: position or elevation is not a finite number", "eye");

  const Geometry g = geometry_of(std::min(eye.metres_per_col, eye.metres_per_row), options.rays, map.shape());
  const int rays = options.rays;
  ClipCullResult result;
  result.boxes.resize(footprints.size());

  ClipCullScratch local;
  ClipCullScratch& w = scratch ? *scratch : local;
  // The columns the boxes need, and how far.
  std::vector<BoxSpan>& spans = w.spans;
  spans.resize(footprints.size());
  std::vector<double>& reach = w.reach;
  reach.assign(static_cast<std::size_t>(rays), 0.0);
  double farthest = 0.0;
  for (std::size_t i = 0; i < footprints.size(); ++i) {
    spans[i] = span_of(footprints[i], eye, g, options.mode);
    const BoxSpan& s = spans[i];
    if (s.eye_inside) continue;
    const long last = std::min(s.a1, s.a0 + rays - 1);
    for (long a = s.a0; a <= last; ++a) {
      double& r = reach[column_of(a, rays)];
      r = std::max(r, s.far);
    }
    farthest = std::max(farthest, s.far);
  }
  const std::vector<double> edges = ring_edges(farthest, g.cell, rays, map.shape());
  // The box tests this will take, bounded before any tracing.
  std::uint64_t planned = 0;
  for (const BoxSpan& s : spans) {
    if (s.eye_inside) continue;
    const auto first = std::upper_bound(edges.begin(), edges.end(), s.near);
    const auto last = std::lower_bound(edges.begin(), edges.end(), s.far);
    const std::uint64_t ring_count = static_cast<std::uint64_t>(std::max<std::ptrdiff_t>(last - first + 1, 1));
    const std::uint64_t column_count = static_cast<std::uint64_t>(std::min<long>(s.a1 - s.a0 + 1, rays));
    planned += ring_count * column_count;
  }
  if (planned > options.max_box_tests)
    return make_error(ErrorCode::kResourceExhausted,
                      "the boxes would need " + std::to_string(planned) + " box tests from this eye (at most " +
                          std::to_string(options.max_box_tests) +
                          "): some footprints span too many rays and rings; register smaller boxes or use fewer rays",
                      "boxes");

  // horizon_at(a, j): the horizon slope of column a over the rings before
  // ring j, for j up to traced[a] (0: column a not traced).
  const std::size_t stride = edges.size();
  if (w.horizons.size() < static_cast<std::size_t>(rays) * stride) w.horizons.resize(static_cast<std::size_t>(rays) * stride);
  w.traced.assign(static_cast<std::size_t>(rays), 0);
  w.stats.assign(static_cast<std::size_t>(rays), SampleStats{});
  // Stored ring by ring (the trace writes a ring's columns side by side).
  const std::size_t columns = static_cast<std::size_t>(rays);
  auto horizon_at = [&](std::size_t a, std::size_t j) -> double& { return w.horizons[j * columns + a]; };
  std::vector<SampleStats>& column_stats = w.stats;
  const double tangent = 1.0 / std::cos(g.dtheta / 2);
  // Per ring, shared by every ray: its middle, level and blend, and the
  // drop of curvature at its middle and far edge.
  struct Ring {
    double mid, near, far, mid_drop, far_drop;
    int k, lowest_level;
    float blend;  // weight of level k + 1
  };
  std::vector<Ring> rings(edges.size() > 0 ? edges.size() - 1 : 0);
  for (std::size_t j = 0; j < rings.size(); ++j) {
    Ring& r = rings[j];
    r.near = edges[j];
    r.far = edges[j + 1];
    r.mid = 0.5 * (r.near + r.far);
    const double lambda = g.lod(r.mid);
    r.k = static_cast<int>(lambda);
    r.blend = r.k + 1 < g.levels ? static_cast<float>(lambda - r.k) : 0.0f;
    r.lowest_level = g.level_at(r.near);
    r.mid_drop = eye.curvature * r.mid * r.mid;
    r.far_drop = eye.curvature * r.far * r.far;
  }
  // The trace runs ring by ring across a block of neighbouring columns (one
  // block a task), each column carrying its running maximum.
  struct Column {
    double cx0, cy0, cx1, cy1, cxm, cym;  // grid steps per metre along its rays (and mid-angle)
    double horizon;
  };
  auto trace_block = [&](std::size_t first, std::size_t last) {
    Column cols[kBlockColumns];
    double block_reach = 0.0;
    for (std::size_t a = first; a < last; ++a) {
      Column& c = cols[a - first];
      const double t0 = static_cast<double>(a) * g.dtheta, t1 = t0 + g.dtheta, tm = t0 + g.dtheta / 2;
      c = {std::cos(t0) / eye.metres_per_col, std::sin(t0) / eye.metres_per_row, std::cos(t1) / eye.metres_per_col,
           std::sin(t1) / eye.metres_per_row, std::cos(tm) / eye.metres_per_col, std::sin(tm) / eye.metres_per_row, kNegInf};
      horizon_at(a, 0) = kNegInf;
      block_reach = std::max(block_reach, reach[a]);
    }
    for (std::size_t j = 0; j < rings.size() && rings[j].near < block_reach; ++j) {
      const Ring& ring = rings[j];
      for (std::size_t a = first; a < last; ++a) {
        if (!(ring.near < reach[a])) continue;
        Column& c = cols[a - first];
        SampleStats& stats = column_stats[a];
        double slope = kNegInf;
        if (options.mode == ClipMode::kFast) {
          const double col = eye.col + ring.mid * c.cx0, row = eye.row + ring.mid * c.cy0;
          float z = view.sample(ring.k, col, row, stats);
          if (ring.blend > 0.0f) z += ring.blend * (view.sample(ring.k + 1, col, row, stats) - z);
          if (z == z) slope = (z - ring.mid_drop - eye.elevation) / ring.mid;
        } else {
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
        horizon_at(a, j + 1) = c.horizon;
        w.traced[a] = static_cast<std::uint32_t>(j + 1);
      }
    }
  };
  const std::size_t blocks = (static_cast<std::size_t>(rays) + kBlockColumns - 1) / kBlockColumns;
  HORIZON_RETURN_IF_ERROR(parallel_for(blocks, options.threads, control, [&](std::size_t b) {
    trace_block(b * kBlockColumns, std::min(static_cast<std::size_t>(rays), (b + 1) * kBlockColumns));
  }));

  // Each box against its columns' horizons.
  std::vector<std::uint64_t>& tests = w.tests;
  tests.assign(footprints.size(), 0);
  auto test = [&](std::size_t i) {
    const BoxSpan& s = spans[i];
    visibility::BoxVisibility& out = result.boxes[i];
    double least = kNegInf;
    if (!s.eye_inside && s.near >= edges.front()) {
      least = std::numeric_limits<double>::infinity();
      const long last = std::min(s.a1, s.a0 + rays - 1);
      const std::size_t first_ring =
          static_cast<std::size_t>(std::upper_bound(edges.begin(), edges.end(), s.near) - edges.begin()) - 1;
      for (long a = s.a0; a <= last && least > kNegInf; ++a) {
        const std::size_t column = column_of(a, rays);
        const std::size_t traced = w.traced[column];
        for (std::size_t j = first_ring; j <= traced && j + 1 < edges.size() && edges[j] < s.far; ++j) {
          ++tests[i];
          const double lo = std::max(s.near, edges[j]), hi = std::min(s.far, edges[j + 1]);
          least = std::min(least, least_ohf(eye.elevation, horizon_at(column, j), eye.curvature, lo, hi));
        }
      }
    }
    out.ohf_min = static_cast<float>(least);
    out.state = footprints[i].z_max + visibility::kTieTolerance >= least ? visibility::Visibility::kSeen
                                                                          : visibility::Visibility::kOccluded;
  };
  const std::size_t box_chunk = 256;
  HORIZON_RETURN_IF_ERROR(parallel_for((footprints.size() + box_chunk - 1) / box_chunk, options.threads, control,
                                       [&](std::size_t c) {
                                         for (std::size_t i = c * box_chunk;
                                              i < std::min(footprints.size(), (c + 1) * box_chunk); ++i)
                                           test(i);
                                       }));

  for (const auto& b : result.boxes) result.visible_count += b.state == visibility::Visibility::kSeen;
  for (std::size_t a = 0; a < w.traced.size(); ++a) {
    if (reach[a] <= 0.0) continue;
    ++result.stats.rays_traced;
    result.stats.rings += w.traced[a];
    result.stats.samples += column_stats[a].samples;
    result.stats.fallbacks += column_stats[a].fallbacks;
  }
  for (std::uint64_t t : tests) result.stats.box_tests += t;
  result.stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace horizon::clipmap
