// The GL trace (trace_gl.hpp), after Sakalauskas, "Silhouette Partitioning
// for Height Field Ray Tracing", sections 4.1.4-6.1.1: per sub-frustum, the
// DEM's lines drawn as line strips into the silhouette map, the pair levels
// built by fragment passes, one full-screen pass tracing every pixel.
#include "trace_gl.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "gpu/gl_helpers.hpp"
#include "trace_gl_shaders.hpp"

namespace horizon::trace::detail {
namespace {

using gpu::compile_shader;
using gpu::gl_status;
using gpu::link_program;
using gpu::set_uniform;

constexpr float kVoidMark = -3.0e38f;  // a void in the terrain texture
constexpr int kMaxLevels = 8;          // the trace shader's sampler array: 4^8 = 65 536 lines

// One context's programs and images, compiled once and grown on demand.
struct TraceGlResources final : gpu::ContextResources {
  GLuint map_program = 0, tree_program = 0, trace_program = 0;
  GLuint vao = 0, fbo = 0;
  gpu::Texture2D terrain{GL_R32F}, map{GL_R32F}, out{GL_RG32F};
  gpu::Texture2D levels[kMaxLevels] = {
      gpu::Texture2D{GL_RGBA32F}, gpu::Texture2D{GL_RGBA32F}, gpu::Texture2D{GL_RGBA32F}, gpu::Texture2D{GL_RGBA32F},
      gpu::Texture2D{GL_RGBA32F}, gpu::Texture2D{GL_RGBA32F}, gpu::Texture2D{GL_RGBA32F}, gpu::Texture2D{GL_RGBA32F}};
  gpu::StorageBuffer columns, map_columns;
  std::vector<float> staging, column_table, map_column_table, readback;
  std::string error;

  TraceGlResources() {
    std::string log;
    const GLuint mv = compile_shader(GL_VERTEX_SHADER, gl_shaders::kMapVertex, log);
    const GLuint mf = mv ? compile_shader(GL_FRAGMENT_SHADER, gl_shaders::kMapFragment, log) : 0;
    map_program = mf ? link_program({mv, mf}, log) : 0;
    if (map_program) {
      const GLuint sv = compile_shader(GL_VERTEX_SHADER, gl_shaders::kScreenVertex, log);
      const GLuint tf = sv ? compile_shader(GL_FRAGMENT_SHADER, gl_shaders::kTreeFragment, log) : 0;
      tree_program = tf ? link_program({sv, tf}, log) : 0;
    }
    if (tree_program) {
      const GLuint sv = compile_shader(GL_VERTEX_SHADER, gl_shaders::kScreenVertex, log);
      const GLuint rf = sv ? compile_shader(GL_FRAGMENT_SHADER, gl_shaders::kTraceFragment, log) : 0;
      trace_program = rf ? link_program({sv, rf}, log) : 0;
    }
    if (!trace_program) error = "gpu: the trace's shaders do not build: " + log;
    glGenVertexArrays(1, &vao);
    glGenFramebuffers(1, &fbo);
  }
  // Images, buffers and the host copies (staging, tables, read-back).
  std::uint64_t image_bytes() const override {
    std::uint64_t bytes = terrain.bytes() + map.bytes() + out.bytes() + columns.held() + map_columns.held();
    for (const gpu::Texture2D& level : levels) bytes += level.bytes();
    for (const std::vector<float>* v : {&staging, &column_table, &map_column_table, &readback})
      bytes += v->capacity() * sizeof(float);
    return bytes;
  }
  void release_images() override {
    for (gpu::Texture2D* t : {&terrain, &map, &out}) t->release();
    for (gpu::Texture2D& level : levels) level.release();
    columns.release();
    map_columns.release();
    for (std::vector<float>* v : {&staging, &column_table, &map_column_table, &readback}) std::vector<float>().swap(*v);
  }
  ~TraceGlResources() override {
    glDeleteProgram(map_program);
    glDeleteProgram(tree_program);
    glDeleteProgram(trace_program);
    glDeleteVertexArrays(1, &vao);
    glDeleteFramebuffers(1, &fbo);
  }
};

void target(GLuint fbo, const gpu::Texture2D& texture, int width, int height) {
  glBindFramebuffer(GL_FRAMEBUFFER, fbo);
  glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, texture.texture, 0);
  glViewport(0, 0, width, height);
}

void bind(GLuint program, const char* name, int unit, const gpu::Texture2D& texture) {
  glActiveTexture(GL_TEXTURE0 + static_cast<GLenum>(unit));
  glBindTexture(GL_TEXTURE_2D, texture.texture);
  set_uniform(program, name, unit);
}

}  // namespace

Status trace_gl(const terrain::HeightView& view, const Camera& camera, const FrameGeometry& g,
                const TraceOptions& options, gpu::Lease& lease, const RunControl* control, TraceImage& image,
                TraceStats& stats) {
  if (camera.spec.projection != Projection::kPerspective)
    return make_error(ErrorCode::kUnsupported,
                      "the GL trace draws lines through a pinhole; a cylindrical camera is traced on the CPU",
                      "projection");
  if (options.column_crossings)
    return make_error(ErrorCode::kUnsupported, "the GL trace tests row crossings only; --columns is traced on the CPU",
                      "column_crossings");
  const int limit = lease.device().max_texture_size;
  int widest = 0, most_lines = 0;
  for (const Run& run : g.runs) {
    widest = std::max(widest, run.x1 - run.x0);
    most_lines = std::max(most_lines, run.primary.count);
  }
  if (view.width() > limit || view.height() > limit || widest > limit || most_lines > limit ||
      camera.spec.height > limit || most_lines > (1 << (2 * kMaxLevels)))
    return make_error(ErrorCode::kResourceExhausted,
                      "gpu: a frame over " + std::to_string(view.width()) + "x" + std::to_string(view.height()) +
                          " cells needs textures beyond this device's " + std::to_string(limit) + " texels a side",
                      "gpu");
  auto fail = [&lease](Status status) {
    lease.fail();
    return status;
  };
  auto& gl = lease.resources<TraceGlResources>();
  if (!gl.error.empty()) return fail(make_error(ErrorCode::kInternal, gl.error, "gpu"));

  // What this frame grows the context's images (and host copies) to, asked
  // for before any is allocated: the largest run's map, levels and target.
  const int width = camera.spec.width, height = camera.spec.height;
  {
    using gpu::vector_bytes_after;
    const auto w = static_cast<std::size_t>(width);
    std::uint64_t images = gl.terrain.bytes_after(view.width(), view.height()) +
                           gl.map.bytes_after(widest, std::max(most_lines, 1)) + gl.out.bytes_after(widest, height) +
                           gl.columns.held_after(2 * w * sizeof(float)) +
                           gl.map_columns.held_after(3 * w * sizeof(float)) + vector_bytes_after(gl.staging, view.cell_count()) +
                           vector_bytes_after(gl.column_table, 2 * w) + vector_bytes_after(gl.map_column_table, 3 * w) +
                           vector_bytes_after(gl.readback, 2 * static_cast<std::size_t>(widest) * static_cast<std::size_t>(height));
    int nodes[kMaxLevels] = {};  // each level's rows; 0 past the top
    for (int below = most_lines, l = 0; below > 0 && l < kMaxLevels; ++l) {
      nodes[l] = (below + 3) / 4;
      if (nodes[l] == 1) break;
      below = nodes[l];
    }
    for (int l = 0; l < kMaxLevels; ++l) images += gl.levels[l].bytes_after(nodes[l] ? widest : 0, nodes[l]);
    HORIZON_RETURN_IF_ERROR(lease.grow_images(gl, images,
                                              "a " + std::to_string(width) + "x" + std::to_string(height) +
                                                  " frame over " + std::to_string(view.width()) + "x" +
                                                  std::to_string(view.height()) + " cells"));
  }

  // The view, voids marked (the shader fills or skips them), and the columns' constants.
  gl.terrain.ensure(view.width(), view.height());
  gl.staging.resize(view.cell_count());
  for (int r = 0; r < view.height(); ++r) {
    const float* src = view.row(r);
    float* dst = gl.staging.data() + static_cast<std::size_t>(r) * static_cast<std::size_t>(view.width());
    for (int c = 0; c < view.width(); ++c) dst[c] = src[c] == src[c] ? src[c] : kVoidMark;
  }
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  glBindTexture(GL_TEXTURE_2D, gl.terrain.texture);
  glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, view.width(), view.height(), GL_RED, GL_FLOAT, gl.staging.data());
  gl.column_table.resize(2 * static_cast<std::size_t>(width));
  for (int x = 0; x < width; ++x) {
    gl.column_table[2 * static_cast<std::size_t>(x)] = g.inv_focal_col[static_cast<std::size_t>(x)];
    gl.column_table[2 * static_cast<std::size_t>(x) + 1] = g.dist_per_t[static_cast<std::size_t>(x)];
  }
  gl.columns.upload(0, gl.column_table.data(), gl.column_table.size() * sizeof(float));
  gl.map_column_table.resize(3 * static_cast<std::size_t>(width));
  for (int x = 0; x < width; ++x) {
    const auto i = static_cast<std::size_t>(x);
    gl.map_column_table[3 * i] = g.pos_per_t[i];
    gl.map_column_table[3 * i + 1] = g.dist_per_t[i];
    gl.map_column_table[3 * i + 2] = g.near[i];
  }
  gl.map_columns.upload(1, gl.map_column_table.data(), gl.map_column_table.size() * sizeof(float));
  if (auto s = gl_status("the trace's upload"); !s.ok()) return fail(s);

  const double yaw = camera.spec.yaw * M_PI / 180.0;
  glBindVertexArray(gl.vao);
  glDisable(GL_DEPTH_TEST);
  glDisable(GL_BLEND);
  for (const Run& run : g.runs) {
    HORIZON_RETURN_IF_ERROR(check_control(control));
    const LineFamily& f = run.primary;
    const int run_width = run.x1 - run.x0, lines = f.count;
    stats.crossings += static_cast<std::uint64_t>(run_width) * static_cast<std::uint64_t>(lines);
    stats.max_lines = std::max(stats.max_lines, lines);

    // 1. The silhouette map: one line strip a line, into run_width x lines texels.
    const int map_rows = std::max(lines, 1);
    gl.map.ensure(run_width, map_rows);
    target(gl.fbo, gl.map, run_width, map_rows);
    const float none = -std::numeric_limits<float>::infinity();
    glClearBufferfv(GL_COLOR, 0, &none);
    if (lines > 0) {
      const GLuint p = gl.map_program;
      glUseProgram(p);
      bind(p, "u_terrain", 0, gl.terrain);
      set_uniform(p, "u_rows", f.axis == LineAxis::kRows ? 1 : 0);
      set_uniform(p, "u_first", f.first);
      set_uniform(p, "u_step", f.step);
      set_uniform(p, "u_pos_count", f.pos_count);
      set_uniform(p, "u_x0", run.x0);
      set_uniform(p, "u_t0", f.t0);
      set_uniform(p, "u_eye_along", f.eye_along);
      set_uniform(p, "u_eye_z", g.eye_z);
      set_uniform(p, "u_curvature", g.curvature);
      set_uniform(p, "u_far", g.far);
      const bool fill = g.fill == g.fill;
      set_uniform(p, "u_fill", fill ? g.fill : 0.0f);
      set_uniform(p, "u_fill_voids", fill ? 1 : 0);
      // The drawn segment: the line's trace on the ground, a line's length past each end.
      set_uniform(p, "u_along0", static_cast<float>(-f.pos_count));
      set_uniform(p, "u_along1", static_cast<float>(2 * f.pos_count));
      glUniform2f(glGetUniformLocation(p, "u_eye"), static_cast<float>(camera.eye.col),
                  static_cast<float>(camera.eye.row));
      set_uniform(p, "u_per_col", static_cast<float>(camera.metres_per_col));
      set_uniform(p, "u_per_row", static_cast<float>(camera.metres_per_row));
      glUniform2f(glGetUniformLocation(p, "u_forward"), static_cast<float>(std::sin(yaw)),
                  static_cast<float>(std::cos(yaw)));
      glUniform2f(glGetUniformLocation(p, "u_right"), static_cast<float>(std::cos(yaw)),
                  static_cast<float>(-std::sin(yaw)));
      set_uniform(p, "u_focal", static_cast<float>(camera.focal));
      set_uniform(p, "u_cx", static_cast<float>(camera.cx - run.x0));
      set_uniform(p, "u_width", static_cast<float>(run_width));
      set_uniform(p, "u_lines", static_cast<float>(lines));
      // Clipped at half the near plane: the fragment holds the exact limit.
      set_uniform(p, "u_near", static_cast<float>(0.5 * options.near));
      glDrawArraysInstanced(GL_TRIANGLE_STRIP, 0, 4, lines);
    }

    // 2. The pair levels, each from the one below.
    int below = lines, levels = 0;
    while (below > 0 && levels < kMaxLevels) {
      const int nodes = (below + 3) / 4;
      gpu::Texture2D& level = gl.levels[levels];
      level.ensure(run_width, nodes);
      glMemoryBarrier(GL_TEXTURE_FETCH_BARRIER_BIT | GL_FRAMEBUFFER_BARRIER_BIT);
      target(gl.fbo, level, run_width, nodes);
      const GLuint p = gl.tree_program;
      glUseProgram(p);
      bind(p, "u_below", 0, levels == 0 ? gl.map : gl.levels[levels - 1]);
      set_uniform(p, "u_below_count", below);
      set_uniform(p, "u_from_map", levels == 0 ? 1 : 0);
      glDrawArrays(GL_TRIANGLES, 0, 3);
      stats.tree_texels += static_cast<std::uint64_t>(run_width) * static_cast<std::uint64_t>(nodes);
      ++levels;
      if (nodes == 1) break;
      below = nodes;
    }
    stats.reads_per_pixel = std::max(stats.reads_per_pixel, levels + 2);

    // 3. The trace: a fragment a pixel.
    gl.out.ensure(run_width, height);
    glMemoryBarrier(GL_TEXTURE_FETCH_BARRIER_BIT | GL_FRAMEBUFFER_BARRIER_BIT);
    target(gl.fbo, gl.out, run_width, height);
    const GLuint p = gl.trace_program;
    glUseProgram(p);
    bind(p, "u_map", 0, gl.map);
    for (int l = 0; l < kMaxLevels; ++l) {
      const std::string name = "u_levels[" + std::to_string(l) + "]";
      bind(p, name.c_str(), 1 + l, gl.levels[std::min(l, std::max(levels - 1, 0))]);
    }
    set_uniform(p, "u_level_count", levels);
    set_uniform(p, "u_cy", g.cy);
    set_uniform(p, "u_t0", f.t0);
    set_uniform(p, "u_x0", run.x0);
    glDrawArrays(GL_TRIANGLES, 0, 3);
    gl.readback.resize(2 * static_cast<std::size_t>(run_width) * static_cast<std::size_t>(height));
    glReadPixels(0, 0, run_width, height, GL_RG, GL_FLOAT, gl.readback.data());
    if (auto s = gl_status("the trace's passes"); !s.ok()) return fail(s);

    for (int y = 0; y < height; ++y) {
      const int j = height - 1 - y;  // the target's rows run up from the image's bottom
      for (int x = 0; x < run_width; ++x) {
        const float* hit =
            gl.readback.data() + 2 * (static_cast<std::size_t>(y) * run_width + static_cast<std::size_t>(x));
        const std::size_t at =
            static_cast<std::size_t>(j) * static_cast<std::size_t>(width) + static_cast<std::size_t>(run.x0 + x);
        const bool sky = !(hit[1] >= 0.0f);
        image.distance[at] = sky ? std::numeric_limits<float>::infinity() : hit[0];
        image.line[at] = sky ? -1 : f.first + f.step * static_cast<int>(hit[1]);
        image.axis[at] = sky ? LineAxis::kRows : f.axis;
        stats.sky_pixels += sky;
      }
    }
  }
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  return Status::Ok();
}

}  // namespace horizon::trace::detail
