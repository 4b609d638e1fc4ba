// Private to visibility: the geometry of the radial sweep, shared by its CPU
// form (radial_sweep.cpp) and its GL form (radial_sweep_gl.cpp), so that the
// two march the same rays over the same lines and give a cell to the same
// sector and the same pair of rays. radial_sweep.cpp's header comment explains
// the geometry; in short: a sector has (u, v) coordinates, u along its major
// axis away from the eye, v across it; line n of the sector is the grid line
// at step k = k0 + n from the eye; ray r of 2 half + 1 has slope dv/dk =
// r / half.
//
// Every value is computed once here, in double, and rounded to float where a
// kernel wants a float, so both forms (and the GPU, which receives these
// tables) see the same bits. What stays in each form is how it walks them:
// the CPU's tasks, thinning and loop bounds; the GPU's disk layout.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "../common/int_floor.hpp"
#include "horizon/common/error.hpp"
#include "horizon/visibility/view_frame.hpp"

namespace horizon::visibility::sweep {

// Which way a sector runs: along rows (north/south: its lines are rows, v is
// the column) or columns (east/west), towards larger (+1) or smaller (-1)
// indices.
struct SectorAxis {
  bool rows = true;
  int dir = 1;
};

// The four sectors, in the order both forms number them: north, south, east, west.
inline constexpr SectorAxis kSectorOrder[4] = {{true, -1}, {true, +1}, {false, +1}, {false, -1}};

// One sector's lines inside the frame's window.
struct SectorLines {
  SectorAxis axis;
  int line0 = 0;                          // DEM index of the first line past the eye (inside the window)
  int lines = 0;                          // lines from line0 to the window's edge; 0: an empty sector
  double k0 = 1.0;                        // step of line0 from the eye, > 0
  int u0 = 0;                             // the window's first line along u, in the DEM
  int v0 = 0;                             // the window's first position along v, in the DEM: v is counted from here
  double eye_v = 0.0;                     // the eye along v, counted from v0
  double metres_u = 1.0, metres_v = 1.0;  // ground metres per unit step along u and v
  bool include_diagonal = true;           // north/south own the cells with |v - eye_v| == k, east/west do not

  double step(int n) const { return k0 + n; }
};

// The sector `axis` of frame `f`. k0 is formed from DEM line numbers (the
// same double whatever the window), eye_v from the window's first v line.
inline SectorLines sector_lines(const ViewFrame& f, SectorAxis axis) {
  const terrain::Window& w = f.window;
  const bool rows = axis.rows;
  SectorLines s;
  s.axis = axis;
  const double eye_u = rows ? f.observer_row : f.observer_col;
  s.u0 = rows ? w.row0 : w.col0;
  const int u1 = rows ? w.row1 : w.col1;  // the window along u, half-open
  s.v0 = rows ? w.col0 : w.row0;
  s.eye_v = (rows ? f.observer_col : f.observer_row) - s.v0;
  s.metres_u = rows ? f.metres_per_row : f.metres_per_col;
  s.metres_v = rows ? f.metres_per_col : f.metres_per_row;
  s.include_diagonal = rows;
  if (axis.dir > 0) {
    s.line0 = std::max(static_cast<int>(std::floor(eye_u)) + 1, s.u0);
    s.lines = u1 - s.line0;
    s.k0 = s.line0 - eye_u;
  } else {
    s.line0 = std::min(static_cast<int>(std::ceil(eye_u)) - 1, u1 - 1);
    s.lines = s.line0 - s.u0 + 1;
    s.k0 = eye_u - s.line0;
  }
  return s;
}

// Rays per side of a sector whose farthest line is at step k_far: enough that
// neighbouring rays are at most ray_spacing cells apart there, rounded up to
// a multiple of `quantum` (the CPU's thinning needs one; the GPU uses 1).
inline int ray_half(double k_far, double ray_spacing, int quantum = 1) {
  return quantum * std::max(1, static_cast<int>(std::ceil(k_far / ray_spacing / quantum)));
}

// Whether ray_half(k_far, ray_spacing) fits its int with room for the
// tables' 2 half + 1 entries. Planned requests stay far below (plan.hpp's
// kMaxSweepRays); a sweep called without a plan checks it before sizing.
inline bool ray_half_fits(double k_far, double ray_spacing) {
  return k_far / ray_spacing <= static_cast<double>(std::numeric_limits<int>::max() / 4);
}

// kResourceExhausted, naming ray_spacing, when a sector of `f` would need
// more rays than ray_half_fits allows (a caller that skipped the plan).
inline Status check_ray_count(const ViewFrame& f, double ray_spacing) {
  for (const SectorAxis axis : kSectorOrder) {
    const SectorLines g = sector_lines(f, axis);
    if (g.lines > 0 && !ray_half_fits(g.step(g.lines - 1), ray_spacing))
      return make_error(ErrorCode::kResourceExhausted,
                        "ray_spacing: " + number_text(ray_spacing, 3) + " cells over a sector of " +
                            std::to_string(g.lines) +
                            " lines needs more rays than the sweep can index; use a "
                            "coarser ray_spacing",
                        "ray_spacing");
  }
  return Status::Ok();
}

// The rays of one sector, index r + half for ray r in [-half, half].
struct RayTable {
  int half = 0;
  double step = 0.0;             // slope spacing between neighbouring rays, 1 / half
  std::vector<float> slope;      // m_r = dv/dk, in [-1, 1]
  std::vector<float> inv_slope;  // 1 / m_r, 0 for m_r == 0
  std::vector<float> curv_k;     // curvature * (ground metres per unit step along ray r)^2

  int count() const { return 2 * half + 1; }
};

inline RayTable ray_table(int half, double metres_u, double metres_v, double curvature) {
  RayTable t;
  t.half = half;
  t.step = 1.0 / half;
  const int rays = t.count();
  t.slope.resize(rays);
  t.inv_slope.resize(rays);
  t.curv_k.resize(rays);
  for (int r = -half; r <= half; ++r) {
    const double m = std::clamp(r * t.step, -1.0, 1.0);
    t.slope[r + half] = static_cast<float>(m);
    t.inv_slope[r + half] = m == 0 ? 0.0f : static_cast<float>(1.0 / m);
    const double metres_per_k = std::hypot(metres_u, m * metres_v);
    t.curv_k[r + half] = static_cast<float>(curvature * metres_per_k * metres_per_k);
  }
  return t;
}

// 1 / step per line n in [0, lines), the double quotient rounded to float.
inline std::vector<float> inv_steps(double k0, int lines) {
  std::vector<float> out(static_cast<std::size_t>(std::max(lines, 0)));
  for (int n = 0; n < lines; ++n) out[n] = static_cast<float>(1.0 / (k0 + n));
  return out;
}

// 1 / (v - eye_v) per v position in [0, count), 0 at a position equal to eye_v.
inline std::vector<float> inv_dvs(double eye_v, int count) {
  std::vector<float> out(static_cast<std::size_t>(std::max(count, 0)));
  for (int v = 0; v < count; ++v) out[v] = v == eye_v ? 0.0f : static_cast<float>(1.0 / (v - eye_v));
  return out;
}

// The v positions [lo, hi] a sector owns on the line at step k (empty when
// lo > hi), before any window or distance limit: |v - eye_v| <= k with the
// diagonal, < k without, so that every cell but the eye's own has one owner
// (up to rounding, which owned_cells, below, settles).
struct CellSpan {
  int lo = 0, hi = -1;
};

inline CellSpan wedge(double eye_v, double k, bool include_diagonal) {
  const double lo = eye_v - k, hi = eye_v + k;
  CellSpan span{static_cast<int>(std::ceil(lo)), static_cast<int>(std::floor(hi))};
  if (!include_diagonal) {
    if (span.lo == lo) ++span.lo;
    if (span.hi == hi) --span.hi;
  }
  return span;
}

// The cells sector `g` owns on its line n, as wedge() gives them, with each
// end settled by comparing the cell's distance from the eye across the
// sector with the line's along it, both taken from DEM numbers and the
// frame's eye: a cell near a diagonal is then judged by its two sectors
// with the same two doubles, and falls in exactly one. (wedge() alone
// rounds eye_v -+ k: with the eye at column 60.4, row 70.6, row 70 of
// column 61 came out a tie for the east sector, which leaves ties to
// north, and beyond the wedge for the north one, and no sector wrote it.)
inline CellSpan owned_cells(const ViewFrame& f, const SectorLines& g, int n) {
  const bool rows = g.axis.rows;
  const double eye_u = rows ? f.observer_row : f.observer_col;
  const double eye_v = rows ? f.observer_col : f.observer_row;
  const double k = std::abs(static_cast<double>(g.line0 + g.axis.dir * n) - eye_u);
  const auto owns = [&](int j) {
    const double d = std::abs(static_cast<double>(j + g.v0) - eye_v);
    return d < k || (g.include_diagonal && d == k);
  };
  CellSpan span = wedge(g.eye_v, g.step(n), g.include_diagonal);
  --span.lo;
  ++span.hi;
  while (span.lo <= span.hi && !owns(span.lo)) ++span.lo;
  while (span.hi >= span.lo && !owns(span.hi)) --span.hi;
  return span;
}

// Which two rays bracket a cell. The cell at v position j on the line at
// step k lies at ray coordinate rho = (j - eye_v) / k * half, computed in
// double from inv_k = 1 / k (double); it takes rays lower_ray(rho) and
// lower_ray(rho) + 1, even when rho is a whole number, blended by the
// fraction rho - r. The GL form's resolve pass computes the same expression
// in GLSL double from the same eye_v and 1 / k, so ties fall the same way.
inline double ray_coordinate(int j, double eye_v, double inv_k, int half) {
  return (j - eye_v) * inv_k * half;
}

inline int lower_ray(double rho, int half) {
  return std::clamp(floor_to_int(rho), -half, half - 1);
}

}  // namespace horizon::visibility::sweep
