// TraceCamera: one camera frame over a dataset, per pixel (the tracing
// itself is core's trace/; this translates, bounds, runs and streams).
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "arena_allocator.hpp"
#include "call_scope.hpp"
#include "handoff.hpp"
#include "horizon/trace/products.hpp"
#include "horizon/trace/trace_plan.hpp"
#include "raster_files.hpp"
#include "trace_service.hpp"
#include "trace_translate.hpp"
#include "translate.hpp"
#include "viewshed_call.hpp"

namespace horizon::server {
namespace {

static_assert(std::endian::native == std::endian::little,
              "channel rows are sent in host order, which must be little-endian");

// The server's own memory per pixel and per cell read, beyond the plan's
// cost.bytes (which holds the cells, the trace image, the kernels' maps and
// trees, the depth and hit images and the footprint grid): each channel's
// bytes as sent, the shaded view's per-pixel hits and pixels, and the
// footprint's GeoTIFF bytes.
constexpr std::uint64_t kShadedBytesPerPixel = sizeof(trace::Hit) + 3 + 3;
constexpr std::uint64_t kFootprintBytesPerCell = 2;

std::uint64_t server_bytes(const TraceAsk& ask, bool footprint, std::uint64_t pixels, std::uint64_t read_cells) {
  std::uint64_t bytes = 0;
  for (v1::TraceChannel c : ask.channels)
    bytes += pixels * (c == v1::TRACE_CHANNEL_SHADED_RGB ? kShadedBytesPerPixel : channel_pixel_bytes(c));
  if (footprint) bytes += read_cells * kFootprintBytesPerCell;
  return bytes;
}

// One channel's pixels in its wire layout (trace.proto, TraceChannel).
std::string channel_bytes(v1::TraceChannel channel, const trace::TraceRun& run) {
  const trace::TraceResult& frame = run.frame;
  const int width = frame.image.width, height = frame.image.height;
  const std::size_t pixels = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  std::string out(pixels * channel_pixel_bytes(channel), '\0');
  char* p = out.data();
  const auto put = [&p](const auto value) {
    std::memcpy(p, &value, sizeof value);
    p += sizeof value;
  };
  constexpr float kNaNf = std::numeric_limits<float>::quiet_NaN();
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  switch (channel) {
    case v1::TRACE_CHANNEL_DEPTH: {
      const terrain::Grid<float> depth = trace::depth_image(frame);
      if (pixels) std::memcpy(out.data(), depth.data(), pixels * sizeof(float));
      break;
    }
    case v1::TRACE_CHANNEL_HIT_CELL:
      // As trace::hit_images(frame, window.col0, window.row0) computes them.
      for (int j = 0; j < height; ++j)
        for (int x = 0; x < width; ++x) {
          const trace::Hit h = frame.hit(x, j);
          put(h.sky ? kNaNf : static_cast<float>(h.col + run.window.col0));
          put(h.sky ? kNaNf : static_cast<float>(h.row + run.window.row0));
        }
      break;
    case v1::TRACE_CHANNEL_HIT_XYZ: {
      const terrain::GeoTransform& t = run.georef.transform;  // the read window's: its cell (0, 0) is the view's
      for (int j = 0; j < height; ++j)
        for (int x = 0; x < width; ++x) {
          const trace::Hit h = frame.hit(x, j);
          put(h.sky ? kNaN : t.x_at(h.col));
          put(h.sky ? kNaN : t.y_at(h.row));
          put(h.sky ? kNaNf : static_cast<float>(h.elevation));
        }
      break;
    }
    case v1::TRACE_CHANNEL_SHADED_RGB: {
      const std::vector<std::uint8_t> rgb = trace::shaded_view(frame, run.view());
      if (!rgb.empty()) std::memcpy(out.data(), rgb.data(), std::min(out.size(), rgb.size()));
      break;
    }
    default:
      break;
  }
  return out;
}

class TraceCall final : public grpc::ServerWriteReactor<v1::TraceResponse> {
 public:
  TraceCall(ServerEnv& env, grpc::CallbackServerContext* context, const v1::TraceRequest& request)
      : scope_(env, context, "TraceCamera"), request_(request) {}

  void start() {
    if (auto refused = scope_.admit(request_, held_bytes(request_))) return finish(*refused);
    handoff_.publish();  // gRPC may run OnCancel from now on
    scope_.env().pool.post([this, ticket = scope_.ticket()]() mutable {
      if (!ticket.take()) return;  // cancelled in the queue: finished, perhaps deleted
      const grpc::Status status = compute();
      if (!status.ok()) return finish(status);
      write_next();
    });
  }

  void OnWriteDone(bool ok) override {
    handoff_.from_grpc();
    // The client went away, or DeadlineWatch ended a stream it did not read by the deadline.
    if (!ok) return finish(scope_.status_of(make_error(ErrorCode::kCancelled, "the client went away mid-stream")));
    write_next();
  }
  void OnCancel() override {
    handoff_.from_grpc();
    if (auto dropped = scope_.cancel()) return finish(*dropped);
    handoff_.publish();  // gRPC runs OnDone only after this returns
  }
  void OnDone() override {
    handoff_.from_grpc();
    delete this;
  }

 private:
  grpc::Status compute();
  void write_next();
  void write(const v1::TraceResponse* message) {
    handoff_.to_grpc([&] { StartWrite(message); });
  }
  void finish(const grpc::Status& status) {
    {
      std::lock_guard lock(mutex_);
      if (finished_) return;
      finished_ = true;
    }
    scope_.finish(status);
    handoff_.to_grpc([&] { Finish(status); });  // after this, `this` may be deleted at any time
  }

  Handoff handoff_;
  CallScope scope_;
  const v1::TraceRequest request_;  // a copy: the call's own lives only until Finish
  std::mutex mutex_;
  bool finished_ = false;

  // Phase 2 state, written by compute() before the first write, then only by
  // the write chain (one write in flight at a time).
  enum class Stage { kHeader, kChannels, kFootprint, kDone };
  Stage stage_ = Stage::kHeader;
  v1::TraceHeader header_;
  std::vector<v1::TraceChannel> channels_;
  std::vector<std::string> data_;  // per channel, its rows in wire layout
  std::string footprint_;          // the footprint GeoTIFF's bytes, when asked for
  std::size_t channel_ = 0;        // the channel being sent
  std::size_t chunk_bytes_ = kDefaultChunkBytes;
  std::size_t cursor_ = 0;  // rows sent of the channel, or bytes of the footprint
  v1::TraceResponse message_;
};

grpc::Status TraceCall::compute() {
  const v1::TraceRequest& req = request_;
  if (req.max_chunk_bytes() < 0)
    return scope_.status_of(
        make_error(ErrorCode::kInvalidArgument, "max_chunk_bytes: must be >= 0", "max_chunk_bytes"));
  chunk_bytes_ = chunk_bytes_for(req.max_chunk_bytes());
  auto dataset = scope_.dataset(req.dataset());
  if (!dataset.ok()) return scope_.status_of(dataset.error());
  const Dataset& d = **dataset;
  const ServerEnv& env = scope_.env();
  const Limits& limits = env.config.limits;

  const int n = req.boxes_size();
  scope_.record().boxes = static_cast<std::uint64_t>(n);
  if (static_cast<std::uint64_t>(n) > limits.max_boxes)
    return scope_.status_of(make_error(
        ErrorCode::kResourceExhausted,
        "boxes: " + std::to_string(n) + " boxes, more than limits.max_boxes = " + std::to_string(limits.max_boxes),
        "boxes"));
  // Every field checked, the camera's frame size among them.
  auto ask = to_trace_ask(req, d.header(), env.config.engine_threads);
  if (!ask.ok()) return scope_.status_of(ask.error());
  const trace::CameraSpec camera = ask->query.camera;  // a copy: the query is dropped once planned
  const std::uint64_t pixels = static_cast<std::uint64_t>(camera.width) * static_cast<std::uint64_t>(camera.height);
  if (pixels > limits.max_trace_pixels)
    return scope_.status_of(make_error(ErrorCode::kResourceExhausted,
                                       "camera: a " + std::to_string(camera.width) + "x" +
                                           std::to_string(camera.height) + " frame is " + std::to_string(pixels) +
                                           " pixels, more than limits.max_trace_pixels = " +
                                           std::to_string(limits.max_trace_pixels) + "; ask a smaller width and height",
                                       "camera"));
  scope_.record().algorithm = ask->query.options.column_crossings ? "trace rows+columns" : "trace rows";

  // The plan: the eye placed on the header, the wedge's cells and blocks
  // named, boxes and edits resolved, the cost known; nothing read yet.
  auto plan = trace::plan_trace(*d.source, ask->query, env.config.engine_threads);
  if (!plan.ok()) return scope_.status_of(rename_trace_field(plan.error()));
  ask->query = {};  // the plan holds its own copy of the boxes and edits
  const trace::TraceCost& cost = plan->cost;
  scope_.record().cells = cost.read_cells;
  if (cost.read_cells > limits.max_cells)
    return scope_.status_of(make_error(ErrorCode::kResourceExhausted,
                                       "options.max_distance: the view's wedge covers " +
                                           std::to_string(cost.read_cells) +
                                           " cells, more than limits.max_cells = " + std::to_string(limits.max_cells) +
                                           "; give a smaller max_distance (or a narrower hfov)",
                                       "options.max_distance"));
  const std::uint64_t bytes = cost.bytes + server_bytes(*ask, req.include_footprint(), pixels, cost.read_cells);
  if (auto s =
          scope_.reserve(bytes, "this trace (" + std::to_string(camera.width) + "x" + std::to_string(camera.height) +
                                    " pixels over " + std::to_string(cost.read_cells) + " cells)");
      !s.ok())
    return scope_.status_of(s.error());

  // BACKEND_GPU: one of the daemon's contexts for this frame (waiting while all are lent).
  std::optional<gpu::Lease> lease;
  std::string gpu_unavailable;
  if (ask->gpu) {
    if (!env.gpu) {
      gpu_unavailable = "this daemon has no GPU contexts (config gpu.contexts, or no EGL display)";
    } else if (auto borrowed = env.gpu->borrow(); borrowed.ok()) {
      lease.emplace(std::move(*borrowed));
    } else {
      gpu_unavailable = borrowed.error().message;
    }
  }
  auto run = trace::run_trace(*plan, *d.source, &env.cache, scope_.control(), lease ? &*lease : nullptr);
  lease.reset();  // on this thread, as EGL wants
  if (!run.ok()) return scope_.status_of(rename_trace_field(run.error()));
  trace::TraceStats& st = run->frame.stats;
  if (st.gpu_fallback.empty()) st.gpu_fallback = gpu_unavailable;
  scope_.record().backend = st.backend;
  scope_.record().gpu_fallback = st.gpu_fallback;  // a fallback puts the request's line at level warn

  // The channels asked for, in order, each from the one frame.
  channels_ = ask->channels;
  for (v1::TraceChannel c : channels_) {
    if (auto s = check_control(scope_.control()); !s.ok()) return scope_.status_of(s.error());
    data_.push_back(channel_bytes(c, *run));
  }
  if (req.include_footprint()) {
    if (auto s = check_control(scope_.control()); !s.ok()) return scope_.status_of(s.error());
    auto bytes_or = geotiff_bytes(env.scratch, trace::footprint(run->frame, run->view()), run->georef, 255.0);
    if (!bytes_or.ok()) return scope_.status_of(bytes_or.error());
    footprint_ = std::move(*bytes_or);
  }
  if (auto s = check_control(scope_.control()); !s.ok()) return scope_.status_of(s.error());

  header_.set_width(camera.width);
  header_.set_height(camera.height);
  for (v1::TraceChannel c : channels_) header_.add_channels(c);
  fill_point(run->eye, d.header().georef, *header_.mutable_camera());
  header_.set_cell_size_x_m(run->frame.camera.metres_per_col);
  header_.set_cell_size_y_m(run->frame.camera.metres_per_row);
  fill_window(run->window, *header_.mutable_read_window());
  fill_transform(run->georef.transform, *header_.mutable_read_transform());
  header_.set_epsg(run->georef.epsg);
  header_.set_dem_cells(static_cast<std::uint64_t>(d.header().width) * static_cast<std::uint64_t>(d.header().height));
  header_.set_blocks(run->read.blocks);
  header_.set_blocks_total(run->read.blocks_total);
  header_.set_edited_cells(run->edited_cells);
  v1::TraceStats& out = *header_.mutable_stats();
  out.set_sub_frusta(st.sub_frusta);
  out.set_pixels(st.pixels);
  out.set_sky_pixels(st.sky_pixels);
  out.set_crossings(st.crossings);
  out.set_tree_texels(st.tree_texels);
  out.set_lines(st.max_lines);
  out.set_reads_per_pixel(st.reads_per_pixel);
  out.set_seconds(st.seconds);
  out.set_backend(st.backend);
  out.set_gpu_fallback(st.gpu_fallback);
  header_.mutable_boxes()->Reserve(n);
  for (int i = 0; i < n; ++i) {
    const trace::BoxView& b = run->boxes[static_cast<std::size_t>(i)];
    v1::BoxView* box = header_.add_boxes();
    box->set_id(req.boxes(i).id());
    box->set_pixels(b.pixels);
    box->set_visible_pixels(b.visible);
  }
  return grpc::Status::OK;
}

void TraceCall::write_next() {
  message_.Clear();
  while (true) {
    switch (stage_) {
      case Stage::kHeader:
        *message_.mutable_header() = header_;
        stage_ = Stage::kChannels;
        channel_ = 0;
        cursor_ = 0;
        return write(&message_);
      case Stage::kChannels: {
        if (channel_ >= channels_.size()) {
          stage_ = Stage::kFootprint;
          cursor_ = 0;
          continue;
        }
        const int height = header_.height();
        std::string& data = data_[channel_];
        if (static_cast<int>(cursor_) >= height) {
          data.clear();
          data.shrink_to_fit();
          ++channel_;
          cursor_ = 0;
          continue;
        }
        const std::size_t row_bytes =
            static_cast<std::size_t>(header_.width()) * channel_pixel_bytes(channels_[channel_]);
        const int rows_per_chunk = static_cast<int>(std::max<std::size_t>(1, chunk_bytes_ / row_bytes));
        const int row0 = static_cast<int>(cursor_);
        const int rows = std::min(rows_per_chunk, height - row0);
        auto* chunk = message_.mutable_rows();
        chunk->set_channel(channels_[channel_]);
        chunk->set_row0(row0);
        chunk->set_rows(rows);
        chunk->set_data(data.data() + static_cast<std::size_t>(row0) * row_bytes,
                        static_cast<std::size_t>(rows) * row_bytes);
        cursor_ += static_cast<std::size_t>(rows);
        return write(&message_);
      }
      case Stage::kFootprint: {
        if (cursor_ >= footprint_.size()) {
          footprint_.clear();
          footprint_.shrink_to_fit();
          stage_ = Stage::kDone;
          continue;
        }
        const std::size_t n = std::min(chunk_bytes_, footprint_.size() - cursor_);
        auto* chunk = message_.mutable_file_chunk();
        chunk->set_kind(v1::FileChunk::KIND_GEOTIFF);
        chunk->set_offset(cursor_);
        chunk->set_total_size(footprint_.size());
        chunk->set_data(footprint_.data() + cursor_, n);
        cursor_ += n;
        return write(&message_);
      }
      case Stage::kDone:
        return finish(grpc::Status::OK);
    }
  }
}

}  // namespace

grpc::ServerWriteReactor<v1::TraceResponse>* start_trace_call(ServerEnv& env, grpc::CallbackServerContext* context,
                                                              const v1::TraceRequest* request) {
  auto* call = new TraceCall(env, context, *request);
  call->start();
  return call;
}

}  // namespace horizon::server
