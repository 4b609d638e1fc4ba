#include "clip_trace.hpp"

#include <algorithm>
#include <limits>
#include <numbers>
#include <string>

#include "horizon/common/parallel.hpp"

namespace horizon::clipmap {
namespace detail {
namespace {

constexpr double kNegInf = -std::numeric_limits<double>::infinity();
constexpr double kTwoPi = 2.0 * std::numbers::pi;

using BoxSpan = ClipCullScratch::BoxSpan;

}  // namespace

double angle_of(double y, double x) {
  const double ax = std::fabs(x), ay = std::fabs(y);
  const bool steep = ay > ax;
  const double num = steep ? ax : ay, den = steep ? ay : ax;
  double t = den > 0.0 ? num / den : 0.0, base = 0.0;  // t in [0, 1]
  // atan t = π/6 + atan((√3 t - 1) / (t + √3)), which lies in [-tan π/12, tan π/12]
  // for t in [tan π/12, 1]: there the series to t^13 is within 2e-10 of atan.
  constexpr double kTanPi12 = 0.2679491924311227, kSqrt3 = 1.7320508075688772;
  if (t > kTanPi12) {
    t = (t * kSqrt3 - 1.0) / (t + kSqrt3);
    base = std::numbers::pi / 6;
  }
  const double t2 = t * t;
  double a =
      base +
      t * (1.0 + t2 * (-1.0 / 3 + t2 * (1.0 / 5 + t2 * (-1.0 / 7 + t2 * (1.0 / 9 + t2 * (-1.0 / 11 + t2 / 13))))));
  if (steep) a = std::numbers::pi / 2 - a;
  if (x < 0.0) a = std::numbers::pi - a;
  return y < 0.0 ? -a : a;
}

namespace {

BoxSpan span_of(const visibility::BoxFootprint& box, const ClipEye& eye, const Geometry& g, ClipMode mode) {
  BoxSpan s;
  if (!box.on_map) {
    s.off_map = true;
    return s;
  }
  const double c0 = box.cells.col0, c1 = box.cells.col1 - 1, r0 = box.cells.row0, r1 = box.cells.row1 - 1;
  if (eye.col >= c0 && eye.col <= c1 && eye.row >= r0 && eye.row <= r1) {
    s.eye_inside = true;
    return s;
  }
  const double x0 = (c0 - eye.col) * eye.metres_per_col, x1 = (c1 - eye.col) * eye.metres_per_col;
  const double y0 = (r0 - eye.row) * eye.metres_per_row, y1 = (r1 - eye.row) * eye.metres_per_row;
  const double nx = x0 > 0.0 ? x0 : x1 < 0.0 ? x1 : 0.0, ny = y0 > 0.0 ? y0 : y1 < 0.0 ? y1 : 0.0;
  s.near = std::sqrt(nx * nx + ny * ny);
  const double fx = std::max(x0 * x0, x1 * x1), fy = std::max(y0 * y0, y1 * y1);
  s.far = std::sqrt(fx + fy);
  // The two corners on the rectangle's silhouette from the eye, from which
  // side of the box the eye is on (sx, sy: the box's side of the eye).
  const int sx = x0 > 0.0 ? 1 : x1 < 0.0 ? -1 : 0, sy = y0 > 0.0 ? 1 : y1 < 0.0 ? -1 : 0;
  double ax, ay, bx, by;
  if (sy == 0) {  // level with the box: its near edge
    ax = bx = sx > 0 ? x0 : x1;
    ay = y0, by = y1;
  } else if (sx == 0) {
    ay = by = sy > 0 ? y0 : y1;
    ax = x0, bx = x1;
  } else if (sx == sy) {  // diagonally off a corner: the other diagonal's corners
    ax = x1, ay = y0, bx = x0, by = y1;
  } else {
    ax = x0, ay = y0, bx = x1, by = y1;
  }
  // The silhouette's angles by angle_of, unless an angle lies so near a
  // ray (or the span so near π) that its error could move a column: then
  // by std::atan2, so the columns are always those of the exact angles.
  auto bounds = [&](double ta, double tb, double& lo, double& hi) {
    double span = tb - ta;
    if (span > std::numbers::pi) span -= kTwoPi;
    if (span < -std::numbers::pi) span += kTwoPi;
    lo = span < 0.0 ? ta + span : ta;
    hi = span < 0.0 ? ta : ta + span;
    return std::fabs(std::fabs(span) - std::numbers::pi) > 4 * kAngleError;
  };
  auto clear_of_rays = [&](double t) {
    const double q = t / g.dtheta;
    return std::fabs(q - std::nearbyint(q)) * g.dtheta > 4 * kAngleError;
  };
  double lo, hi;
  if (!bounds(angle_of(ay, ax), angle_of(by, bx), lo, hi) || !clear_of_rays(lo) || !clear_of_rays(hi))
    bounds(std::atan2(ay, ax), std::atan2(by, bx), lo, hi);
  s.a0 = static_cast<long>(std::floor(lo / g.dtheta));
  s.a1 = mode == ClipMode::kFast ? static_cast<long>(std::ceil(hi / g.dtheta))
                                 : static_cast<long>(std::floor(hi / g.dtheta));
  return s;
}

// The least of eye + d h + curvature d² over d in [lo, hi].
double least_ohf(double eye, double h, double curvature, double lo, double hi) {
  if (h == kNegInf) return kNegInf;
  auto ohf = [&](double d) { return eye + d * h + curvature * d * d; };
  const double ends = std::min(ohf(lo), ohf(hi));
  return curvature > 0.0 ? std::min(ends, ohf(std::clamp(-h / (2.0 * curvature), lo, hi))) : ends;
}

}  // namespace

// The ring table and bucket index of plan.edges.
void set_rings(TracePlan& plan, const ClipEye& eye);

namespace {

// The bucket's first edge beyond it, moved until `before(edge, d)` holds
// for exactly the edges ahead of it: the count of edges before d.
template <class Before>
std::size_t count_before(const TracePlan& plan, double d, Before before) {
  const auto& edges = plan.edges;
  std::size_t i = 0;
  if (d >= 0.0) {
    const double b = std::floor(d * plan.inv_bucket_width);
    i = b < static_cast<double>(plan.bucket_first.size()) ? plan.bucket_first[static_cast<std::size_t>(b)]
                                                          : edges.size();
  }
  while (i > 0 && !before(edges[i - 1], d)) --i;
  while (i < edges.size() && before(edges[i], d)) ++i;
  return i;
}

}  // namespace

std::size_t TracePlan::edges_upto(double d) const {
  return count_before(*this, d, [](double e, double x) { return e <= x; });
}
std::size_t TracePlan::edges_below(double d) const {
  return count_before(*this, d, [](double e, double x) { return e < x; });
}

Geometry geometry_of(double cell, int rays, const ClipmapShape& shape) {
  // A level's origin is snapped to its sub-tile grid: its window reaches
  // n/2 - t cells from the clip centre at least.
  return {cell, kTwoPi / rays, shape.levels, cell * (shape.level_size / 2 - shape.subtile)};
}

Result<TracePlan> plan_trace(const ClipEye& eye, std::span<const visibility::BoxFootprint> footprints,
                             const ClipCullOptions& options, const ClipmapShape& shape, ClipCullScratch& w) {
  TracePlan plan;
  plan.g = geometry_of(std::min(eye.metres_per_col, eye.metres_per_row), options.rays, shape);
  plan.rays = options.rays;
  const int rays = options.rays;
  // The columns the boxes need, and how far.
  w.spans.resize(footprints.size());
  w.reach.assign(static_cast<std::size_t>(rays), 0.0);
  double farthest = 0.0;
  for (std::size_t i = 0; i < footprints.size(); ++i) {
    const BoxSpan& s = w.spans[i] = span_of(footprints[i], eye, plan.g, options.mode);
    if (s.eye_inside || s.off_map) continue;
    const long last = std::min(s.a1, s.a0 + rays - 1);
    for (long a = s.a0; a <= last; ++a) {
      double& r = w.reach[column_of(a, rays)];
      r = std::max(r, s.far);
    }
    farthest = std::max(farthest, s.far);
  }
  plan.edges = ring_edges(farthest, plan.g.cell, rays, shape);
  set_rings(plan, eye);
  // The box tests this will take, bounded before any tracing.
  for (BoxSpan& s : w.spans) {
    if (s.eye_inside || s.off_map) continue;
    const std::size_t first = plan.edges_upto(s.near), last = plan.edges_below(s.far);
    s.first_ring = static_cast<std::uint32_t>(first > 0 ? first - 1 : 0);
    const std::uint64_t ring_count = last + 1 > first ? last + 1 - first : 1;
    const std::uint64_t column_count = static_cast<std::uint64_t>(std::min<long>(s.a1 - s.a0 + 1, rays));
    plan.box_tests += ring_count * column_count;
  }
  if (plan.box_tests > options.max_box_tests)
    return make_error(ErrorCode::kResourceExhausted,
                      "the boxes would need " + std::to_string(plan.box_tests) + " box tests from this eye (at most " +
                          std::to_string(options.max_box_tests) +
                          "): some footprints span too many rays and rings; register smaller boxes or use fewer rays",
                      "boxes");
  return plan;
}

TracePlan plan_reach(const ClipEye& eye, const ClipCullOptions& options, const ClipmapShape& shape, double reach,
                     ClipCullScratch& w) {
  TracePlan plan;
  plan.g = geometry_of(std::min(eye.metres_per_col, eye.metres_per_row), options.rays, shape);
  plan.rays = options.rays;
  w.spans.clear();
  w.reach.assign(static_cast<std::size_t>(options.rays), reach);
  plan.edges = ring_edges(reach, plan.g.cell, options.rays, shape);
  set_rings(plan, eye);
  return plan;
}

void set_rings(TracePlan& plan, const ClipEye& eye) {
  const auto& edges = plan.edges;
  // Buckets no wider than the finest ring (so one holds at most an edge or
  // two), and at most 65 536 of them for the longest reach.
  plan.bucket_first.clear();
  if (!edges.empty()) {
    const double width = std::max(plan.g.cell, edges.back() / 65536.0);
    const std::size_t buckets = static_cast<std::size_t>(edges.back() / width) + 1;
    plan.inv_bucket_width = 1.0 / width;
    plan.bucket_first.resize(buckets);
    std::size_t i = 0;
    for (std::size_t b = 0; b < buckets; ++b) {
      while (i < edges.size() && edges[i] <= static_cast<double>(b) * width) ++i;
      plan.bucket_first[b] = static_cast<std::uint32_t>(i);
    }
  }
  plan.rings.resize(edges.size() > 0 ? edges.size() - 1 : 0);
  for (std::size_t j = 0; j < plan.rings.size(); ++j) {
    Ring& r = plan.rings[j];
    r.near = edges[j];
    r.far = edges[j + 1];
    r.mid = 0.5 * (r.near + r.far);
    r.inv_mid = 1.0 / r.mid;
    const double lambda = plan.g.lod(r.mid);
    r.k = static_cast<int>(lambda);
    r.blend = r.k + 1 < plan.g.levels ? static_cast<float>(lambda - r.k) : 0.0f;
    r.lowest_level = plan.g.level_at(r.near);
    r.mid_drop = eye.curvature * r.mid * r.mid;
    r.far_drop = eye.curvature * r.far * r.far;
  }
}

void prepare_horizons(const TracePlan& plan, ClipCullScratch& w) {
  const std::size_t columns = static_cast<std::size_t>(plan.rays);
  if (w.horizons.size() < columns * plan.edges.size()) w.horizons.resize(columns * plan.edges.size());
  w.traced.assign(columns, 0);
  w.stats.assign(columns, SampleStats{});
}

double least_on_column(const TracePlan& plan, const ClipEye& eye, const BoxSpan& s, const double* horizons,
                       std::size_t stride, std::size_t traced, std::uint64_t& tests) {
  const auto& edges = plan.edges;
  double least = std::numeric_limits<double>::infinity();
  for (std::size_t j = s.first_ring; j <= traced && j + 1 < edges.size() && edges[j] < s.far; ++j) {
    ++tests;
    const double lo = std::max(s.near, edges[j]), hi = std::min(s.far, edges[j + 1]);
    least = std::min(least, least_ohf(eye.elevation, horizons[j * stride], eye.curvature, lo, hi));
  }
  return least;
}

Status test_boxes(const TracePlan& plan, const ClipEye& eye, std::span<const visibility::BoxFootprint> footprints,
                  const ClipCullOptions& options, const RunControl* control, ClipCullScratch& w,
                  ClipCullResult& result) {
  const int rays = plan.rays;
  result.boxes.resize(footprints.size());
  w.tests.assign(footprints.size(), 0);
  auto test = [&](std::size_t i) {
    const BoxSpan& s = w.spans[i];
    double least = kNegInf;
    if (testable(s, plan)) {
      least = std::numeric_limits<double>::infinity();
      const long last = std::min(s.a1, s.a0 + rays - 1);
      for (long a = s.a0; a <= last; ++a) {
        const std::size_t column = column_of(a, rays);
        least = std::min(least, least_on_column(plan, eye, s, &horizon_at(w, rays, column, 0),
                                                static_cast<std::size_t>(rays), w.traced[column], w.tests[i]));
      }
    }
    set_answer(result.boxes[i], least, footprints[i]);
  };
  const std::size_t box_chunk = 256;
  HORIZON_RETURN_IF_ERROR(
      parallel_for((footprints.size() + box_chunk - 1) / box_chunk, options.threads, control, [&](std::size_t c) {
        for (std::size_t i = c * box_chunk; i < std::min(footprints.size(), (c + 1) * box_chunk); ++i) test(i);
      }));
  std::uint64_t tests = 0;
  for (std::uint64_t t : w.tests) tests += t;
  summarize(w, tests, result);
  return Status::Ok();
}

void summarize(const ClipCullScratch& w, std::uint64_t box_tests, ClipCullResult& result) {
  result.visible_count = 0;
  for (const auto& b : result.boxes) result.visible_count += visibility::may_be_seen(b.state);
  for (std::size_t a = 0; a < w.traced.size(); ++a) {
    result.stats.samples += w.stats[a].samples;
    result.stats.fallbacks += w.stats[a].fallbacks;
    if (w.reach[a] <= 0.0) continue;
    ++result.stats.rays_traced;
    result.stats.rings += w.traced[a];
  }
  result.stats.box_tests += box_tests;
}

}  // namespace detail

Status check_rays(int rays) {
  if (rays < 64 || rays > 65536)
    return make_error(ErrorCode::kInvalidArgument, "rays must be in [64, 65536], got " + std::to_string(rays), "rays");
  return Status::Ok();
}

std::vector<double> ring_edges(double reach, double cell_metres, int rays, const ClipmapShape& shape) {
  const detail::Geometry g = detail::geometry_of(cell_metres, rays, shape);
  std::vector<double> edges{0.5 * cell_metres};
  while (edges.back() < reach) edges.push_back(edges.back() + std::ldexp(cell_metres, g.level_at(edges.back())));
  return edges;
}

}  // namespace horizon::clipmap
