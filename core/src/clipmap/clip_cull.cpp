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

// A box as the trace sees it: its columns (rays or wedges, unwrapped) and
// ground distance range; `eye_inside` when its hull holds the eye.
struct BoxSpan {
  long a0 = 0, a1 = -1;
  double near = 0.0, far = 0.0;
  bool eye_inside = false;
};

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
  double d = lo;
  if (curvature > 0.0) d = std::clamp(-h / (2.0 * curvature), lo, hi);
  else if (h < 0.0) d = hi;
  return std::min({eye + lo * h + curvature * lo * lo, eye + hi * h + curvature * hi * hi, eye + d * h + curvature * d * d});
}

}  // namespace

std::vector<double> ring_edges(double reach, double cell_metres, int rays, const ClipmapShape& shape) {
  const Geometry g = geometry_of(cell_metres, rays, shape);
  std::vector<double> edges{0.5 * cell_metres};
  while (edges.back() < reach) edges.push_back(edges.back() + std::ldexp(cell_metres, g.level_at(edges.back())));
  return edges;
}

Result<ClipCullResult> cull_on_clipmap(const ClipmapReader& view, const ClipEye& eye,
                                       std::span<const visibility::BoxFootprint> footprints,
                                       const ClipCullOptions& options, const RunControl* control) {
  const auto start = std::chrono::steady_clock::now();
  const Clipmap& map = view.map();
  const terrain::Reduction want =
      options.mode == ClipMode::kConservative ? terrain::Reduction::kMin : terrain::Reduction::kMean;
  if (map.shape().reduction != want)
    return make_error(ErrorCode::kInvalidArgument,
                      options.mode == ClipMode::kConservative ? "conservative culling needs a min clip-map"
                                                              : "fast culling needs a mean clip-map",
                      "mode");
  if (options.rays < 64 || options.rays > 65536)
    return make_error(ErrorCode::kInvalidArgument, "rays must be in [64, 65536], got " + std::to_string(options.rays),
                      "rays");
  if (!std::isfinite(eye.col) || !std::isfinite(eye.row) || !std::isfinite(eye.elevation))
    return make_error(ErrorCode::kInvalidArgument, "eye: position or elevation is not a finite number", "eye");

  const Geometry g = geometry_of(std::min(eye.metres_per_col, eye.metres_per_row), options.rays, map.shape());
  const int rays = options.rays;
  ClipCullResult result;
  result.boxes.resize(footprints.size());

  // The columns the boxes need, and how far.
  std::vector<BoxSpan> spans(footprints.size());
  std::vector<double> reach(static_cast<std::size_t>(rays), 0.0);
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

  // before[a][j]: the horizon slope of column a over the rings before ring j.
  std::vector<std::vector<double>> before(static_cast<std::size_t>(rays));
  std::vector<SampleStats> column_stats(static_cast<std::size_t>(rays));
  const double tangent = 1.0 / std::cos(g.dtheta / 2);
  auto trace = [&](std::size_t a) {
    if (reach[a] <= 0.0) return;
    std::vector<double>& h = before[a];
    SampleStats& stats = column_stats[a];
    h.assign(1, kNegInf);
    const double t0 = static_cast<double>(a) * g.dtheta, t1 = t0 + g.dtheta;
    const double cx0 = std::cos(t0) / eye.metres_per_col, cy0 = std::sin(t0) / eye.metres_per_row;
    const double cx1 = std::cos(t1) / eye.metres_per_col, cy1 = std::sin(t1) / eye.metres_per_row;
    const double cxm = std::cos(t0 + g.dtheta / 2) / eye.metres_per_col, cym = std::sin(t0 + g.dtheta / 2) / eye.metres_per_row;
    double horizon = kNegInf;
    for (std::size_t j = 0; j + 1 < edges.size() && edges[j] < reach[a]; ++j) {
      const double b0 = edges[j], b1 = edges[j + 1];
      double slope = kNegInf;
      if (options.mode == ClipMode::kFast) {
        const double d = 0.5 * (b0 + b1);
        const double lambda = g.lod(d);
        const int k = static_cast<int>(lambda);
        const double f = lambda - k;
        const double col = eye.col + d * cx0, row = eye.row + d * cy0;
        float z = view.sample(k, col, row, stats);
        if (f > 0.0 && k + 1 < g.levels) z = static_cast<float>((1.0 - f) * z + f * view.sample(k + 1, col, row, stats));
        if (z == z) slope = (z - eye.curvature * d * d - eye.elevation) / d;
      } else {
        // The wedge's piece of ring j: the rays' end points and the outer arc's tangent point.
        const double xs[5] = {b0 * cx0, b1 * cx0, b0 * cx1, b1 * cx1, b1 * tangent * cxm};
        const double ys[5] = {b0 * cy0, b1 * cy0, b0 * cy1, b1 * cy1, b1 * tangent * cym};
        const auto [xmin, xmax] = std::minmax_element(xs, xs + 5);
        const auto [ymin, ymax] = std::minmax_element(ys, ys + 5);
        const float low = view.lowest(g.level_at(b0), static_cast<int>(std::floor(eye.col + *xmin)),
                                      static_cast<int>(std::floor(eye.row + *ymin)),
                                      static_cast<int>(std::ceil(eye.col + *xmax)),
                                      static_cast<int>(std::ceil(eye.row + *ymax)), stats);
        if (low > -std::numeric_limits<float>::infinity() && low < std::numeric_limits<float>::infinity()) {
          const double rise = low - eye.curvature * b1 * b1 - eye.elevation;
          slope = rise / (rise > 0.0 ? b1 : b0);
        }
      }
      horizon = std::max(horizon, slope);
      h.push_back(horizon);
    }
  };
  std::vector<std::size_t> columns;
  for (std::size_t a = 0; a < reach.size(); ++a)
    if (reach[a] > 0.0) columns.push_back(a);
  const std::size_t chunk = 16;
  HORIZON_RETURN_IF_ERROR(parallel_for((columns.size() + chunk - 1) / chunk, options.threads, control, [&](std::size_t c) {
    for (std::size_t i = c * chunk; i < std::min(columns.size(), (c + 1) * chunk); ++i) trace(columns[i]);
  }));

  // Each box against its columns' horizons.
  std::vector<std::uint64_t> tests(footprints.size(), 0);
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
        const std::vector<double>& h = before[column_of(a, rays)];
        for (std::size_t j = first_ring; j < h.size() && j + 1 < edges.size() && edges[j] < s.far; ++j) {
          ++tests[i];
          const double lo = std::max(s.near, edges[j]), hi = std::min(s.far, edges[j + 1]);
          least = std::min(least, least_ohf(eye.elevation, h[j], eye.curvature, lo, hi));
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
  for (std::size_t a = 0; a < before.size(); ++a) {
    if (before[a].empty()) continue;
    ++result.stats.rays_traced;
    result.stats.rings += before[a].size() - 1;
    result.stats.samples += column_stats[a].samples;
    result.stats.fallbacks += column_stats[a].fallbacks;
  }
  for (std::uint64_t t : tests) result.stats.box_tests += t;
  result.stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace horizon::clipmap
