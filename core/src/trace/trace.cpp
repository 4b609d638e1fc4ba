// The trace's driver (horizon/trace/trace.hpp): validation, the sub-frusta's
// blocks of columns in parallel, and each pixel's hit from the descent's
// leaves. The kernels are in silhouette.cpp, the shared geometry in
// frustum.cpp, the GL form in trace_gl.cpp.
#include "horizon/trace/trace.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <vector>

#include "frustum.hpp"
#include "horizon/common/parallel.hpp"
#include "horizon/geodesy/crs.hpp"
#include "silhouette.hpp"
#include "trace_gl.hpp"

namespace horizon::trace {
namespace {

Status bad_option(const char* field, const std::string& what) {
  return make_error(ErrorCode::kInvalidArgument, std::string(field) + ": " + what, field);
}

// One block's scratch, kept by each thread between blocks and frames.
struct Scratch {
  std::vector<float> map, pairs, map2, pairs2;
  alignas(64) float slope[detail::kBlock];
  alignas(64) std::int32_t leaf[detail::kBlock];
  alignas(64) std::int32_t leaf2[detail::kBlock];
};

Scratch& scratch() {
  thread_local Scratch s;
  return s;
}

detail::BlockLines primary_lines(const detail::FrameGeometry& g, const detail::Run& run, int x0, int lanes) {
  detail::BlockLines b;
  b.lanes = lanes;
  b.eye_along = run.primary.eye_along;
  b.pos_count = run.primary.pos_count;
  b.line_stride = run.primary.line_stride;
  b.pos_stride = run.primary.pos_stride;
  for (int i = 0; i < lanes; ++i) {
    const auto x = static_cast<std::size_t>(x0 + i);
    b.first[i] = run.primary.first;
    b.step[i] = run.primary.step;
    b.count[i] = run.primary.count;
    b.t0[i] = run.primary.t0;
    b.pos_per_t[i] = g.pos_per_t[x];
    b.dist_per_t[i] = g.dist_per_t[x];
    b.near[i] = g.near[x];
  }
  return b;
}

detail::BlockLines secondary_lines(const detail::FrameGeometry& g, const detail::Run& run, int x0, int lanes,
                                   int& lines) {
  detail::BlockLines b;
  b.lanes = lanes;
  b.eye_along = run.secondary[0].eye_along;
  b.pos_count = run.secondary[0].pos_count;
  b.line_stride = run.secondary[0].line_stride;
  b.pos_stride = run.secondary[0].pos_stride;
  lines = 0;
  for (int i = 0; i < lanes; ++i) {
    const auto x = static_cast<std::size_t>(x0 + i);
    const detail::LineFamily& f = run.secondary[g.side[x]];
    b.first[i] = f.first;
    b.step[i] = f.step;
    // A column looking straight down its quadrant's axis crosses none.
    b.count[i] = std::isfinite(g.dist_per_t2[x]) ? f.count : 0;
    b.t0[i] = f.t0;
    b.pos_per_t[i] = g.pos_per_t2[x];
    b.dist_per_t[i] = g.dist_per_t2[x];
    b.near[i] = g.near[x];
    lines = std::max(lines, b.count[i]);
  }
  return b;
}

// One crossing as the hit resolution needs it.
struct Crossing {
  float distance = std::numeric_limits<float>::infinity();
  float slope = detail::kNoCrossing;
  bool valid = false;
};

Crossing crossing_of(const float* map, int lane, const detail::BlockLines& b, int k) {
  Crossing c;
  if (k < 0 || k >= b.count[lane]) return c;
  c.distance = (static_cast<float>(k) + b.t0[lane]) * b.dist_per_t[lane];
  c.slope = map[static_cast<std::size_t>(k) * detail::kBlock + static_cast<std::size_t>(lane)];
  c.valid = true;
  return c;
}

// The last crossing of b's lane strictly nearer than d (detail::last_crossing_before).
int last_before(const detail::BlockLines& b, int lane, float d) {
  detail::LineFamily f;
  f.t0 = b.t0[lane];
  f.count = b.count[lane];
  return detail::last_crossing_before(f, d, b.dist_per_t[lane]);
}

}  // namespace

Status validate_trace_options(const TraceOptions& o) {
  if (!std::isfinite(o.near) || o.near < 0)
    return bad_option("near", "must be a finite number of metres >= 0, got " + number_text(o.near));
  if (std::isnan(o.max_distance) || !(o.max_distance > 0))
    return bad_option("max_distance", "must be a positive number of metres, got " + number_text(o.max_distance));
  if (!(o.max_distance > o.near))
    return bad_option("max_distance", "must be beyond the near plane (" + number_text(o.near) + " m), got " +
                                          number_text(o.max_distance));
  if (!std::isfinite(o.curvature_coefficient) || o.curvature_coefficient < 0 || o.curvature_coefficient > 2)
    return bad_option("curvature_coefficient", "must lie in [0, 2], got " + number_text(o.curvature_coefficient));
  if (o.nodata == visibility::NodataPolicy::kFill && !std::isfinite(o.nodata_fill_height))
    return bad_option("nodata_fill_height",
                      "must be a finite number of metres, got " + number_text(o.nodata_fill_height));
  return Status::Ok();
}

Hit TraceResult::hit(int x, int j) const {
  Hit h;
  const float d =
      image.distance[static_cast<std::size_t>(j) * static_cast<std::size_t>(image.width) + static_cast<std::size_t>(x)];
  if (!std::isfinite(d)) return h;
  const double s = camera.slope(x, j);
  const double az = camera.azimuth[static_cast<std::size_t>(x)];
  h.sky = false;
  h.distance = d;
  h.range = d * std::sqrt(1.0 + s * s);
  h.col = camera.eye.col + d * std::sin(az) / camera.metres_per_col;
  h.row = camera.eye.row - d * std::cos(az) / camera.metres_per_row;
  h.elevation = camera.eye.elevation + s * d + curvature * d * d;
  return h;
}

Result<TraceResult> trace_frame(const terrain::HeightView& view, const Camera& camera, const TraceOptions& options,
                                const RunControl* control, gpu::Lease* gpu) {
  TraceResult result;
  HORIZON_RETURN_IF_ERROR(trace_frame(view, camera, options, result, control, gpu));
  return result;
}

Status trace_frame(const terrain::HeightView& view, const Camera& camera, const TraceOptions& options,
                   TraceResult& result, const RunControl* control, gpu::Lease* gpu) {
  const auto start = std::chrono::steady_clock::now();
  HORIZON_RETURN_IF_ERROR(validate_trace_options(options));
  HORIZON_RETURN_IF_ERROR(validate_camera(camera.spec));
  if (view.width() < 2 || view.height() < 2)
    return make_error(ErrorCode::kDataError,
                      "a trace needs at least 2x2 cells, the DEM has " + std::to_string(view.width()) + "x" +
                          std::to_string(view.height()),
                      "dem");
  if (!std::isfinite(camera.eye.col) || !std::isfinite(camera.eye.row) || !std::isfinite(camera.eye.elevation))
    return make_error(ErrorCode::kInvalidArgument, "camera: position or eye elevation is not a finite number",
                      "camera");
  const int width = camera.spec.width, height = camera.spec.height;
  if (camera.azimuth.size() != static_cast<std::size_t>(width) ||
      camera.focal_col.size() != static_cast<std::size_t>(width))
    return make_error(ErrorCode::kInvalidArgument, "camera: not made by make_camera for its spec", "camera");

  result.camera = camera;
  const detail::FrameGeometry g = detail::make_frame_geometry(camera, view, options);
  const auto pixels = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  TraceImage& image = result.image;
  image.width = width;
  image.height = height;
  // Every pixel is written below, sky included: no fill first (on a reused
  // result, no page faults either).
  image.distance.resize(pixels);
  image.line.resize(pixels);
  image.axis.resize(pixels);
  TraceStats& stats = result.stats;
  stats = {};
  stats.sub_frusta = static_cast<int>(g.runs.size());
  stats.pixels = pixels;
  result.curvature = options.curvature_coefficient / (2.0 * geodesy::kEarthRadiusMetres);

  if (gpu) {
    const Status gl = detail::trace_gl(view, camera, g, options, *gpu, control, image, stats);
    if (gl.ok()) {
      stats.backend = "gpu";
      stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      return Status::Ok();
    }
    const ErrorCode code = gl.error().code;
    if (code == ErrorCode::kCancelled || code == ErrorCode::kDeadlineExceeded) return gl;
    // What the GL form does not do, or a GL failure: the CPU answers, and says why.
    const std::string why = gl.error().message;
    stats = {};
    stats.sub_frusta = static_cast<int>(g.runs.size());
    stats.pixels = pixels;
    stats.gpu_fallback = why;
  }

  struct Block {
    const detail::Run* run;
    int x0, lanes;
  };
  std::vector<Block> blocks;
  std::vector<detail::TreeShape> shapes;  // per run, the primary family's tree
  for (const detail::Run& run : g.runs) {
    for (int x0 = run.x0; x0 < run.x1; x0 += detail::kBlock)
      blocks.push_back({&run, x0, std::min(detail::kBlock, run.x1 - x0)});
    shapes.push_back(detail::tree_shape(run.primary.count));
    stats.max_lines = std::max(stats.max_lines, run.primary.count);
  }
  const detail::Isa isa = visibility::sweep::simd::kernel_isa();
  const float* data = view.data();
  const bool columns = options.column_crossings;
  std::vector<std::uint64_t> crossings(blocks.size(), 0), texels(blocks.size(), 0), sky(blocks.size(), 0);
  std::vector<int> reads(blocks.size(), 0);

  auto body = [&](std::size_t bi) {
    const Block& blk = blocks[bi];
    const detail::Run& run = *blk.run;
    const detail::TreeShape& shape = shapes[static_cast<std::size_t>(blk.run - g.runs.data())];
    Scratch& s = scratch();
    const int lines = run.primary.count;
    const detail::BlockLines b1 = primary_lines(g, run, blk.x0, blk.lanes);
    s.map.resize(static_cast<std::size_t>(lines) * detail::kBlock);
    s.pairs.resize(shape.floats);
    detail::build_map(isa, data, b1, g, lines, s.map.data());
    detail::build_tree(s.map.data(), shape, s.pairs.data());
    crossings[bi] = static_cast<std::uint64_t>(blk.lanes) * static_cast<std::uint64_t>(lines);
    texels[bi] = (shape.floats / 4 / detail::kBlock) * static_cast<std::uint64_t>(blk.lanes);
    reads[bi] = shape.levels + 2;

    int lines2 = 0;
    detail::BlockLines b2;
    detail::TreeShape shape2;
    if (columns) {
      b2 = secondary_lines(g, run, blk.x0, blk.lanes, lines2);
      shape2 = detail::tree_shape(lines2);
      s.map2.resize(static_cast<std::size_t>(lines2) * detail::kBlock);
      s.pairs2.resize(shape2.floats);
      detail::build_map(isa, data, b2, g, lines2, s.map2.data());
      detail::build_tree(s.map2.data(), shape2, s.pairs2.data());
      crossings[bi] += static_cast<std::uint64_t>(blk.lanes) * static_cast<std::uint64_t>(lines2);
      texels[bi] += (shape2.floats / 4 / detail::kBlock) * static_cast<std::uint64_t>(blk.lanes);
      reads[bi] += shape2.levels + 2;
    }

    const LineAxis axis1 = run.primary.axis;
    const LineAxis axis2 = axis1 == LineAxis::kRows ? LineAxis::kColumns : LineAxis::kRows;
    for (int j = 0; j < height; ++j) {
      for (int i = 0; i < detail::kBlock; ++i)
        s.slope[i] = i < blk.lanes ? detail::pixel_slope(g, blk.x0 + i, j) : std::numeric_limits<float>::infinity();
      detail::descend(isa, s.pairs.data(), shape, s.slope, s.leaf);
      if (columns) detail::descend(isa, s.pairs2.data(), shape2, s.slope, s.leaf2);
      const std::size_t row = static_cast<std::size_t>(j) * static_cast<std::size_t>(width);
      if (!columns) {
        // One family: the hits of the whole block row at once.
        float* distance = image.distance.data() + row + static_cast<std::size_t>(blk.x0);
        std::int32_t* line = image.line.data() + row + static_cast<std::size_t>(blk.x0);
        if (lines > 0) {
          detail::resolve_rows(isa, s.map.data(), b1, s.slope, s.leaf, blk.lanes, distance, line);
        } else {
          std::fill(distance, distance + blk.lanes, std::numeric_limits<float>::infinity());
          std::fill(line, line + blk.lanes, -1);
        }
        LineAxis* axis = image.axis.data() + row + static_cast<std::size_t>(blk.x0);
        for (int i = 0; i < blk.lanes; ++i) {
          axis[i] = line[i] < 0 ? LineAxis::kRows : axis1;
          sky[bi] += line[i] < 0;
        }
        continue;
      }
      for (int i = 0; i < blk.lanes; ++i) {
        const float slope = s.slope[i];
        const int k1 = s.leaf[i], k2 = s.leaf2[i];
        const std::size_t at = row + static_cast<std::size_t>(blk.x0 + i);
        if (k1 < 0 && k2 < 0) {
          image.distance[at] = std::numeric_limits<float>::infinity();
          image.line[at] = -1;
          image.axis[at] = LineAxis::kRows;
          ++sky[bi];
          continue;
        }
        const Crossing h1 = crossing_of(s.map.data(), i, b1, k1);
        const Crossing h2 = crossing_of(s.map2.data(), i, b2, k2);
        const bool first = h1.valid && !(h2.distance < h1.distance);
        const Crossing& hit = first ? h1 : h2;
        // The crossing before the hit: the same family's previous one, or
        // the other family's last one nearer than the hit, whichever is later.
        Crossing before = first ? crossing_of(s.map.data(), i, b1, k1 - 1) : crossing_of(s.map2.data(), i, b2, k2 - 1);
        const Crossing other = first ? crossing_of(s.map2.data(), i, b2, last_before(b2, i, hit.distance))
                                     : crossing_of(s.map.data(), i, b1, last_before(b1, i, hit.distance));
        if (other.valid &&
            (!before.valid || (first ? other.distance > before.distance : !(other.distance < before.distance))))
          before = other;
        image.distance[at] = detail::chord_hit(slope, before.distance, before.slope, hit.distance, hit.slope);
        image.line[at] = first ? b1.first[i] + b1.step[i] * k1 : b2.first[i] + b2.step[i] * k2;
        image.axis[at] = first ? axis1 : axis2;
      }
    }
  };
  HORIZON_RETURN_IF_ERROR(parallel_for(blocks.size(), options.threads, control, body));

  for (std::size_t i = 0; i < blocks.size(); ++i) {
    stats.crossings += crossings[i];
    stats.tree_texels += texels[i];
    stats.reads_per_pixel = std::max(stats.reads_per_pixel, reads[i]);
    stats.sky_pixels += sky[i];
  }
  stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return Status::Ok();
}

}  // namespace horizon::trace
