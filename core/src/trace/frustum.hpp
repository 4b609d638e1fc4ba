// Private to core/trace: the geometry the CPU and GL traces share — which
// grid lines each screen column's ray crosses, in which order, where.
//
// A screen column is the vertical half-plane through the eye at its
// azimuth. Its ray (seen from above) crosses the DEM's row lines (y = r) and
// column lines (x = c) one after another. Sakalauskas's method orders one
// family of parallel lines front to back and partitions them; that family
// must be the one the ray crosses most squarely, so the screen is cut into
// sub-frusta ("runs" of adjacent columns) by the quadrant of their azimuth
// in grid terms (on square cells, the metric azimuth):
//
//   quadrant 0, azimuth in [-45, 45) degrees (north): row lines, rows decreasing
//   quadrant 1, [45, 135) (east):                      column lines, columns increasing
//   quadrant 2, [135, 225) (south):                    row lines, rows increasing
//   quadrant 3, [225, 315) (west):                     column lines, columns decreasing
//
// Inside a run every column crosses the same "primary" lines, line k lying
// t = k + t0 line spacings ahead of the eye along the quadrant's axis
// (t0 in (0, 1]: the line through the eye itself is never crossed). With phi
// the column's azimuth off that axis (|phi| <= 45 degrees), crossing k lies
//   position along the line = eye_along + t * pos_per_t   (cells)
//   ground distance         = t * dist_per_t              (metres)
// with pos_per_t = +-tan(phi) * spacing / along_cell (at most one cell a
// line) and dist_per_t = spacing / cos(phi): both linear in t, so nothing
// per crossing but a multiply-add. The "secondary" lines (the other family, R3's other
// crossings: the exact extension) follow the same form per column, ordered
// by their own t from the eye to the side phi leans to; a column looking
// straight down the axis (phi = 0) crosses none.
//
// All per-crossing arithmetic is float32, one formula (crossing_slope), so
// the scalar, AVX2 and AVX-512 forms give the same bits.
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "horizon/terrain/height_view.hpp"
#include "horizon/trace/camera.hpp"
#include "horizon/trace/trace.hpp"

namespace horizon::trace::detail {

inline constexpr float kNoCrossing = -std::numeric_limits<float>::infinity();

// One family of parallel grid lines, as a kernel reads it: crossing k is on
// grid line first + step * k; along that line the cells are `pos_count`
// long; the cell (line, i) is at data[line * line_stride + i * pos_stride].
struct LineFamily {
  LineAxis axis = LineAxis::kRows;
  int first = 0, step = 1;
  int count = 0;           // crossings 0..count-1 lie on lines inside the view
  float t0 = 1.0f;         // line spacings from the eye to crossing 0
  float eye_along = 0.0f;  // the eye's position along these lines (cells)
  std::ptrdiff_t line_stride = 0, pos_stride = 1;
  int pos_count = 0;
};

// A sub-frustum: screen columns [x0, x1) of one quadrant.
struct Run {
  int x0 = 0, x1 = 0;
  int quadrant = 0;
  LineFamily primary;
  // The secondary family towards each side: [0] for phi < 0, [1] for phi > 0.
  LineFamily secondary[2];
};

// The frame's geometry: runs, and per screen column the constants of its
// ray (structure of arrays, indexed by screen column).
struct FrameGeometry {
  std::vector<Run> runs;
  float eye_z = 0.0f;      // eye elevation, metres
  float curvature = 0.0f;  // metres of drop per square metre of distance
  float fill = terrain::HeightView::kTransparent;
  float far = std::numeric_limits<float>::infinity();  // ground metres
  std::vector<float> pos_per_t, dist_per_t;            // primary family
  std::vector<float> pos_per_t2, dist_per_t2;          // secondary family (0 / +inf with phi = 0)
  std::vector<std::uint8_t> side;                      // which secondary family: 0 (phi < 0) or 1
  std::vector<float> near;                             // ground metres from which crossings count
  std::vector<float> inv_focal_col;                    // 1 / f_col, for a pixel's slope
  float cy = 0.0f;
  int height = 0;
  // Cells the grid lines run over (the view's size).
  int view_width = 0, view_height = 0;
};

// Builds the runs and the per-column tables for `camera` over `view` (whose
// grid the camera's eye is in). The view must be at least 2 x 2 cells.
FrameGeometry make_frame_geometry(const Camera& camera, const terrain::HeightView& view, const TraceOptions& options);

// A pixel's slope: (y_up - cy) / f_col, y_up = height - j - 0.5, as float.
inline float pixel_slope(const FrameGeometry& g, int x, int j) {
  const float y_up = static_cast<float>(g.height - j) - 0.5f;
  return (y_up - g.cy) * g.inv_focal_col[x];
}

// The slope (eye-relative climb per ground metre, curvature-lowered) of
// the crossing `t` line spacings ahead on grid line `line` of a family
// whose cells along a line are `pos_count` long, cell (line, i) at
// data[line * line_stride + i * pos_stride], for a column whose crossings
// move pos_per_t cells along the line and dist_per_t ground metres per line
// spacing. kNoCrossing where it leaves the view, lies nearer than `near` or
// farther than `far`, or meets a void (voids read through `fill` first).
// R3's row-line sample: the terrain between the two cells the crossing
// falls between. Every form of the trace (SIMD, GL, the reference) does
// these operations in this order.
inline float crossing_slope(const float* data, float eye_along, int pos_count, std::ptrdiff_t line_stride,
                            std::ptrdiff_t pos_stride, int line, float t, float pos_per_t, float dist_per_t, float near,
                            float far, float eye_z, float curvature, float fill) {
  const float p = eye_along + t * pos_per_t;
  const float d = t * dist_per_t;
  if (!(d >= near && d <= far && p >= 0.0f && p <= static_cast<float>(pos_count - 1))) return kNoCrossing;
  int i = static_cast<int>(std::floor(p));
  if (i > pos_count - 2) i = pos_count - 2;
  const float f = p - static_cast<float>(i);
  const float* a = data + static_cast<std::ptrdiff_t>(line) * line_stride + static_cast<std::ptrdiff_t>(i) * pos_stride;
  float h0 = a[0], h1 = a[pos_stride];
  h0 = h0 == h0 ? h0 : fill;
  h1 = h1 == h1 ? h1 : fill;
  const float z = h0 + f * (h1 - h0);
  const float s = ((z - eye_z) - curvature * d * d) / d;
  return s == s ? s : kNoCrossing;
}

// crossing_slope of crossing k of `family`.
inline float family_slope(const float* data, const LineFamily& family, int k, float pos_per_t, float dist_per_t,
                          float near, float far, float eye_z, float curvature, float fill) {
  return crossing_slope(data, family.eye_along, family.pos_count, family.line_stride, family.pos_stride,
                        family.first + family.step * k, static_cast<float>(k) + family.t0, pos_per_t, dist_per_t, near,
                        far, eye_z, curvature, fill);
}

// Ground distance of crossing k of a family, as crossing_slope takes it.
inline float crossing_distance(const LineFamily& family, int k, float dist_per_t) {
  return (static_cast<float>(k) + family.t0) * dist_per_t;
}

// Where the pixel's ray (slope s) meets the chord between the crossing
// before its hit (distance d0, slope s0; s0 < s, or s0 = kNoCrossing: none)
// and the hit crossing (d1, s1 >= s): the ground distance of the hit. In
// the curvature-lowered frame both crossings and the ray are straight, so
// this is the perspective-correct version of the paper's InterpolateV.
inline float chord_hit(float s, float d0, float s0, float d1, float s1) {
  if (!(s0 > kNoCrossing)) return d1;
  const float z0 = s0 * d0, z1 = s1 * d1;
  const float denom = (z1 - z0) - s * (d1 - d0);
  if (!(denom > 0.0f)) return d1;
  float t = (s * d0 - z0) / denom;
  t = t < 0.0f ? 0.0f : (t > 1.0f ? 1.0f : t);
  return d0 + t * (d1 - d0);
}

// The index of the last crossing of `family` strictly nearer than ground
// distance `d` (-1: none), for a column whose crossings are dist_per_t apart.
inline int last_crossing_before(const LineFamily& family, float d, float dist_per_t) {
  if (!(dist_per_t < std::numeric_limits<float>::infinity()) || family.count == 0) return -1;
  int k = static_cast<int>(std::ceil(d / dist_per_t - family.t0)) - 1;
  if (k >= family.count) k = family.count - 1;
  // Guard the division's rounding with the exact distances.
  while (k >= 0 && crossing_distance(family, k, dist_per_t) >= d) --k;
  while (k + 1 < family.count && crossing_distance(family, k + 1, dist_per_t) < d) ++k;
  return k;
}

}  // namespace horizon::trace::detail
