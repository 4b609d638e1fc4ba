// `horizon trace DATASET --server HOST:PORT ...`: the daemon traces one frame
// (TraceService.TraceCamera); this writes the same depth and hit TIFFs
// (terrain::write_tiff_image), PNG (the shaded view's pixels through
// imageio::write_png) and footprint GeoTIFF (the daemon's bytes) as embedded
// mode, and prints its report.
#include <chrono>
#include <cmath>
#include <cstring>
#include <iostream>
#include <map>

#include "commands/command.hpp"
#include "commands/trace.hpp"
#include "horizon/terrain/geotiff_writer.hpp"
#include "output.hpp"
#include "remote/client.hpp"
#include "remote/files.hpp"
#include "remote/module_abi.hpp"

namespace horizon::cli::remote {
namespace {

std::size_t pixel_bytes(v1::TraceChannel channel) {
  switch (channel) {
    case v1::TRACE_CHANNEL_DEPTH:
      return 4;
    case v1::TRACE_CHANNEL_HIT_CELL:
      return 8;
    case v1::TRACE_CHANNEL_HIT_XYZ:
      return 20;
    case v1::TRACE_CHANNEL_SHADED_RGB:
      return 3;
    default:
      return 0;
  }
}

v1::TraceRequest make_request(const TraceInputs& in) {
  v1::TraceRequest request;
  request.set_dataset(in.dataset);
  v1::Camera& c = *request.mutable_camera();
  *c.mutable_position() = to_proto_point(in.camera.position);
  c.set_yaw(in.camera.yaw);
  c.set_pitch(in.camera.pitch);
  c.set_hfov(in.camera.hfov);
  c.set_width(in.camera.width);
  c.set_height(in.camera.height);
  c.set_projection(in.camera.projection == trace::Projection::kCylindrical ? v1::PROJECTION_CYLINDRICAL
                                                                           : v1::PROJECTION_PERSPECTIVE);
  v1::TraceOptions& o = *request.mutable_options();
  o.set_near(in.options.near);
  if (std::isfinite(in.options.max_distance)) o.set_max_distance(in.options.max_distance);
  o.set_curvature(in.options.curvature_coefficient);
  if (in.options.nodata == visibility::NodataPolicy::kFill) {
    o.set_nodata(v1::NODATA_POLICY_FILL);
    o.set_nodata_fill_height(in.options.nodata_fill_height);
  }
  o.set_column_crossings(in.options.column_crossings);
  o.set_backend(in.gpu ? v1::BACKEND_GPU : v1::BACKEND_CPU);
  request.mutable_boxes()->Reserve(static_cast<int>(in.boxes.size()));
  for (std::size_t i = 0; i < in.boxes.size(); ++i) {
    v1::Box& box = *request.add_boxes() = to_proto_box(in.boxes[i]);
    if (!in.box_ids.empty()) box.set_id(in.box_ids[i]);
  }
  for (const TraceEditRect& e : in.edits) {
    v1::HeightEdit& edit = *request.add_edits();
    v1::EditRectangle& r = *edit.mutable_rect();
    r.set_x_min(e.x_min);
    r.set_y_min(e.y_min);
    r.set_x_max(e.x_max);
    r.set_y_max(e.y_max);
    edit.set_mode(e.mode == terrain::EditMode::kRaise ? v1::EDIT_MODE_RAISE : v1::EDIT_MODE_SET);
    edit.add_heights(e.height);
  }
  if (in.depth_path) request.add_channels(v1::TRACE_CHANNEL_DEPTH);
  if (in.hits_path) {
    request.add_channels(v1::TRACE_CHANNEL_HIT_CELL);
    request.add_channels(v1::TRACE_CHANNEL_HIT_XYZ);  // its elevations are the third band
  }
  if (in.png_path) request.add_channels(v1::TRACE_CHANNEL_SHADED_RGB);
  request.set_include_footprint(in.footprint_path.has_value());
  return request;
}

// One float32 image from a channel's rows: the float at byte `offset` of
// each pixel's `stride` bytes.
terrain::Grid<float> band(const std::string& data, int width, int height, std::size_t stride, std::size_t offset) {
  terrain::Grid<float> grid(width, height, terrain::kUninitialized);
  float* out = grid.data();
  const std::size_t n = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  for (std::size_t i = 0; i < n; ++i) std::memcpy(out + i, data.data() + i * stride + offset, sizeof(float));
  return grid;
}

}  // namespace

int impl::run_trace(const Args& args, const TraceInputs& in) {
  Client client(args);
  const auto started = std::chrono::steady_clock::now();
  v1::Dataset dataset;
  if (auto s = client.get_dataset(in.dataset, dataset); !s.ok()) return report_status(s, client.address());

  const v1::TraceRequest request = make_request(in);
  auto context = client.context();
  auto reader = client.traces().TraceCamera(context.get(), request);
  v1::TraceResponse message;
  v1::TraceHeader header;
  bool have_header = false;
  std::map<int, std::string> channels;  // by TraceChannel value, rows appended in order
  std::string footprint;
  const auto refuse = [&](const std::string& what) {
    context->TryCancel();
    reader->Finish();
    return report_error(make_error(ErrorCode::kDataError, "the daemon sent " + what));
  };
  while (reader->Read(&message)) {
    if (message.has_header()) {
      header = message.header();
      have_header = true;
    } else if (message.has_rows()) {
      const v1::TraceRows& rows = message.rows();
      const std::size_t row_bytes = static_cast<std::size_t>(header.width()) * pixel_bytes(rows.channel());
      std::string& data = channels[rows.channel()];
      if (!have_header || row_bytes == 0 || rows.rows() < 1 ||
          static_cast<std::size_t>(rows.row0()) * row_bytes != data.size() ||
          rows.data().size() != static_cast<std::size_t>(rows.rows()) * row_bytes ||
          rows.row0() + rows.rows() > header.height())
        return refuse("rows out of order or of the wrong size");
      data += rows.data();
    } else if (message.has_file_chunk()) {
      if (message.file_chunk().offset() != footprint.size()) return refuse("file bytes out of order");
      footprint += message.file_chunk().data();
    }
  }
  if (auto s = reader->Finish(); !s.ok()) return report_status(s, client.address());
  const int width = header.width(), height = header.height();
  const std::size_t pixels = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  if (!have_header || width != in.camera.width || height != in.camera.height ||
      header.boxes_size() != static_cast<int>(in.boxes.size()))
    return report_error(make_error(ErrorCode::kDataError, "the daemon sent no header for this frame"));
  for (int c : request.channels())
    if (channels[c].size() != pixels * pixel_bytes(static_cast<v1::TraceChannel>(c)))
      return report_error(make_error(ErrorCode::kDataError, "the daemon sent too few rows of a channel"));

  // The files, in embedded mode's order.
  const auto writing = std::chrono::steady_clock::now();
  if (in.depth_path) {
    const terrain::Grid<float> depth = band(channels[v1::TRACE_CHANNEL_DEPTH], width, height, 4, 0);
    const terrain::Grid<float>* bands[] = {&depth};
    if (Status s = terrain::write_tiff_image(*in.depth_path, bands); !s.ok()) return report_error(s.error());
  }
  if (in.hits_path) {
    const std::string& cells = channels[v1::TRACE_CHANNEL_HIT_CELL];
    const std::string& xyz = channels[v1::TRACE_CHANNEL_HIT_XYZ];
    const terrain::Grid<float> col = band(cells, width, height, 8, 0), row = band(cells, width, height, 8, 4),
                               elevation = band(xyz, width, height, 20, 16);
    const terrain::Grid<float>* bands[] = {&col, &row, &elevation};
    if (Status s = terrain::write_tiff_image(*in.hits_path, bands); !s.ok()) return report_error(s.error());
  }
  if (in.footprint_path)
    if (Status s = write_file_atomic(*in.footprint_path, footprint); !s.ok()) return report_error(s.error());
  if (in.png_path)
    if (Status s =
            write_png_atomic(*in.png_path, width, height,
                             reinterpret_cast<const std::uint8_t*>(channels[v1::TRACE_CHANNEL_SHADED_RGB].data()));
        !s.ok())
      return report_error(s.error());

  TraceReport report;
  report.dem = in.dataset;
  report.server = client.address();
  report.eye = to_grid_point(header.camera());
  report.eye_lonlat = to_lonlat(header.camera());
  report.geographic = dataset.geographic();
  report.camera = in.camera;
  report.columns = in.options.column_crossings;
  const v1::TraceStats& s = header.stats();
  trace::TraceStats& st = report.stats;
  st.sub_frusta = s.sub_frusta();
  st.pixels = s.pixels();
  st.sky_pixels = s.sky_pixels();
  st.crossings = s.crossings();
  st.tree_texels = s.tree_texels();
  st.max_lines = s.lines();
  st.reads_per_pixel = s.reads_per_pixel();
  st.seconds = s.seconds();
  st.backend = s.backend().empty() ? "cpu" : s.backend();
  st.gpu_fallback = s.gpu_fallback();
  if (in.gpu && !st.gpu_fallback.empty())
    std::cerr << "horizon: warning: GPU not used (" << st.gpu_fallback << "); answered on the CPU\n";
  const v1::Window& w = header.read_window();
  report.window = {w.col0(), w.row0(), w.col1(), w.row1()};
  report.dem_cells = header.dem_cells();
  report.blocks = header.blocks();
  report.blocks_total = header.blocks_total();
  report.edited_cells = header.edited_cells();
  for (const v1::BoxView& b : header.boxes()) {
    report.boxes.push_back({b.pixels(), b.visible_pixels()});
    if (!in.box_ids.empty()) report.ids.push_back(b.id());  // the daemon's echo
  }
  const auto now = std::chrono::steady_clock::now();
  report.total_seconds = std::chrono::duration<double>(now - started).count();
  report.write_seconds = std::chrono::duration<double>(now - writing).count();
  print_trace(report, in.json);
  return kExitOk;
}

}  // namespace horizon::cli::remote
