// clip_trace_gl_shader.hpp (internal) — the compute shader of clip_trace_gl.cpp:
// the CPU trace of clip_cull.cpp (trace_cpu) and the reader's sampling
// (ClipmapReader::sample, ::lowest) written again in GLSL, with the same
// double and float arithmetic in the same order, so that on an IEEE device
// the horizons are the CPU's.
//
// One invocation per column (ray in fast mode, wedge in conservative mode),
// marching the plan's rings outward while ring.near < the column's reach.
//
// Levels: one R32F texture array, layer k = level k as its toroidal slots
// hold it (ClipmapReader::copy_level): level cell (i, j) is texel
// (i mod n, j mod n), the wrap addressing of the clip-map's torus. Voids
// and never-written slots hold kVoid. Residency: an R8UI texture array of
// (n/t)^2 sub-tile slots per level; a cell is resident when it lies in its
// level's window [origin, origin + n) and its slot's byte is 1.
#pragma once

namespace horizon::clipmap::gl_shader {

inline constexpr const char* kTrace = R"GLSL(
#version 430
layout(local_size_x = 64) in;

const int kMaxLevels = 10;
const float kVoid = -3.0e38;

struct Ring {
  double near_edge, far_edge, mid, inv_mid, mid_drop, far_drop, blend;
  int k, lowest_level;
};
struct Column {
  double cx0, cy0, cx1, cy1, cxm, cym, reach, unused;
};

layout(std430, binding = 0) readonly buffer Rings { Ring rings[]; };
layout(std430, binding = 1) readonly buffer Columns { Column columns[]; };
layout(std430, binding = 2) writeonly buffer Horizons { double horizons[]; };  // ring-major, as the CPU's
layout(std430, binding = 3) writeonly buffer Counts { uvec4 counts[]; };       // traced, samples, fallbacks

uniform sampler2DArray u_cells;
uniform usampler2DArray u_resident;
uniform int u_n, u_log_t, u_levels, u_rays, u_rings, u_fast, u_first, u_count;
uniform ivec2 u_origin[kMaxLevels];
uniform ivec2 u_size[kMaxLevels];   // level widths and heights, cells
uniform ivec2 u_source;             // source width and height
uniform dvec2 u_eye;                // source grid coordinates
uniform double u_eye_z, u_tangent;

uint samples = 0u, fallbacks = 0u;

bool resident(int k, int i, int j) {
  ivec2 o = u_origin[k];
  if (i < o.x || i >= o.x + u_n || j < o.y || j >= o.y + u_n) return false;
  int mask = (u_n >> u_log_t) - 1;
  return texelFetch(u_resident, ivec3((i >> u_log_t) & mask, (j >> u_log_t) & mask, k), 0).r != 0u;
}

float cell(int k, int i, int j) { return texelFetch(u_cells, ivec3(i & (u_n - 1), j & (u_n - 1), k), 0).r; }

// ClipmapReader::sample: bilinear at level k or the first coarser level
// whose four cells are resident; kVoid outside the source or on a void.
float sample_at(int k, double col, double row) {
  ++samples;
  if (!(col >= -0.5 && row >= -0.5 && col <= double(u_source.x) - 0.5 && row <= double(u_source.y) - 0.5))
    return kVoid;
  for (int kk = k; kk < u_levels; ++kk) {
    precise double scale = 1.0 / double(1 << kk);
    precise double u = (col + 0.5) * scale - 0.5, v = (row + 0.5) * scale - 0.5;
    double fi = floor(u), fj = floor(v);
    precise double a = u - fi, b = v - fj;
    int w = u_size[kk].x, h = u_size[kk].y;
    int i0 = clamp(int(fi), 0, w - 1), i1 = min(int(fi) + 1, w - 1);
    int j0 = clamp(int(fj), 0, h - 1), j1 = min(int(fj) + 1, h - 1);
    if (!resident(kk, i0, j0) || !resident(kk, i1, j0) || !resident(kk, i0, j1) || !resident(kk, i1, j1)) continue;
    if (kk > k) ++fallbacks;
    float z00 = cell(kk, i0, j0), z10 = cell(kk, i1, j0), z01 = cell(kk, i0, j1), z11 = cell(kk, i1, j1);
    if (z00 == kVoid || z10 == kVoid || z01 == kVoid || z11 == kVoid) return kVoid;
    precise float d0 = z10 - z00, d1 = z11 - z01;
    precise double top = double(z00) + double(d0) * a, bottom = double(z01) + double(d1) * a;
    precise double z = top + (bottom - top) * b;
    return float(z);
  }
  return kVoid;
}

// ClipmapReader::lowest: the least cell meeting source cells [c0, c1] x
// [r0, r1] at level k or the first coarser level holding them all.
float lowest_at(int k, int c0, int r0, int c1, int r1) {
  ++samples;
  c0 = max(c0, 0);
  r0 = max(r0, 0);
  c1 = min(c1, u_source.x - 1);
  r1 = min(r1, u_source.y - 1);
  if (c0 > c1 || r0 > r1) return uintBitsToFloat(0x7f800000u);
  for (int kk = k; kk < u_levels; ++kk) {
    int i0 = c0 >> kk, i1 = c1 >> kk, j0 = r0 >> kk, j1 = r1 >> kk;
    bool all = true;
    for (int j = j0; j <= j1 && all; ++j)
      for (int i = i0; i <= i1 && all; ++i) all = resident(kk, i, j);
    if (!all) continue;
    if (kk > k) ++fallbacks;
    float least = uintBitsToFloat(0x7f800000u);
    for (int j = j0; j <= j1; ++j)
      for (int i = i0; i <= i1; ++i) {
        float z = cell(kk, i, j);
        if (z == kVoid) return uintBitsToFloat(0xff800000u);
        least = min(least, z);
      }
    return least;
  }
  return uintBitsToFloat(0xff800000u);
}

void main() {
  int index = int(gl_GlobalInvocationID.x);
  if (index >= u_count) return;
  int a = u_first + index;
  Column c = columns[a];
  double neg_inf = double(uintBitsToFloat(0xff800000u));
  double horizon = neg_inf;
  horizons[a] = neg_inf;
  int j = 0;
  for (; j < u_rings && rings[j].near_edge < c.reach; ++j) {
    Ring ring = rings[j];
    if (u_fast != 0) {
      precise double x = u_eye.x + ring.mid * c.cx0, y = u_eye.y + ring.mid * c.cy0;
      float z = sample_at(ring.k, x, y);
      if (ring.blend > 0.0) {
        float z1 = sample_at(ring.k + 1, x, y);
        precise float blended = z + float(ring.blend) * (z1 - z);
        z = (z == kVoid || z1 == kVoid) ? kVoid : blended;
      }
      if (z != kVoid) {
        precise double slope = (double(z) - ring.mid_drop - u_eye_z) * ring.inv_mid;
        horizon = max(horizon, slope);
      }
    } else {
      // The wedge's piece of ring j: the rays' end points and the outer arc's tangent point.
      double b0 = ring.near_edge, b1 = ring.far_edge;
      precise double t1 = b1 * u_tangent;
      precise double xs[5] = double[5](b0 * c.cx0, b1 * c.cx0, b0 * c.cx1, b1 * c.cx1, t1 * c.cxm);
      precise double ys[5] = double[5](b0 * c.cy0, b1 * c.cy0, b0 * c.cy1, b1 * c.cy1, t1 * c.cym);
      double xmin = xs[0], xmax = xs[0], ymin = ys[0], ymax = ys[0];
      for (int p = 1; p < 5; ++p) {
        xmin = min(xmin, xs[p]);
        xmax = max(xmax, xs[p]);
        ymin = min(ymin, ys[p]);
        ymax = max(ymax, ys[p]);
      }
      precise double x0 = u_eye.x + xmin, y0 = u_eye.y + ymin, x1 = u_eye.x + xmax, y1 = u_eye.y + ymax;
      float low = lowest_at(ring.lowest_level, int(floor(x0)), int(floor(y0)), int(ceil(x1)), int(ceil(y1)));
      if (!isinf(low)) {
        precise double rise = double(low) - ring.far_drop - u_eye_z;
        precise double slope = rise / (rise > 0.0 ? b1 : b0);
        horizon = max(horizon, slope);
      }
    }
    horizons[(j + 1) * u_rays + a] = horizon;
  }
  counts[a] = uvec4(uint(j), samples, fallbacks, 0u);
}
)GLSL";

}  // namespace horizon::clipmap::gl_shader
