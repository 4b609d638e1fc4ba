// The GL trace of a clip-map plan (clip_trace.hpp), the GPU form of
// trace_cpu in clip_cull.cpp: the same plan, rings and column directions,
// traced by the compute shader of clip_trace_gl_shader.hpp over the levels
// copied into one texture array; the box tests and viewshed cells that read
// the horizons are the CPU's own (test_boxes, clip_viewshed.cpp).
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "clip_trace.hpp"
#include "clip_trace_gl_shader.hpp"
#include "gpu/gl_helpers.hpp"

namespace horizon::clipmap::detail {
namespace {

constexpr float kVoid = -3.0e38f;  // the shader's void
constexpr std::size_t kDispatchColumns = 8192;  // columns per dispatch: the control is checked between them

struct GlRing {
  double near, far, mid, inv_mid, mid_drop, far_drop, blend;
  std::int32_t k, lowest_level;
};
static_assert(sizeof(GlRing) == 64, "std430 layout of the shader's Ring");

struct GlColumn {
  double cx0, cy0, cx1, cy1, cxm, cym, reach, unused;
};
static_assert(sizeof(GlColumn) == 64, "std430 layout of the shader's Column");

// One context's program and its copy of the last clip-map traced there:
// a level is uploaded again only when its version has changed.
struct ClipTraceResources final : gpu::ContextResources {
  GLuint program = 0;
  std::string error;
  gpu::TextureArray cells{GL_R32F}, resident{GL_R8UI};
  static constexpr std::uint64_t kNone = UINT64_MAX;  // a level not copied yet
  std::uint64_t map_id = 0;
  std::uint64_t versions[ClipmapShape::kMaxLevels];
  gpu::StorageBuffer rings, columns, horizons, counts;
  // Host-side tables, kept so that a warm context allocates nothing per trace.
  std::vector<float> staging;
  std::vector<std::uint8_t> staging_resident;
  std::vector<GlRing> ring_table;
  std::vector<GlColumn> column_table;
  std::vector<std::uint32_t> count_table;

  ClipTraceResources() {
    std::fill(std::begin(versions), std::end(versions), kNone);
    std::string log;
    const GLuint cs = gpu::compile_shader(GL_COMPUTE_SHADER, gl_shader::kTrace, log);
    program = cs ? gpu::link_program({cs}, log) : 0;
    if (!program) error = "gpu: the clip-map trace shader does not build: " + log;
  }
  // The level copies, buffers and host tables.
  std::uint64_t image_bytes() const override {
    return cells.bytes() + resident.bytes() + rings.held() + columns.held() + horizons.held() + counts.held() +
           staging.capacity() * sizeof(float) + staging_resident.capacity() + ring_table.capacity() * sizeof(GlRing) +
           column_table.capacity() * sizeof(GlColumn) + count_table.capacity() * sizeof(std::uint32_t);
  }
  void release_images() override {
    cells.release();
    resident.release();
    for (gpu::StorageBuffer* b : {&rings, &columns, &horizons, &counts}) b->release();
    std::vector<float>().swap(staging);
    std::vector<std::uint8_t>().swap(staging_resident);
    std::vector<GlRing>().swap(ring_table);
    std::vector<GlColumn>().swap(column_table);
    std::vector<std::uint32_t>().swap(count_table);
    map_id = 0;
    std::fill(std::begin(versions), std::end(versions), kNone);
  }
  ~ClipTraceResources() override { glDeleteProgram(program); }
};

// Brings the context's copy of the levels up to `view`'s snapshot.
void upload_levels(ClipTraceResources& gl, const ClipmapReader& view, std::uint64_t& bytes) {
  const Clipmap& map = view.map();
  const ClipmapShape& shape = map.shape();
  const int n = shape.level_size, tiles = n / shape.subtile;
  const bool new_cells = gl.cells.ensure(n, n, shape.levels);  // both arrays sized, whichever was re-created
  const bool new_resident = gl.resident.ensure(tiles, tiles, shape.levels);
  if (new_cells || new_resident || gl.map_id != map.id()) {
    gl.map_id = map.id();
    std::fill(std::begin(gl.versions), std::end(gl.versions), ClipTraceResources::kNone);
  }
  gl.staging.resize(static_cast<std::size_t>(n) * static_cast<std::size_t>(n));
  gl.staging_resident.resize(static_cast<std::size_t>(tiles) * static_cast<std::size_t>(tiles));
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  for (int k = 0; k < shape.levels; ++k) {
    const std::uint64_t version = view.level(k).version;
    if (version == gl.versions[k]) continue;
    view.copy_level(k, gl.staging.data(), gl.staging_resident.data());
    for (float& z : gl.staging)
      if (z != z) z = kVoid;
    glBindTexture(GL_TEXTURE_2D_ARRAY, gl.cells.texture);
    glTexSubImage3D(GL_TEXTURE_2D_ARRAY, 0, 0, 0, k, n, n, 1, GL_RED, GL_FLOAT, gl.staging.data());
    glBindTexture(GL_TEXTURE_2D_ARRAY, gl.resident.texture);
    glTexSubImage3D(GL_TEXTURE_2D_ARRAY, 0, 0, 0, k, tiles, tiles, 1, GL_RED_INTEGER, GL_UNSIGNED_BYTE,
                    gl.staging_resident.data());
    gl.versions[k] = version;
    bytes += gl.staging.size() * sizeof(float) + gl.staging_resident.size();
  }
}

}  // namespace

Status trace_gl(const TracePlan& plan, const ClipmapReader& view, const ClipEye& eye, const ClipCullOptions& options,
                const RunControl* control, gpu::Lease& lease, ClipCullScratch& w, std::uint64_t& uploaded) {
  auto fail = [&lease](Status status) {
    lease.fail();
    return status;
  };
  auto& gl = lease.resources<ClipTraceResources>();  // beside the OHF sweep's on the same context
  if (!gl.error.empty()) return fail(make_error(ErrorCode::kInternal, gl.error, "gpu"));

  const Clipmap& map = view.map();
  const ClipmapShape& shape = map.shape();
  const int rays = plan.rays;
  const std::size_t columns = static_cast<std::size_t>(rays);
  {
    // What this trace grows the context's copies and tables to, asked for before any is allocated.
    const int n = shape.level_size, tiles = n / shape.subtile;
    const std::size_t horizon_values = columns * plan.edges.size();
    using gpu::vector_bytes_after;
    const std::uint64_t images =
        gl.cells.bytes_after(n, n, shape.levels) + gl.resident.bytes_after(tiles, tiles, shape.levels) +
        gl.rings.held_after(std::max<std::size_t>(plan.rings.size(), 1) * sizeof(GlRing)) +
        gl.columns.held_after(columns * sizeof(GlColumn)) + gl.horizons.held_after(horizon_values * sizeof(double)) +
        gl.counts.held_after(columns * 4 * sizeof(std::uint32_t)) +
        vector_bytes_after(gl.staging, std::size_t(n) * std::size_t(n)) +
        vector_bytes_after(gl.staging_resident, std::size_t(tiles) * std::size_t(tiles)) +
        vector_bytes_after(gl.ring_table, std::max<std::size_t>(plan.rings.size(), 1)) + vector_bytes_after(gl.column_table, columns) +
        vector_bytes_after(gl.count_table, columns * 4);
    HORIZON_RETURN_IF_ERROR(lease.grow_images(
        gl, images, "the clip-map trace of " + std::to_string(shape.levels) + " levels of " + std::to_string(n) + "^2"));
  }
  upload_levels(gl, view, uploaded);
  if (auto s = gpu::gl_status("the clip-map upload"); !s.ok()) return fail(s);

  // The plan's rings and the columns' rays, as trace_cpu has them.
  std::vector<GlRing>& rings = gl.ring_table;
  rings.clear();
  for (const Ring& r : plan.rings)
    rings.push_back({r.near, r.far, r.mid, r.inv_mid, r.mid_drop, r.far_drop, static_cast<double>(r.blend), r.k,
                     r.lowest_level});
  if (rings.empty()) rings.push_back({});  // a buffer of no rings still needs a binding
  std::vector<GlColumn>& cols = gl.column_table;
  cols.resize(columns);
  const double dtheta = plan.g.dtheta;
  for (std::size_t a = 0; a < columns; ++a) {
    const ColumnRays c = column_rays(a, dtheta, eye);
    cols[a] = {c.cx0, c.cy0, c.cx1, c.cy1, c.cxm, c.cym, w.reach[a], 0.0};
  }
  const std::size_t horizon_values = columns * plan.edges.size();
  gl.rings.upload(0, rings.data(), rings.size() * sizeof(GlRing));
  gl.columns.upload(1, cols.data(), cols.size() * sizeof(GlColumn));
  gl.horizons.reserve(2, horizon_values * sizeof(double));
  gl.counts.reserve(3, columns * 4 * sizeof(std::uint32_t));
  if (auto s = gpu::gl_status("the trace's tables"); !s.ok()) return fail(s);

  const GLuint p = gl.program;
  glUseProgram(p);
  glActiveTexture(GL_TEXTURE0);
  glBindTexture(GL_TEXTURE_2D_ARRAY, gl.cells.texture);
  gpu::set_uniform(p, "u_cells", 0);
  glActiveTexture(GL_TEXTURE1);
  glBindTexture(GL_TEXTURE_2D_ARRAY, gl.resident.texture);
  gpu::set_uniform(p, "u_resident", 1);
  gpu::set_uniform(p, "u_n", shape.level_size);
  gpu::set_uniform(p, "u_log_t", std::countr_zero(static_cast<unsigned>(shape.subtile)));  // t: a power of two
  gpu::set_uniform(p, "u_levels", shape.levels);
  gpu::set_uniform(p, "u_rays", rays);
  gpu::set_uniform(p, "u_rings", static_cast<int>(plan.rings.size()));
  gpu::set_uniform(p, "u_fast", options.mode == ClipMode::kFast ? 1 : 0);
  GLint origins[2 * ClipmapShape::kMaxLevels] = {}, sizes[2 * ClipmapShape::kMaxLevels] = {};
  for (int k = 0; k < shape.levels; ++k) {
    const LevelState state = view.level(k);
    origins[2 * k] = state.origin.col0;
    origins[2 * k + 1] = state.origin.row0;
    sizes[2 * k] = map.level_width(k);
    sizes[2 * k + 1] = map.level_height(k);
  }
  glUniform2iv(glGetUniformLocation(p, "u_origin"), shape.levels, origins);
  glUniform2iv(glGetUniformLocation(p, "u_size"), shape.levels, sizes);
  glUniform2i(glGetUniformLocation(p, "u_source"), map.source_width(), map.source_height());
  glUniform2d(glGetUniformLocation(p, "u_eye"), eye.col, eye.row);
  glUniform1d(glGetUniformLocation(p, "u_eye_z"), eye.elevation);
  glUniform1d(glGetUniformLocation(p, "u_tangent"), 1.0 / std::cos(dtheta / 2));
  for (std::size_t first = 0; first < columns; first += kDispatchColumns) {
    HORIZON_RETURN_IF_ERROR(check_control(control));
    const std::size_t count = std::min(kDispatchColumns, columns - first);
    gpu::set_uniform(p, "u_first", static_cast<int>(first));
    gpu::set_uniform(p, "u_count", static_cast<int>(count));
    glDispatchCompute(static_cast<GLuint>((count + 63) / 64), 1, 1);
    if (first + count < columns) glFinish();  // bounds the queue, so that a stop takes effect soon
  }
  glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
  if (auto s = gpu::gl_status("the clip-map trace"); !s.ok()) return fail(s);

  // Horizons for every ring of every column, as trace_cpu leaves them.
  if (w.horizons.size() < horizon_values) w.horizons.resize(horizon_values);
  gl.horizons.download(w.horizons.data(), horizon_values * sizeof(double));
  std::vector<std::uint32_t>& counts = gl.count_table;
  counts.resize(columns * 4);
  gl.counts.download(counts.data(), counts.size() * sizeof(std::uint32_t));
  if (auto s = gpu::gl_status("reading the horizons back"); !s.ok()) return fail(s);
  for (std::size_t a = 0; a < columns; ++a) {
    w.traced[a] = counts[4 * a];
    w.stats[a].samples += counts[4 * a + 1];
    w.stats[a].fallbacks += counts[4 * a + 2];
  }
  return Status::Ok();
}

}  // namespace horizon::clipmap::detail
