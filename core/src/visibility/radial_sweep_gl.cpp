// The fast occlusion height field as GL passes on an EGL context (see
// radial_sweep_gl.hpp), after US patent 7,027,046 (Benton et al., "Occlusion
// height field"): the GPU form of radial_sweep.cpp.
#include "horizon/visibility/radial_sweep_gl.hpp"

#include <algorithm>
#include <barrier>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <thread>
#include <vector>

#include "gpu/gl_helpers.hpp"
#include "horizon/common/parallel.hpp"
#include "radial_sweep_gl_disk.hpp"
#include "radial_sweep_gl_shaders.hpp"
#include "sweep_geometry.hpp"

namespace horizon::visibility {
namespace {

using gpu::compile_shader;
using gpu::gl_status;
using gpu::link_program;
using gpu::set_uniform;

constexpr float kNoHorizon = -1.0e30f;  // as radial_sweep.cpp
constexpr float kVoid = -3.0e38f;       // a void in the terrain texture

std::string with_pass(const char* main, const char* pass) {
  std::string source = std::string(gl_shaders::kCommon) + "#define PASS " + pass + "\n" + main;
  return source;
}

// The GL objects of one context: compiled once, grown on demand.
struct OhfResources final : gpu::ContextResources {
  GLuint fragment[4] = {};  // modulate, propagate, resolve, shifted (fragment only)
  GLuint compute[3] = {};
  GLuint scan = 0;
  GLuint vao = 0, fbo = 0, timers[2] = {};
  gpu::StorageBuffer sectors, table, doubles;  // bindings 0, 1, 2 of gl_shaders::kCommon
  gpu::Texture2D terrain{GL_R32F}, disk[2]{gpu::Texture2D{GL_RG32F}, gpu::Texture2D{GL_RG32F}}, out{GL_RG32F};
  std::string error;  // set when a program failed to build

  OhfResources() {
    const char* passes[3] = {"modulate", "propagate", "resolve"};
    std::string log;
    for (int i = 0; i < 3 && error.empty(); ++i) {
      GLuint vs = compile_shader(GL_VERTEX_SHADER, gl_shaders::kVertex, log);
      GLuint fs = vs ? compile_shader(GL_FRAGMENT_SHADER, with_pass(gl_shaders::kFragmentMain, passes[i]), log) : 0;
      fragment[i] = fs ? link_program({vs, fs}, log) : 0;
      GLuint cs =
          fragment[i] ? compile_shader(GL_COMPUTE_SHADER, with_pass(gl_shaders::kComputeMain, passes[i]), log) : 0;
      compute[i] = cs ? link_program({cs}, log) : 0;
      if (!compute[i]) error = std::string("gpu: the ") + passes[i] + " shader does not build: " + log;
    }
    if (error.empty()) {
      GLuint vs = compile_shader(GL_VERTEX_SHADER, gl_shaders::kVertex, log);
      GLuint fs = vs ? compile_shader(GL_FRAGMENT_SHADER, with_pass(gl_shaders::kFragmentMain, "shifted"), log) : 0;
      fragment[3] = fs ? link_program({vs, fs}, log) : 0;
      if (!fragment[3]) error = "gpu: the shift shader does not build: " + log;
    }
    if (error.empty()) {
      GLuint cs = compile_shader(GL_COMPUTE_SHADER, std::string(gl_shaders::kCommon) + gl_shaders::kComputeScan, log);
      scan = cs ? link_program({cs}, log) : 0;
      if (!scan) error = "gpu: the scan shader does not build: " + log;
    }
    glGenVertexArrays(1, &vao);
    glGenFramebuffers(1, &fbo);
    glGenQueries(2, timers);
  }
  std::uint64_t image_bytes() const override {
    return terrain.bytes() + disk[0].bytes() + disk[1].bytes() + out.bytes() + sectors.held() + table.held() +
           doubles.held();
  }
  void release_images() override {
    for (gpu::Texture2D* t : {&terrain, &disk[0], &disk[1], &out}) t->release();
    for (gpu::StorageBuffer* b : {&sectors, &table, &doubles}) b->release();
  }
  ~OhfResources() override {
    for (GLuint p : fragment) glDeleteProgram(p);
    for (GLuint p : compute) glDeleteProgram(p);
    glDeleteProgram(scan);
    glDeleteVertexArrays(1, &vao);
    glDeleteFramebuffers(1, &fbo);
    glDeleteQueries(2, timers);
  }
};

}  // namespace

namespace gl {

DiskPlan plan_disk(const ViewFrame& f, double ray_spacing) {
  const terrain::Window& w = f.window;
  DiskPlan plan;
  for (const sweep::SectorAxis axis : sweep::kSectorOrder) {
    DiskSector s;
    s.lines = sweep::sector_lines(f, axis);
    if (s.lines.lines <= 0) continue;
    s.ray_half = sweep::ray_half(s.lines.step(s.lines.lines - 1), ray_spacing);
    s.base = plan.rows;
    s.u_count = axis.rows ? w.height() : w.width();
    s.v_count = axis.rows ? w.width() : w.height();
    plan.rows += 2 * s.ray_half + 1;
    plan.width = std::max(plan.width, s.lines.lines);
    plan.sectors.push_back(s);
  }

  // Per disk row: the sector's ray table (the CPU sweep's, sweep_geometry.hpp).
  const double curvature = f.curvature;
  std::vector<float>& table = plan.table;
  std::vector<double>& doubles = plan.doubles;
  table.assign(3 * static_cast<std::size_t>(plan.rows), 0.0f);
  for (const DiskSector& s : plan.sectors) {
    const sweep::SectorLines& g = s.lines;
    const sweep::RayTable rays = sweep::ray_table(s.ray_half, g.metres_u, g.metres_v, curvature);
    const std::size_t base = static_cast<std::size_t>(s.base);
    std::copy(rays.slope.begin(), rays.slope.end(), table.begin() + base);
    std::copy(rays.inv_slope.begin(), rays.inv_slope.end(), table.begin() + plan.rows + base);
    std::copy(rays.curv_k.begin(), rays.curv_k.end(), table.begin() + 2 * plan.rows + base);
  }
  for (const DiskSector& s : plan.sectors) {
    const sweep::SectorLines& g = s.lines;
    GpuSector gs{};
    gs.rows = g.axis.rows;
    gs.dir = g.axis.dir;
    gs.line0 = g.line0 - g.u0;  // window-relative: line 0 is the window's first row (or column)
    gs.lines = g.lines;
    gs.ray_half = s.ray_half;
    gs.base = s.base;
    gs.u_count = s.u_count;
    gs.v_count = s.v_count;
    gs.j_max = std::max(0, s.v_count - 2);
    gs.k0 = static_cast<float>(g.k0);
    gs.eye_v = static_cast<float>(g.eye_v);
    gs.v_min = 0.0f;
    gs.v_max = static_cast<float>(s.v_count - 1);
    gs.curvature = static_cast<float>(curvature);
    gs.mu2 = static_cast<float>(g.metres_u * g.metres_u);
    gs.mv2 = static_cast<float>(g.metres_v * g.metres_v);
    gs.steps_at = static_cast<std::int32_t>(table.size());
    gs.d_at = static_cast<std::int32_t>(doubles.size());
    doubles.push_back(g.eye_v);
    const std::vector<float> inv_step = sweep::inv_steps(g.k0, g.lines);
    for (int n = 0; n < g.lines; ++n) {
      const double k = g.step(n);
      const float kf = static_cast<float>(k);
      const sweep::CellSpan wedge = sweep::owned_cells(f, g, n);
      table.insert(table.end(), {kf, static_cast<float>(k - 1.0), 1.0f / kf, inv_step[static_cast<std::size_t>(n)],
                                 static_cast<float>(wedge.lo), static_cast<float>(wedge.hi)});
      doubles.push_back(1.0 / k);
    }
    gs.dv_at = static_cast<std::int32_t>(table.size());
    const std::vector<float> inv_dv = sweep::inv_dvs(g.eye_v, s.v_count);
    table.insert(table.end(), inv_dv.begin(), inv_dv.end());
    plan.gpu_sectors.push_back(gs);
  }
  return plan;
}

}  // namespace gl

Status prepare_radial_gl(gpu::ContextPool& pool) {
  // One thread per context, each holding its lease until all have one, so
  // that every context (not one of them n times) is prepared.
  const int n = pool.size();
  std::barrier all_lent(n);
  std::vector<std::string> errors(static_cast<std::size_t>(n));
  std::vector<std::thread> threads;
  for (int i = 0; i < n; ++i)
    threads.emplace_back([&, i] {
      auto lease = pool.borrow();
      if (lease.ok()) {
        errors[static_cast<std::size_t>(i)] = lease->resources<OhfResources>().error;
      } else {
        errors[static_cast<std::size_t>(i)] = lease.error().message;
      }
      all_lent.arrive_and_wait();
    });
  for (std::thread& t : threads) t.join();
  for (const std::string& e : errors)
    if (!e.empty()) return make_error(ErrorCode::kInternal, e, "gpu");
  return Status::Ok();
}

Status radial_ohf_gl(gpu::Lease& lease, const terrain::HeightView& z, const ViewFrame& f, const RadialOptions& radial,
                     const GpuOptions& options, const RunControl* control, terrain::Grid<float>& ohf,
                     WorkStats& stats) {
  // Every failure below marks the context failed: it is replaced on return.
  auto fail = [&lease](Status status) {
    lease.fail();
    return status;
  };
  HORIZON_RETURN_IF_ERROR(sweep::check_ray_count(f, radial.ray_spacing));  // the context is fine
  const terrain::Window& w = f.window;
  // The disk and its tables, the CPU sweep's geometry (sweep_geometry.hpp):
  // float values of double formulas.
  gl::DiskPlan disk = gl::plan_disk(f, radial.ray_spacing);
  const std::vector<gl::DiskSector>& sectors = disk.sectors;
  const int disk_width = disk.width, disk_rows = disk.rows;
  const int limit = lease.device().max_texture_size;
  if (w.width() > limit || w.height() > limit || disk_width > limit || disk_rows > limit)
    return make_error(ErrorCode::kResourceExhausted,
                      "gpu: a window of " + std::to_string(w.width()) + "x" + std::to_string(w.height()) +
                          " cells needs a ray disk of " + std::to_string(disk_width) + "x" + std::to_string(disk_rows) +
                          " texels; this device's limit is " + std::to_string(limit) + " per side",
                      "gpu");
  reset_output(ohf, w);
  if (sectors.empty()) return Status::Ok();  // a one-cell window: only the eye's cell, below

  auto& gl = lease.resources<OhfResources>();
  if (!gl.error.empty()) return fail(make_error(ErrorCode::kInternal, gl.error, "gpu"));

  const double curvature = f.curvature;
  std::vector<gl::GpuSector>& gpu_sectors = disk.gpu_sectors;

  // The images this run grows the context's to, asked for before any is allocated.
  const std::uint64_t images =
      gl.terrain.bytes_after(w.width(), w.height()) + 2 * gl.disk[0].bytes_after(disk_width, disk_rows) +
      gl.out.bytes_after(w.width(), w.height()) + gl.sectors.held_after(4 * sizeof(gl::GpuSector)) +
      gl.table.held_after(disk.table.size() * sizeof(float)) + gl.doubles.held_after(disk.doubles.size() * sizeof(double));
  HORIZON_RETURN_IF_ERROR(lease.grow_images(
      gl, images, "the OHF sweep of a " + std::to_string(w.width()) + "x" + std::to_string(w.height()) + " window"));

  // Terrain: the window under the view's void policy, voids left as kVoid.
  std::vector<float> staging(w.cell_count());
  for (int r = w.row0; r < w.row1; ++r) {
    const float* src = z.row(r) + w.col0;
    float* dst = staging.data() + static_cast<std::size_t>(r - w.row0) * w.width();
    for (int c = 0; c < w.width(); ++c) {
      const float v = z.fill(src[c]);
      dst[c] = std::isnan(v) ? kVoid : v;
    }
  }
  gl.terrain.ensure(w.width(), w.height());
  glBindTexture(GL_TEXTURE_2D, gl.terrain.texture);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, w.width(), w.height(), GL_RED, GL_FLOAT, staging.data());
  gl.disk[0].ensure(disk_width, disk_rows);
  gl.disk[1].ensure(disk_width, disk_rows);
  gl.out.ensure(w.width(), w.height());
  const int sector_count = static_cast<int>(gpu_sectors.size());
  gpu_sectors.resize(4, gl::GpuSector{});  // the shader declares four
  gl.sectors.upload(0, gpu_sectors.data(), gpu_sectors.size() * sizeof(gl::GpuSector));
  gl.table.upload(1, disk.table.data(), disk.table.size() * sizeof(float));
  gl.doubles.upload(2, disk.doubles.data(), disk.doubles.size() * sizeof(double));
  if (auto s = gl_status("upload"); !s.ok()) return fail(s);

  const float eye_hi = static_cast<float>(f.eye);
  const float eye_lo = static_cast<float>(f.eye - static_cast<double>(eye_hi));
  const int blend = radial.blend == RayBlend::kLinear ? 0 : radial.blend == RayBlend::kMin ? 1 : 2;
  const bool compute = options.method == GpuMethod::kCompute;
  auto bind_common = [&](GLuint program, GLuint disk_texture) {
    glUseProgram(program);
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D, gl.terrain.texture);
    set_uniform(program, "u_terrain", 0);
    glActiveTexture(GL_TEXTURE1);
    glBindTexture(GL_TEXTURE_2D, disk_texture);
    set_uniform(program, "u_disk", 1);
    set_uniform(program, "u_sectors", sector_count);
    set_uniform(program, "u_rows", disk_rows);
    set_uniform(program, "u_blend", blend);
    set_uniform(program, "u_eye_hi", eye_hi);
    set_uniform(program, "u_eye_lo", eye_lo);
    set_uniform(program, "u_eye_x", static_cast<float>(f.observer_col - w.col0));
    set_uniform(program, "u_eye_y", static_cast<float>(f.observer_row - w.row0));
  };
  // One pass of `which` (0 modulate, 1 propagate, 2 resolve, 3 shifted) into `target`.
  auto run_pass = [&](int which, const gpu::Texture2D& target, int width, int height, GLuint disk_texture, int shift) {
    const GLuint program = compute ? gl.compute[which] : gl.fragment[which];
    bind_common(program, disk_texture);
    set_uniform(program, "u_shift", shift);
    if (compute) {
      glUniform2i(glGetUniformLocation(program, "u_size"), width, height);
      glBindImageTexture(0, target.texture, 0, GL_FALSE, 0, GL_WRITE_ONLY, GL_RG32F);
      glDispatchCompute(static_cast<GLuint>((width + 15) / 16), static_cast<GLuint>((height + 15) / 16), 1);
      glMemoryBarrier(GL_TEXTURE_FETCH_BARRIER_BIT | GL_FRAMEBUFFER_BARRIER_BIT);
    } else {
      glBindFramebuffer(GL_FRAMEBUFFER, gl.fbo);
      glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, target.texture, 0);
      glViewport(0, 0, width, height);
      glBindVertexArray(gl.vao);
      glDrawArrays(GL_TRIANGLES, 0, 3);
    }
  };
  glDisable(GL_BLEND);
  glDisable(GL_DEPTH_TEST);

  // 1. Perspective modulation into disk 0.
  glQueryCounter(gl.timers[0], GL_TIMESTAMP);
  run_pass(0, gl.disk[0], disk_width, disk_rows, 0, 0);
  if (auto s = gl_status("the modulation pass"); !s.ok()) return fail(s);
  // 2. Propagation (the shift disk), ping-ponging between the two disks.
  int current = 0;
  int passes = 0;
  auto poll = [&]() -> Status {
    if ((++passes & 31) != 0) return Status::Ok();
    HORIZON_RETURN_IF_ERROR(check_control(control));
    glFinish();  // bounds the queue, so that a stop takes effect soon
    return Status::Ok();
  };
  if (compute && !options.log_step) {
    // One invocation per ray carries the running maximum outward.
    bind_common(gl.scan, gl.disk[0].texture);
    glUniform2i(glGetUniformLocation(gl.scan, "u_size"), disk_width, disk_rows);
    glBindImageTexture(0, gl.disk[1].texture, 0, GL_FALSE, 0, GL_WRITE_ONLY, GL_RG32F);
    glDispatchCompute(static_cast<GLuint>((disk_rows + 63) / 64), 1, 1);
    glMemoryBarrier(GL_TEXTURE_FETCH_BARRIER_BIT | GL_FRAMEBUFFER_BARRIER_BIT);
    current = 1;
  } else if (!compute && blend != 2) {
    // The patent's shift disk: the disk drawn onto its copy shifted outward,
    // GL_MAX blending keeping the larger horizon. With one-texel shifts the
    // copy may lag one pass behind (max(H[k-1], shift H[k]) = H[k+1]);
    // doubled shifts need an up-to-date copy first.
    glCopyImageSubData(gl.disk[0].texture, GL_TEXTURE_2D, 0, 0, 0, 0, gl.disk[1].texture, GL_TEXTURE_2D, 0, 0, 0, 0,
                       disk_width, disk_rows, 1);
    glEnable(GL_BLEND);
    glBlendEquation(GL_MAX);
    for (int shift = 1; shift < disk_width; shift = options.log_step ? 2 * shift : shift + 1) {
      if (options.log_step && shift > 1)
        glCopyImageSubData(gl.disk[current].texture, GL_TEXTURE_2D, 0, 0, 0, 0, gl.disk[1 - current].texture,
                           GL_TEXTURE_2D, 0, 0, 0, 0, disk_width, disk_rows, 1);
      run_pass(3, gl.disk[1 - current], disk_width, disk_rows, gl.disk[current].texture, options.log_step ? shift : 1);
      current = 1 - current;
      if (auto s = poll(); !s.ok()) {
        glDisable(GL_BLEND);
        return s;
      }
    }
    glDisable(GL_BLEND);
  } else {
    // The larger of each texel and the one `shift` inward, with where it lies, in the shader.
    for (int shift = 1; shift < disk_width; shift = options.log_step ? 2 * shift : shift + 1) {
      run_pass(1, gl.disk[1 - current], disk_width, disk_rows, gl.disk[current].texture, options.log_step ? shift : 1);
      current = 1 - current;
      HORIZON_RETURN_IF_ERROR(poll());
    }
  }
  if (auto s = gl_status("the propagation passes"); !s.ok()) return fail(s);
  if (auto s = check_control(control); !s.ok()) return s;
  // 3. Resolve every window cell from its two bracketing rays.
  run_pass(2, gl.out, w.width(), w.height(), gl.disk[current].texture, 0);
  glQueryCounter(gl.timers[1], GL_TIMESTAMP);
  std::vector<float> resolved(2 * w.cell_count());
  glBindFramebuffer(GL_FRAMEBUFFER, gl.fbo);
  glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, gl.out.texture, 0);
  glPixelStorei(GL_PACK_ALIGNMENT, 4);
  glReadPixels(0, 0, w.width(), w.height(), GL_RG, GL_FLOAT, resolved.data());
  if (auto s = gl_status("the resolve pass"); !s.ok()) return fail(s);
  GLuint64 t0 = 0, t1 = 0;
  glGetQueryObjectui64v(gl.timers[0], GL_QUERY_RESULT, &t0);
  glGetQueryObjectui64v(gl.timers[1], GL_QUERY_RESULT, &t1);
  stats.device_seconds = t1 > t0 ? 1e-9 * static_cast<double>(t1 - t0) : 0.0;

  // OHF = eye + k * horizon + curvature * d^2 in double, with the CPU
  // sweep's k and distance for the sector that owns the cell.
  const double max_d2 = f.max_distance * f.max_distance;
  std::vector<std::uint64_t> answered(static_cast<std::size_t>(w.height()), 0);
  parallel_for(static_cast<std::size_t>(w.height()), 0, [&](std::size_t y) {
    const float* src = resolved.data() + 2 * y * static_cast<std::size_t>(w.width());
    const float* zr = z.row(w.row0 + static_cast<int>(y)) + w.col0;
    float* dst = ohf.row(static_cast<int>(y));
    std::uint64_t count = 0;
    for (int x = 0; x < w.width(); ++x) {
      const int si = static_cast<int>(src[2 * x + 1]);
      if (si < 0 || si >= static_cast<int>(sectors.size()) || std::isnan(z.fill(zr[x]))) continue;
      const sweep::SectorLines& s = sectors[static_cast<std::size_t>(si)].lines;
      const bool rows = s.axis.rows;
      const int line = rows ? static_cast<int>(y) : x, j = rows ? x : static_cast<int>(y);  // window-relative
      const double k = s.k0 + (line - (s.line0 - s.u0)) * s.axis.dir;
      const double du = k * s.metres_u, dv = (j - s.eye_v) * s.metres_v;
      const double d2 = du * du + dv * dv;
      if (d2 > max_d2) continue;
      const double hz = src[2 * x];
      dst[x] = !(hz > 0.5 * kNoHorizon) ? -std::numeric_limits<float>::infinity()
                                        : static_cast<float>(f.eye + k * hz + curvature * d2);
      ++count;
    }
    answered[y] = count;
  });
  std::uint64_t evaluated = 0;
  for (std::uint64_t c : answered) evaluated += c;
  // The eye's own cell when the eye sits exactly on its centre: no sector owns it.
  const double oc = f.observer_col, orow = f.observer_row;
  if (oc == std::floor(oc) && orow == std::floor(orow) && w.contains(int(oc), int(orow)) &&
      !std::isnan(z.at(int(oc), int(orow)))) {
    ohf.at(int(oc) - w.col0, int(orow) - w.row0) = -std::numeric_limits<float>::infinity();
    ++evaluated;
  }
  std::uint64_t disk_texels = 0;
  for (const gl::DiskSector& s : sectors) disk_texels += static_cast<std::uint64_t>(2 * s.ray_half + 1) * s.lines.lines;
  stats.cells_evaluated = evaluated;
  stats.rays = static_cast<std::uint64_t>(disk_rows);
  stats.terrain_samples = 2 * disk_texels;
  return Status::Ok();
}

}  // namespace horizon::visibility
