// Private to the radial sweep: one sector's geometry and the terrain samples
// a cell takes of its own sight line (RayBlend::kResample).
//
// radial_sweep.cpp marches the rays; resample_cells.cpp evaluates a line's
// cells from the rays' state. Both take their samples through this file, so
// a ray spawned by thinning and a cell re-sampling its sight line compute the
// same float for the same crossing, whichever kernel (scalar or AVX2) runs.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>

namespace horizon::visibility::sweep {

// "No horizon yet": a finite value below any real one, so that blending two
// rays never produces NaN from -inf arithmetic.
constexpr float kNoHorizon = -1.0e30f;

// One sector, in (u, v) terms, addressing the elevation and output grids.
struct Sector {
  // Elevation: value at (line i, v index j) = z[i * z_line + j * z_v].
  const float* z = nullptr;
  std::ptrdiff_t z_line = 0, z_v = 0;
  float fill = std::numeric_limits<float>::quiet_NaN();  // what a void reads as (HeightView::void_fill)
  // v is counted from the window's first v line (v_offset in the DEM), so the
  // float arithmetic is the same whatever surrounds the window: a result
  // never depends on how much of the file around it was read.
  int v_offset = 0;
  int v_count = 0;  // positions along v in the DEM from v_offset on
  // Output (window-relative): ohf[(i - out_line0) * o_line + (j - out_v0) * o_v],
  // or, when `mask` is set (radial_mask), the codes at the same place of it.
  float* out = nullptr;
  std::uint8_t* mask = nullptr;
  std::ptrdiff_t o_line = 0, o_v = 0;
  int out_line0 = 0, out_v0 = 0;
  int win_v0 = 0, win_v1 = 0;  // window range along v, half-open
  // Lines: first line index, direction (+1 / -1), count; step of line n is k0 + n.
  int line0 = 0, dir = 1, lines = 0, line_count = 0;  // line_count = lines in the whole DEM along u
  double k0 = 1.0;
  double eye_v = 0.0;
  double metres_u = 1.0, metres_v = 1.0;
  bool include_diagonal = true;  // north/south own |dv| == k, east/west do not
  bool rows = true;              // u runs along rows (north/south: lines are rows, v = column)
};

// Height of the terrain sample a + t (b - a) relative to the eye, in float32
// without losing the eye-relative bits at high altitude: the eye is split
// into eye_hi (its float rounding) + eye_lo, and a - eye_hi is exact for
// terrain near the eye (Sterbenz), so the result is the same whether the
// scene sits at 0 m or at 8 km (a plain a + t (b - a) - eye rounds to
// 0.5 mm there, which a crossing close to the eye amplifies to decimetres).
// HeightView::fill: a void (NaN) reads as `fill`, NaN when voids are transparent.
inline float fill_void(float v, float fill) {
  return v == v ? v : fill;
}

inline float eye_relative(float a, float b, float t, float eye_hi, float eye_lo) {
  return ((a - eye_hi) - eye_lo) + t * (b - a);
}

// Re-sampling a cell's own sight line (RayBlend::kResample). The cell at
// step k, v = j has sight line v = eye_v + m k' (m = (j - eye_v) / k). Where a
// bracketing ray found its horizon (on the u line at step n', or on the v line
// c) the cell's sight line crosses the same grid line close by; its R3 sample
// there, and at the last line before the cell, are taken. Every value is one
// of R3's samples of that sight line, so the maximum never exceeds R3's
// horizon: the result errs only towards "visible", and only when the sight
// line's own maximum lies where neither bracketing ray had its maximum.
struct CellLine {
  const Sector* s;
  const float* inv_step;                          // 1 / (k0 + n) per line step n
  const float* inv_dv;                            // 1 / (c - eye_v) per v index c (0 where c == eye_v)
  float eye, eye_lo, eye_v, v_min, v_max, k0, k;  // eye = eye_hi + eye_lo (see eye_relative)
  float curvature, mu2, mv2;                      // curvature per metre^2; metres per unit step along u and v, squared
  int j_max, zv, line0, dir, line_count;
  std::ptrdiff_t z_line;
};

struct CellRay {
  float m, inv_m, curv_k;  // the cell's slope dv/dk, its inverse (0 when m == 0), curvature per unit step
  int own_v = -1;          // the cell's own v line, which its sight line reaches only at the cell itself
};

inline CellRay cell_ray(const CellLine& L, int j) {
  const float dj = static_cast<float>(j) - L.eye_v;
  const float m = dj / L.k;
  return {m, L.k * L.inv_dv[j], L.curvature * (L.mu2 + m * m * L.mv2), j};
}

// Sample on the u line at step n (the cell's line has a larger step).
inline float sample_u(const CellLine& L, const CellRay& c, int n) {
  const float kn = L.k0 + static_cast<float>(n);
  const float v = std::min(std::max(L.eye_v + c.m * kn, L.v_min), L.v_max);
  const int j0 = std::min(static_cast<int>(v), L.j_max);
  const float t = v - static_cast<float>(j0);
  const float* zl = L.s->z + (L.line0 + L.dir * n) * L.z_line;
  const float a = fill_void(zl[j0 * L.zv], L.s->fill), b = fill_void(zl[(j0 + 1) * L.zv], L.s->fill);
  return eye_relative(a, b, t, L.eye, L.eye_lo) * L.inv_step[n] - c.curv_k * kn;
}

// Sample on the v line `vline`, if the sight line crosses it before the cell.
inline float sample_v(const CellLine& L, const CellRay& c, int vline) {
  if (c.inv_m == 0.0f || vline == c.own_v) return kNoHorizon;
  const float kc = (static_cast<float>(vline) - L.eye_v) * c.inv_m;
  if (!(kc > 0.0f && kc < L.k)) return kNoHorizon;
  // Between the lines at steps k0 + n1 and k0 + n1 + 1 (n1 = -1: the line at or behind the eye).
  const float x = kc - L.k0;
  const int n1 = static_cast<int>(std::floor(x));
  const float t = x - static_cast<float>(n1);
  const int la = std::clamp(L.line0 + L.dir * n1, 0, L.line_count - 1);
  const int lb = std::clamp(L.line0 + L.dir * (n1 + 1), 0, L.line_count - 1);
  const float a = fill_void(L.s->z[la * L.z_line + vline * L.zv], L.s->fill);
  const float b = fill_void(L.s->z[lb * L.z_line + vline * L.zv], L.s->fill);
  return eye_relative(a, b, t, L.eye, L.eye_lo) * (c.m * L.inv_dv[vline]) - c.curv_k * kc;
}

inline float sample_at(const CellLine& L, const CellRay& c, int where) {
  if (where >= 0) return sample_u(L, c, where);
  if (where <= -2) return sample_v(L, c, -2 - where);
  return kNoHorizon;
}

}  // namespace horizon::visibility::sweep
