#include "trace_translate.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "translate.hpp"

namespace horizon::server {
namespace {

Error invalid(const std::string& field, const std::string& what) {
  return make_error(ErrorCode::kInvalidArgument, field + ": " + what, field);
}

// The cells whose centres lie in the rectangle (edges included), clipped to
// the dataset: what `horizon trace --edit` changes. Clamped in double before
// any cast, so a rectangle far off the dataset is an empty window, not an
// overflow.
terrain::Window rectangle_cells(const v1::EditRectangle& r, const terrain::DemHeader& h) {
  const terrain::GeoTransform& t = h.georef.transform;
  const double c0 = t.col_at(r.x_min()), c1 = t.col_at(r.x_max());
  const double r0 = t.row_at(r.y_min()), r1 = t.row_at(r.y_max());
  const auto first = [](double v, int n) { return static_cast<int>(std::clamp(std::ceil(v), 0.0, double(n))); };
  const auto end = [](double v, int n) { return static_cast<int>(std::clamp(std::floor(v) + 1.0, 0.0, double(n))); };
  return {first(std::min(c0, c1), h.width), first(std::min(r0, r1), h.height), end(std::max(c0, c1), h.width),
          end(std::max(r0, r1), h.height)};
}

Result<terrain::HeightEdit> to_edit(const v1::HeightEdit& in, const terrain::DemHeader& h, int i) {
  const std::string name = "edits[" + std::to_string(i) + "]";
  terrain::HeightEdit edit;
  switch (in.mode()) {
    case v1::EDIT_MODE_UNSPECIFIED:
    case v1::EDIT_MODE_SET:
      edit.mode = terrain::EditMode::kSet;
      break;
    case v1::EDIT_MODE_RAISE:
      edit.mode = terrain::EditMode::kRaise;
      break;
    default:
      return invalid(name + ".mode", "unknown value " + std::to_string(static_cast<int>(in.mode())));
  }
  switch (in.area_case()) {
    case v1::HeightEdit::kRect: {
      const v1::EditRectangle& r = in.rect();
      const std::string field = name + ".rect";
      for (const auto& [key, v] : {std::pair{"x_min", r.x_min()}, std::pair{"y_min", r.y_min()},
                                   std::pair{"x_max", r.x_max()}, std::pair{"y_max", r.y_max()}})
        if (!std::isfinite(v)) return invalid(field + "." + key, "not a finite number");
      if (r.x_max() < r.x_min()) return invalid(field + ".x_max", "less than x_min");
      if (r.y_max() < r.y_min()) return invalid(field + ".y_max", "less than y_min");
      edit.cells = rectangle_cells(r, h);
      if (edit.cells.empty())
        return make_error(ErrorCode::kOutOfRange,
                          field + ": the rectangle holds no cell centre of the dataset (" + std::to_string(h.width) +
                              "x" + std::to_string(h.height) + " cells)",
                          field);
      break;
    }
    case v1::HeightEdit::kCells:
      // Checked against the dataset by terrain::validate_edits ("edits[i].cells").
      edit.cells = {in.cells().col0(), in.cells().row0(), in.cells().col1(), in.cells().row1()};
      break;
    default:
      return invalid(name + ".rect", "an edit needs its cells: a rect (dataset CRS) or cells (a grid window)");
  }
  edit.heights.assign(in.heights().begin(), in.heights().end());
  return edit;
}

}  // namespace

Result<TraceAsk> to_trace_ask(const v1::TraceRequest& request, const terrain::DemHeader& header, unsigned threads) {
  TraceAsk ask;
  if (!request.has_camera()) return invalid("camera", "required");
  const v1::Camera& cam = request.camera();
  if (!cam.has_position()) return invalid("camera.position", "required");
  trace::CameraSpec& c = ask.query.camera;
  auto position = to_point_spec(cam.position(), "camera.position");
  if (!position.ok()) return position.error();
  c.position = *position;
  c.yaw = cam.yaw();
  c.pitch = cam.pitch();
  c.hfov = cam.hfov();
  c.width = cam.width();
  c.height = cam.height();
  switch (cam.projection()) {
    case v1::PROJECTION_UNSPECIFIED:
    case v1::PROJECTION_PERSPECTIVE:
      c.projection = trace::Projection::kPerspective;
      break;
    case v1::PROJECTION_CYLINDRICAL:
      c.projection = trace::Projection::kCylindrical;
      break;
    default:
      return invalid("camera.projection", "unknown value " + std::to_string(static_cast<int>(cam.projection())));
  }
  if (Status s = trace::validate_camera(c); !s.ok()) {
    Error e = s.error();
    e.field = "camera." + e.field;
    e.message = "camera." + e.message.substr(std::string("camera ").size());
    return e;
  }

  const v1::TraceOptions& in = request.options();
  trace::TraceOptions& o = ask.query.options;
  if (in.has_near()) o.near = in.near();
  if (in.has_max_distance()) o.max_distance = in.max_distance();
  if (in.has_curvature()) o.curvature_coefficient = in.curvature();
  switch (in.nodata()) {
    case v1::NODATA_POLICY_UNSPECIFIED:
    case v1::NODATA_POLICY_TRANSPARENT:
      o.nodata = visibility::NodataPolicy::kTransparent;
      break;
    case v1::NODATA_POLICY_FILL:
      o.nodata = visibility::NodataPolicy::kFill;
      break;
    default:
      return invalid("options.nodata", "unknown value " + std::to_string(static_cast<int>(in.nodata())));
  }
  o.nodata_fill_height = in.nodata_fill_height();
  o.column_crossings = in.column_crossings();
  o.threads = threads;
  auto backend = to_backend(in.backend(), "options.backend");
  if (!backend.ok()) return backend.error();
  ask.gpu = *backend == visibility::Backend::kGpu;
  if (Status s = trace::validate_trace_options(o); !s.ok()) return rename_trace_field(s.error());

  auto boxes = to_boxes(request.boxes());
  if (!boxes.ok()) return boxes.error();
  ask.query.boxes = std::move(*boxes);
  ask.query.edits.reserve(static_cast<std::size_t>(request.edits_size()));
  for (int i = 0; i < request.edits_size(); ++i) {
    auto edit = to_edit(request.edits(i), header, i);
    if (!edit.ok()) return edit.error();
    ask.query.edits.push_back(std::move(*edit));
  }

  for (int i = 0; i < request.channels_size(); ++i) {
    const auto channel = static_cast<v1::TraceChannel>(request.channels(i));
    const std::string field = "channels[" + std::to_string(i) + "]";
    if (channel_pixel_bytes(channel) == 0)
      return invalid(field, "unknown or unset channel value " + std::to_string(static_cast<int>(channel)));
    if (std::find(ask.channels.begin(), ask.channels.end(), channel) != ask.channels.end())
      return invalid(field, std::string(v1::TraceChannel_Name(channel)) + " is asked for twice");
    ask.channels.push_back(channel);
  }
  return ask;
}

Error rename_trace_field(Error error) {
  const std::string engine = error.field;
  std::string& f = error.field;
  if (f == "curvature_coefficient") {
    f = "options.curvature";
  } else if (f == "near" || f == "max_distance" || f == "nodata_fill_height") {
    f = "options." + f;
  } else if (f.starts_with("camera.position")) {
    if (f.ends_with(".lon")) f.replace(f.size() - 3, 3, "x");
    if (f.ends_with(".lat")) f.replace(f.size() - 3, 3, "y");
  }
  // The message names the field as the client sent it.
  if (f != engine && error.message.starts_with(engine)) error.message.replace(0, engine.size(), f);
  return error;
}

std::size_t channel_pixel_bytes(v1::TraceChannel channel) {
  switch (channel) {
    case v1::TRACE_CHANNEL_DEPTH:
      return sizeof(float);
    case v1::TRACE_CHANNEL_HIT_CELL:
      return 2 * sizeof(float);
    case v1::TRACE_CHANNEL_HIT_XYZ:
      return 2 * sizeof(double) + sizeof(float);
    case v1::TRACE_CHANNEL_SHADED_RGB:
      return 3;
    default:
      return 0;
  }
}

}  // namespace horizon::server
