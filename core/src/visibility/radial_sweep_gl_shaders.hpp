// GLSL sources of the GL form of the fast OHF (radial_sweep_gl.hpp), one
// function per pass, shared by the fragment and the compute form:
//   vec2 modulate(ivec2 texel)  - the disk texel (step, ray): (sample, where)
//   vec2 propagate(ivec2 texel) - the larger of texel n and texel n - u_shift
//   vec2 shifted(ivec2 texel)   - texel n - u_shift, for GL_MAX blending
//   vec2 resolve(ivec2 cell)    - a window cell: (horizon per unit step, sector)
// The "where" codes and the arithmetic are those of radial_sweep.cpp, which
// these functions mirror line for line (its comments explain them).
#pragma once

namespace horizon::visibility::gl_shaders {

// Shared declarations and the sampling functions.
inline constexpr const char* kCommon = R"GLSL(
#version 430 core
const float kNoHorizon = -1.0e30;
struct Sector {
  int rows, dir, line0, lines, ray_half, base, u_count, v_count, j_max, steps_at, dv_at, d_at;
  float k0, eye_v, v_min, v_max, curvature, mu2, mv2, pad1;
};
layout(std430, binding = 0) readonly buffer Sectors { Sector sectors[4]; };
// Per disk row (ray): slope, 1/slope, curvature per unit step. Per sector and
// step (at steps_at): k, k - 1, 1/k (float division), 1/k (from double), and
// the first and last v position the sector owns on that line. Per sector and
// v position (at dv_at): 1 / (v - eye_v).
layout(std430, binding = 1) readonly buffer Tables { float table[]; };
// Per sector (at d_at): eye_v, then 1/k per step, in double: which two rays
// bracket a cell is decided as the CPU decides it, ties included.
layout(std430, binding = 2) readonly buffer Doubles { double dtable[]; };
uniform sampler2D u_terrain;  // R32F, window-sized; voids hold -3e38
uniform sampler2D u_disk;     // RG32F disk being propagated, or the horizons (resolve)
uniform int u_sectors, u_rows, u_shift, u_blend;  // u_blend: 0 linear, 1 min, 2 resample
uniform float u_eye_hi, u_eye_lo, u_eye_x, u_eye_y;

float ray_slope(int row) { return table[row]; }
float ray_inv_slope(int row) { return table[u_rows + row]; }
float ray_curv_k(int row) { return table[2 * u_rows + row]; }
const int kStepFields = 6;
float step_k(Sector s, int n) { return table[s.steps_at + kStepFields * n]; }
float step_kp(Sector s, int n) { return table[s.steps_at + kStepFields * n + 1]; }
float step_inv_kf(Sector s, int n) { return table[s.steps_at + kStepFields * n + 2]; }
float step_inv(Sector s, int n) { return table[s.steps_at + kStepFields * n + 3]; }
bool owns(Sector s, int n, int j) {
  return n >= 0 && n < s.lines && float(j) >= table[s.steps_at + kStepFields * n + 4] &&
         float(j) <= table[s.steps_at + kStepFields * n + 5];
}
float inv_dv(Sector s, int v) { return table[s.dv_at + v]; }

float z_at(Sector s, int line, int v) {
  return texelFetch(u_terrain, s.rows != 0 ? ivec2(v, line) : ivec2(line, v), 0).r;
}
bool is_void(float a, float b) { return a < -1.0e38 || b < -1.0e38; }
float eye_relative(float a, float b, float t) {
  precise float r = ((a - u_eye_hi) - u_eye_lo) + t * (b - a);
  return r;
}
int sector_of_row(int row) {
  int s = 0;
  while (s + 1 < u_sectors && row >= sectors[s + 1].base) ++s;
  return s;
}
// A ray's crossing of a v grid line strictly inside step n, if any.
vec2 cross_sample(Sector s, int row, int n) {
  float m = ray_slope(row);
  float kf = step_k(s, n), kp = step_kp(s, n), k_start = max(kp, 0.0);
  float v_start = s.eye_v + m * k_start, v_end = s.eye_v + m * kf;
  float up = floor(v_start) + 1.0, down = ceil(v_start) - 1.0;
  float cv = m > 0.0 ? up : down;
  bool crosses = (m > 0.0 && up < v_end) || (m < 0.0 && down > v_end);
  if (!crosses || cv < s.v_min || cv > s.v_max) return vec2(kNoHorizon, -1.0);
  int jc = int(cv);
  float kc = max((cv - s.eye_v) * ray_inv_slope(row), 1.0e-6);
  float tc = kc - kp;
  int line = s.line0 + s.dir * n;
  int prev = clamp(line - s.dir, 0, s.u_count - 1);
  float pa = z_at(s, prev, jc), pb = z_at(s, line, jc);
  if (is_void(pa, pb)) return vec2(kNoHorizon, -1.0);
  return vec2(eye_relative(pa, pb, tc) / kc - ray_curv_k(row) * kc, float(-2 - jc));
}
// The ray's crossing of the line at step n itself.
vec2 line_sample(Sector s, int row, int n) {
  float kf = step_k(s, n);
  float v = min(max(s.eye_v + ray_slope(row) * kf, s.v_min), s.v_max);
  int j0 = min(int(v), s.j_max);
  float t = v - float(j0);
  int line = s.line0 + s.dir * n;
  float a = z_at(s, line, j0), b = z_at(s, line, min(j0 + 1, s.v_count - 1));
  if (is_void(a, b)) return vec2(kNoHorizon, -1.0);
  return vec2(eye_relative(a, b, t) * step_inv_kf(s, n) - ray_curv_k(row) * kf, float(n));
}

vec2 modulate(ivec2 texel) {
  int n = texel.x, row = texel.y;
  Sector s = sectors[sector_of_row(row)];
  if (n >= s.lines) return vec2(kNoHorizon, -1.0);
  vec2 c = cross_sample(s, row, n), l = line_sample(s, row, n);
  return l.x > c.x ? l : c;  // the earlier sample wins ties, as in the CPU's fold
}

vec2 propagate(ivec2 texel) {
  vec2 here = texelFetch(u_disk, texel, 0).xy;
  if (texel.x < u_shift) return here;
  vec2 before = texelFetch(u_disk, ivec2(texel.x - u_shift, texel.y), 0).xy;
  return here.x > before.x ? here : before;
}

// The disk moved u_shift texels away from the eye, for GL_MAX blending onto
// itself (the horizon value only: blending keeps each channel's maximum
// separately, so "where" does not survive it).
vec2 shifted(ivec2 texel) {
  if (texel.x < u_shift) return vec2(kNoHorizon, -1.0);
  return texelFetch(u_disk, ivec2(texel.x - u_shift, texel.y), 0).xy;
}

// Re-sampling a cell's own sight line (RayBlend::kResample).
struct CellRay { float m, inv_m, curv_k; int own_v; float k; };
float sample_u(Sector s, CellRay c, int n) {
  float kn = s.k0 + float(n);
  float v = min(max(s.eye_v + c.m * kn, s.v_min), s.v_max);
  int j0 = min(int(v), s.j_max);
  float t = v - float(j0);
  int line = s.line0 + s.dir * n;
  float a = z_at(s, line, j0), b = z_at(s, line, min(j0 + 1, s.v_count - 1));
  if (is_void(a, b)) return kNoHorizon;
  return eye_relative(a, b, t) * step_inv(s, n) - c.curv_k * kn;
}
float sample_v(Sector s, CellRay c, int vline) {
  if (c.inv_m == 0.0 || vline == c.own_v) return kNoHorizon;
  float kc = (float(vline) - s.eye_v) * c.inv_m;
  if (!(kc > 0.0 && kc < c.k)) return kNoHorizon;
  float x = kc - s.k0;
  int n1 = int(floor(x));
  float t = x - float(n1);
  int la = clamp(s.line0 + s.dir * n1, 0, s.u_count - 1);
  int lb = clamp(s.line0 + s.dir * (n1 + 1), 0, s.u_count - 1);
  float a = z_at(s, la, vline), b = z_at(s, lb, vline);
  if (is_void(a, b)) return kNoHorizon;
  return eye_relative(a, b, t) * (c.m * inv_dv(s, vline)) - c.curv_k * kc;
}
float sample_at(Sector s, CellRay c, int where) {
  if (where >= 0) return sample_u(s, c, where);
  if (where <= -2) return sample_v(s, c, -2 - where);
  return kNoHorizon;
}

// The sector owning a cell, as the CPU's per-line ranges assign it
// (north/south own the diagonals); -1 for the eye's own cell.
int owner(ivec2 cell, float dc, float dr) {
  for (int i = 0; i < u_sectors; ++i) {
    Sector s = sectors[i];
    float du = s.rows != 0 ? dr : dc;
    if (du == 0.0 || (du > 0.0 ? 1 : -1) != s.dir) continue;
    int line = s.rows != 0 ? cell.y : cell.x, j = s.rows != 0 ? cell.x : cell.y;
    if (owns(s, (line - s.line0) * s.dir, j)) return i;
  }
  return -1;
}

vec2 resolve(ivec2 cell) {
  float dc = float(cell.x) - u_eye_x, dr = float(cell.y) - u_eye_y;
  int si = owner(cell, dc, dr);
  if (si < 0) return vec2(kNoHorizon, -1.0);
  Sector s = sectors[si];
  bool rows = s.rows != 0;
  int line = rows ? cell.y : cell.x, j = rows ? cell.x : cell.y;
  int n = (line - s.line0) * s.dir;
  float kf = step_k(s, n);
  float dj = float(j) - s.eye_v;
  precise double rho_d = (double(j) - dtable[s.d_at]) * dtable[s.d_at + 1 + n] * double(s.ray_half);
  int r = clamp(int(floor(rho_d)), -s.ray_half, s.ray_half - 1);
  float rho = float(rho_d - double(r));  // the fraction past ray r
  int row0 = s.base + r + s.ray_half, row1 = row0 + 1;
  vec2 h0 = n > 0 ? texelFetch(u_disk, ivec2(n - 1, row0), 0).xy : vec2(kNoHorizon, -1.0);
  vec2 h1 = n > 0 ? texelFetch(u_disk, ivec2(n - 1, row1), 0).xy : vec2(kNoHorizon, -1.0);
  vec2 c0 = cross_sample(s, row0, n), c1 = cross_sample(s, row1, n);
  float hz;
  if (u_blend == 2) {
    int a0 = int(c0.x > h0.x ? c0.y : h0.y);
    int a1 = int(c1.x > h1.x ? c1.y : h1.y);
    float m = dj / kf;
    CellRay c = CellRay(m, kf * inv_dv(s, j), s.curvature * (s.mu2 + m * m * s.mv2), j, kf);
    float best = kNoHorizon;
    if (n > 0) { float x = sample_u(s, c, n - 1); best = x > best ? x : best; }
    if (a0 != n - 1) { float x = sample_at(s, c, a0); best = x > best ? x : best; }
    if (a1 != a0 && a1 != n - 1) { float x = sample_at(s, c, a1); best = x > best ? x : best; }
    hz = best;
  } else {
    float x0 = h0.x, x1 = h1.x;
    if (int(c0.y) != -2 - j && c0.x > x0) x0 = c0.x;
    if (int(c1.y) != -2 - j && c1.x > x1) x1 = c1.x;
    float f = clamp(rho, 0.0, 1.0);
    hz = u_blend == 1 ? min(x0, x1) : x0 + f * (x1 - x0);
  }
  return vec2(hz, float(si));
}
)GLSL";

// A full-screen triangle; the fragment stages index texels by gl_FragCoord.
inline constexpr const char* kVertex = R"GLSL(
#version 430 core
void main() {
  vec2 p = vec2(float((gl_VertexID & 1) << 2) - 1.0, float((gl_VertexID & 2) << 1) - 1.0);
  gl_Position = vec4(p, 0.0, 1.0);
}
)GLSL";

// Fragment form: `PASS` is modulate, propagate or resolve.
inline constexpr const char* kFragmentMain = R"GLSL(
layout(location = 0) out vec2 o_value;
void main() { o_value = PASS(ivec2(gl_FragCoord.xy)); }
)GLSL";

// Compute form of the same passes, writing u_out.
inline constexpr const char* kComputeMain = R"GLSL(
layout(local_size_x = 16, local_size_y = 16) in;
layout(rg32f, binding = 0) writeonly uniform image2D u_out;
uniform ivec2 u_size;
void main() {
  ivec2 p = ivec2(gl_GlobalInvocationID.xy);
  if (p.x >= u_size.x || p.y >= u_size.y) return;
  imageStore(u_out, p, vec4(PASS(p), 0.0, 0.0));
}
)GLSL";

// Compute form of one-texel propagation: each invocation carries one ray's
// running maximum outward through every step (N shifts in one dispatch).
inline constexpr const char* kComputeScan = R"GLSL(
layout(local_size_x = 64) in;
layout(rg32f, binding = 0) writeonly uniform image2D u_out;
uniform ivec2 u_size;
void main() {
  int row = int(gl_GlobalInvocationID.x);
  if (row >= u_size.y) return;
  vec2 best = vec2(kNoHorizon, -1.0);
  for (int n = 0; n < u_size.x; ++n) {
    vec2 here = texelFetch(u_disk, ivec2(n, row), 0).xy;
    best = here.x > best.x ? here : best;
    imageStore(u_out, ivec2(n, row), vec4(best, 0.0, 0.0));
  }
}
)GLSL";

}  // namespace horizon::visibility::gl_shaders
