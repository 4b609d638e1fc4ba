// Private to core/trace: the GLSL of the GL trace (trace_gl.cpp), the
// paper's GPU design (Sakalauskas, sections 4.1.4, 5 and 6.1.1):
//
//  * kMapVertex/kMapFragment: every DEM line of a sub-frustum drawn as a
//    line (one instanced draw: an instance a line) into the silhouette-map
//    target, one texel row per line, one texel column per screen column:
//    the paper's section 6.1.2 with one segment a line, drawn as a quad one
//    texel tall (a GL line's diamond-exit rule drops the column at a
//    viewport's edge; a quad covers every texel centre it spans). The vertex shader
//    projects the line's ends with the pinhole (clip w = forward distance,
//    so GL clips at the near plane); the rasteriser gives each screen column
//    the line covers one fragment, and the fragment shader finds that
//    column's crossing and its slope itself, as the CPU does (the paper's
//    per-fragment search, done directly). A line's projection on a pinhole
//    is a straight segment whatever the heights on it, so the segment
//    drawn is the line's ground trace, extended a whole line's length past
//    both ends: every column whose crossing lies on the DEM gets its
//    fragment, and the fragment refuses the rest. The target is cleared to
//    "no crossing" first.
//  * kTreeFragment: one pass per pair level into its own RGBA32F target:
//    R = max(q0), G = max(q2), B = max(q0, q1), A = max(q0..q3) of the four
//    children below (the map's lines, then the previous level's A).
//  * kTraceFragment: one full-screen pass, a pixel a fragment: the descent
//    through the pair levels, the two map reads and the chord, as
//    silhouette.cpp and trace.cpp do on the CPU; out: the hit's ground
//    distance and its line (or +inf and -1 for sky).
#pragma once

namespace horizon::trace::detail::gl_shaders {

inline constexpr const char* kMapVertex = R"GLSL(
#version 430 core
uniform int u_rows;           // 1: the lines are rows (position along = column); 0: columns
uniform int u_first, u_step;
uniform float u_along0, u_along1;  // the segment drawn for a line: along-line positions (cells)
uniform vec2 u_eye;           // the eye in the view's grid
uniform float u_per_col, u_per_row;
uniform vec2 u_forward, u_right;  // the camera's axes on the ground, (east, north)
uniform float u_focal, u_cx, u_width, u_lines, u_near;
void main() {
  int k = gl_InstanceID;
  float line = float(u_first + u_step * k);
  // A strip of four corners: the line's two ends, each at the bottom and top of its texel row.
  float along = gl_VertexID < 2 ? u_along0 : u_along1;
  float row = float(k) + float(gl_VertexID & 1);
  vec2 cell = u_rows == 1 ? vec2(along, line) : vec2(line, along);
  vec2 ground = vec2((cell.x - u_eye.x) * u_per_col, (u_eye.y - cell.y) * u_per_row);
  float w = dot(ground, u_forward);
  float x_cam = dot(ground, u_right);
  // Screen x in the target's pixels: u_cx + f x_cam / w; NDC = 2 x / width - 1.
  float x_clip = (2.0 * u_cx / u_width - 1.0) * w + 2.0 * u_focal * x_cam / u_width;
  float y_clip = (2.0 * row / u_lines - 1.0) * w;
  gl_Position = vec4(x_clip, y_clip, w - 2.0 * u_near, w);  // z in [-w, w] exactly when w >= near
}
)GLSL";

// crossing_slope (frustum.hpp), operation for operation: the column's
// crossing of line k, its two cells, and the slope; `precise` keeps the
// compiler from fusing or reordering, so the map holds the CPU's bits.
inline constexpr const char* kMapFragment = R"GLSL(
#version 430 core
uniform sampler2D u_terrain;  // the view, R32F; voids hold a value below -1e38
uniform int u_rows, u_first, u_step, u_pos_count, u_x0;
uniform float u_t0, u_eye_along, u_eye_z, u_curvature, u_far, u_fill;
uniform int u_fill_voids;
// Per screen column: pos_per_t, dist_per_t, near (frustum.hpp's tables).
layout(std430, binding = 1) readonly buffer MapColumns { float map_columns[]; };
layout(location = 0) out float o_slope;
void main() {
  ivec2 p = ivec2(gl_FragCoord.xy);  // (column in the sub-frustum, line k)
  int x = u_x0 + p.x, k = p.y;
  float pos_per_t = map_columns[3 * x], dist_per_t = map_columns[3 * x + 1], near = map_columns[3 * x + 2];
  precise float t = float(k) + u_t0;
  precise float pos = u_eye_along + t * pos_per_t;
  precise float d = t * dist_per_t;
  if (!(d >= near && d <= u_far && pos >= 0.0 && pos <= float(u_pos_count - 1))) discard;
  int i = min(int(floor(pos)), u_pos_count - 2);
  precise float f = pos - float(i);
  int line = u_first + u_step * k;
  ivec2 c0 = u_rows == 1 ? ivec2(i, line) : ivec2(line, i);
  ivec2 c1 = u_rows == 1 ? ivec2(i + 1, line) : ivec2(line, i + 1);
  float h0 = texelFetch(u_terrain, c0, 0).r, h1 = texelFetch(u_terrain, c1, 0).r;
  if (h0 < -1.0e38 || h1 < -1.0e38) {
    if (u_fill_voids == 0) discard;  // transparent: the cleared "no crossing" stays
    if (h0 < -1.0e38) h0 = u_fill;
    if (h1 < -1.0e38) h1 = u_fill;
  }
  precise float z = h0 + f * (h1 - h0);
  precise float s = ((z - u_eye_z) - u_curvature * d * d) / d;
  o_slope = s;
}
)GLSL";

// Full-screen triangle for the tree and trace passes.
inline constexpr const char* kScreenVertex = R"GLSL(
#version 430 core
void main() {
  vec2 p = vec2(float((gl_VertexID & 1) << 2) - 1.0, float((gl_VertexID & 2) << 1) - 1.0);
  gl_Position = vec4(p, 0.0, 1.0);
}
)GLSL";

inline constexpr const char* kTreeFragment = R"GLSL(
#version 430 core
uniform sampler2D u_below;  // the map (its R), or the previous pair level (its A)
uniform int u_below_count;  // rows of u_below in use
uniform int u_from_map;
layout(location = 0) out vec4 o_texel;
float child(int x, int c) {
  if (c >= u_below_count) return uintBitsToFloat(0xff800000u);
  vec4 t = texelFetch(u_below, ivec2(x, c), 0);
  return u_from_map == 1 ? t.r : t.a;
}
void main() {
  ivec2 p = ivec2(gl_FragCoord.xy);
  float q0 = child(p.x, 4 * p.y), q1 = child(p.x, 4 * p.y + 1);
  float q2 = child(p.x, 4 * p.y + 2), q3 = child(p.x, 4 * p.y + 3);
  float ab = q0 < q1 ? q1 : q0, cd = q2 < q3 ? q3 : q2;
  o_texel = vec4(q0, q2, ab, ab < cd ? cd : ab);
}
)GLSL";

inline constexpr const char* kTraceFragment = R"GLSL(
#version 430 core
uniform sampler2D u_map;
uniform sampler2D u_levels[8];  // pair levels 1..u_level_count
uniform int u_level_count;
uniform float u_cy, u_t0;
uniform int u_x0;               // the sub-frustum's first screen column
layout(std430, binding = 0) readonly buffer Columns { vec2 columns[]; };  // (1 / f_col, metres per line)
layout(location = 0) out vec2 o_hit;
void main() {
  ivec2 p = ivec2(gl_FragCoord.xy);  // x in the sub-frustum, y up from the image's bottom row
  vec2 col = columns[u_x0 + p.x];
  float s = (float(p.y) + 0.5 - u_cy) * col.x;
  float inf = uintBitsToFloat(0x7f800000u), none = uintBitsToFloat(0xff800000u);
  if (u_level_count == 0) { o_hit = vec2(inf, -1.0); return; }
  int node = 0;
  float root = 0.0;
  for (int l = 7; l >= 0; --l) {
    if (l >= u_level_count) continue;
    vec4 t = texelFetch(u_levels[l], ivec2(p.x, node), 0);
    if (l == u_level_count - 1) {
      root = t.a;
      if (!(s <= root)) { o_hit = vec2(inf, -1.0); return; }
    }
    int q = s <= t.b ? (s <= t.r ? 0 : 1) : (s <= t.g ? 2 : 3);
    node = node * 4 + q;
  }
  float s1 = texelFetch(u_map, ivec2(p.x, node), 0).r;
  float s0 = node > 0 ? texelFetch(u_map, ivec2(p.x, node - 1), 0).r : none;
  float d1 = (float(node) + u_t0) * col.y;
  float d = d1;
  if (s0 > none) {
    float d0 = (float(node - 1) + u_t0) * col.y;
    float z0 = s0 * d0, z1 = s1 * d1;
    float denom = (z1 - z0) - s * (d1 - d0);
    if (denom > 0.0) d = d0 + clamp((s * d0 - z0) / denom, 0.0, 1.0) * (d1 - d0);
  }
  o_hit = vec2(d, float(node));
}
)GLSL";

}  // namespace horizon::trace::detail::gl_shaders
