#include "session_translate.hpp"

#include <algorithm>
#include <cmath>

#include "horizon/common/error.hpp"
#include "translate.hpp"

namespace horizon::server {
namespace {

}  // namespace

Result<clipmap::SessionOptions> to_session_options(const v1::OpenSession& open, const SessionConfig& config,
                                                   unsigned threads, int width, int height,
                                                   gpu::ContextPool* gpu) {
  clipmap::SessionOptions o;
  const v1::ClipmapShape& shape = open.clipmap();
  const std::uint32_t n = shape.level_size() ? shape.level_size() : config.level_size;
  if (n > config.max_level_size)
    return make_error(ErrorCode::kInvalidArgument,
                      "open.clipmap.level_size: " + std::to_string(n) + " is more than this server allows (" +
                          std::to_string(config.max_level_size) + ")",
                      "open.clipmap.level_size");
  o.shape.level_size = static_cast<int>(std::min<std::uint32_t>(n, 1u << 20));
  // A client's own subtile is checked by the engine; the default shrinks to fit a small level.
  const std::uint32_t t = shape.subtile() ? shape.subtile() : std::min(config.subtile, std::max(8u, n / 2));
  o.shape.subtile = static_cast<int>(std::min<std::uint32_t>(t, 1u << 20));
  if (shape.levels()) {
    o.shape.levels = static_cast<int>(std::min<std::uint32_t>(shape.levels(), 1000));
  } else {
    o.shape.levels = clipmap::levels_to_cover(o.shape.level_size, width, height);
  }
  for (int k = 0; k < shape.every_size(); ++k)
    o.updater.every.push_back(static_cast<int>(std::min<std::uint32_t>(shape.every(k), 1u << 30)));
  if (shape.has_lead_seconds()) o.updater.lead_seconds = shape.lead_seconds();
  switch (open.mode()) {
    case v1::SESSION_MODE_UNSPECIFIED:
    case v1::SESSION_MODE_FAST:
      o.mode = clipmap::ClipMode::kFast;
      break;
    case v1::SESSION_MODE_CONSERVATIVE:
      o.mode = clipmap::ClipMode::kConservative;
      break;
    case v1::SESSION_MODE_EXACT:
      o.mode = clipmap::ClipMode::kExact;
      break;
    default:
      return make_error(ErrorCode::kInvalidArgument, "open.mode: unknown value " + std::to_string(open.mode()),
                        "open.mode");
  }
  if (open.rays()) o.rays = static_cast<int>(std::min<std::uint32_t>(open.rays(), 1u << 30));
  auto curvature = to_curvature(open.has_curvature(), open.curvature());
  if (!curvature.ok()) return curvature.error();  // "curvature": the caller names it open.curvature
  o.curvature_coefficient = *curvature;
  o.threads = threads;
  o.max_boxes = config.max_boxes;
  o.exact_bytes = std::uint64_t{config.exact_mb} << 20;
  if (open.has_viewshed_radius_m()) o.viewshed_radius = open.viewshed_radius_m();  // checked by the engine
  switch (open.backend()) {
    case v1::BACKEND_UNSPECIFIED:
    case v1::BACKEND_AUTO:
    case v1::BACKEND_CPU:
      break;
    case v1::BACKEND_GPU:
      o.use_gpu = true;  // exact mode refuses it in ClipSession::bytes_for, before memory is reserved
      o.gpu = gpu;
      break;
    default:
      return make_error(ErrorCode::kInvalidArgument, "open.backend: unknown value " + std::to_string(open.backend()),
                        "open.backend");
  }
  return o;
}

Result<clipmap::SessionPose> to_session_pose(const v1::Pose& pose, const std::string& field) {
  clipmap::SessionPose p;
  if (!pose.has_position())
    return make_error(ErrorCode::kInvalidArgument, field + ".position: required", field + ".position");
  auto position = to_point_spec(pose.position(), field + ".position");
  if (!position.ok()) return position.error();
  p.position = *position;
  if (!std::isfinite(pose.east_m_per_s()) || !std::isfinite(pose.north_m_per_s()))
    return make_error(ErrorCode::kInvalidArgument, field + ".velocity: not a finite number", field + ".east_m_per_s");
  p.east_per_s = pose.east_m_per_s();
  p.north_per_s = pose.north_m_per_s();
  p.seq = pose.seq();
  return p;
}

Result<std::vector<clipmap::SessionBox>> to_session_boxes(
    const google::protobuf::RepeatedPtrField<v1::SessionBox>& boxes, const std::string& field) {
  std::vector<clipmap::SessionBox> out(static_cast<std::size_t>(boxes.size()));
  for (int i = 0; i < boxes.size(); ++i) {
    const v1::SessionBox& in = boxes.Get(i);
    const std::string at = field + "[" + std::to_string(i) + "]";
    if (!in.has_box()) return make_error(ErrorCode::kInvalidArgument, at + ".box: required", at + ".box");
    auto frame = to_frame(in.box().frame(), at + ".box.frame");
    if (!frame.ok()) return frame.error();
    const v1::Box& b = in.box();
    out[static_cast<std::size_t>(i)] = {in.id(), {*frame, b.x_min(), b.y_min(), b.x_max(), b.y_max(), b.z_min(), b.z_max()}};
  }
  return out;
}

void fill_shape(const clipmap::SessionOptions& options, v1::ClipmapShape& out) {
  out.set_levels(static_cast<std::uint32_t>(options.shape.levels));
  out.set_level_size(static_cast<std::uint32_t>(options.shape.level_size));
  out.set_subtile(static_cast<std::uint32_t>(options.shape.subtile));
  for (int e : options.updater.every) out.add_every(static_cast<std::uint32_t>(e));
  out.set_lead_seconds(options.updater.lead_seconds);
}

void fill_answer(const clipmap::SessionAnswer& a, std::uint64_t dropped, v1::PoseAnswer& out) {
  out.set_seq(a.seq);
  out.set_poses_dropped(dropped);
  out.set_eye_elevation(a.eye_elevation);
  out.mutable_changes()->Reserve(static_cast<int>(a.changes.size()));
  for (const clipmap::BoxChange& c : a.changes) {
    v1::BoxChange* m = out.add_changes();
    m->set_id(c.id);
    m->set_state(to_proto_box_state(c.state));
    m->set_ohf_min(c.ohf_min);
  }
  out.set_boxes(static_cast<std::uint32_t>(a.boxes));
  out.set_visible(static_cast<std::uint32_t>(a.visible));
  for (std::size_t k = 0; k < a.levels.size(); ++k) {
    const clipmap::LevelReport& l = a.levels[k];
    v1::LevelStatus* m = out.add_levels();
    m->set_level(static_cast<std::uint32_t>(k));
    m->set_col0(l.state.origin.col0);
    m->set_row0(l.state.origin.row0);
    m->set_full_extent(l.state.full_extent);
    m->set_version(l.state.version);
    m->set_staleness(l.staleness);
    m->set_resident_subtiles(l.state.resident_subtiles);
  }
  out.set_rays(a.cull.rays_traced);
  out.set_rings(a.cull.rings);
  out.set_samples(a.cull.samples);
  out.set_fallbacks(a.cull.fallbacks);
  out.set_subtiles_loaded(a.subtiles_loaded);
  out.set_bytes_loaded(a.bytes_loaded);
  out.set_seconds(a.seconds);
  if (a.loader_error) out.set_loader_error(a.loader_error->message);
  if (!a.levels.empty()) out.set_backend(a.cull.gpu ? "gpu" : "cpu");  // exact answers have no trace
  out.set_gpu_fallback(a.gpu_fallback);
  if (a.viewshed) {
    v1::PoseViewshed* v = out.mutable_viewshed();
    v->set_visible_cells(a.viewshed->visible_cells);
    v->set_hidden_cells(a.viewshed->hidden_cells);
    v->set_col0(a.viewshed->window.col0);
    v->set_row0(a.viewshed->window.row0);
    v->set_width(static_cast<std::uint32_t>(a.viewshed->window.width()));
    v->set_height(static_cast<std::uint32_t>(a.viewshed->window.height()));
    v->set_seconds(a.viewshed->seconds);
  }
}

}  // namespace horizon::server
