// Private to visibility: the ray disk of the GL form of the fast OHF
// (radial_sweep_gl.cpp) and the tables it uploads, built on the CPU from the
// sweep geometry both forms share (sweep_geometry.hpp). No GL here, so the
// tables can be checked against the CPU sweep's without a context.
//
// Layout: one disk row per ray, the sectors' rays one after another (sector
// order of sweep::kSectorOrder, empty sectors left out); one column per step
// outward. The storage buffers, as gl_shaders::kCommon reads them:
//   binding 0: GpuSector per sector (padded to four by the caller);
//   binding 1 (`table`, float): per disk row its ray's slope, then 1/slope,
//     then curvature per unit step (three blocks of `rows` floats); then per
//     sector at steps_at six floats per line (k, k - 1, 1/k by float
//     division, 1/k from double, the wedge's first and last v position), and
//     at dv_at 1 / (v - eye_v) per v position of the window;
//   binding 2 (`doubles`): per sector at d_at eye_v, then 1/k per line, for
//     the bracketing-ray decision in double (sweep::ray_coordinate).
#pragma once

#include <cstdint>
#include <vector>

#include "horizon/visibility/view_frame.hpp"
#include "sweep_geometry.hpp"

namespace horizon::visibility::gl {

// Mirrors `struct Sector` in gl_shaders::kCommon (std430: 4-byte scalars only).
struct GpuSector {
  std::int32_t rows, dir, line0, lines, ray_half, base, u_count, v_count, j_max, steps_at, dv_at, d_at;
  float k0, eye_v, v_min, v_max, curvature, mu2, mv2, pad1;
};
static_assert(sizeof(GpuSector) == 80);

// One non-empty sector as the disk holds it, with the double-precision
// geometry kept for the read-back.
struct DiskSector {
  sweep::SectorLines lines;      // line0 in the DEM; the GPU gets it window-relative
  int ray_half = 0;              // its rays, sweep::ray_half(k_far, ray_spacing)
  int base = 0;                  // its first disk row
  int u_count = 0, v_count = 0;  // the window along u and v
};

struct DiskPlan {
  std::vector<DiskSector> sectors;
  std::vector<GpuSector> gpu_sectors;  // one per sector
  std::vector<float> table;            // binding 1
  std::vector<double> doubles;         // binding 2
  int width = 1, rows = 0;             // disk texels: the most lines of a sector; all sectors' rays
};

// The disk of frame `f` at `ray_spacing` (RadialOptions::ray_spacing), with
// its tables: O(rays + lines + window side) floats, built in microseconds.
DiskPlan plan_disk(const ViewFrame& f, double ray_spacing);

}  // namespace horizon::visibility::gl
