#include "viewshed_call.hpp"

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstring>
#include <mutex>
#include <string>

#include "arena_allocator.hpp"
#include "call_scope.hpp"
#include "handoff.hpp"
#include "horizon/geodesy/observer.hpp"
#include "horizon/visibility/plan.hpp"
#include "horizon/visibility/viewshed.hpp"
#include "horizon/visibility/viewshed_preview.hpp"
#include "raster_files.hpp"
#include "translate.hpp"
#include "viewshed_many_call.hpp"
#include "viewshed_output.hpp"
#include "worker_memory.hpp"

namespace horizon::server {
namespace {

static_assert(std::endian::native == std::endian::little,
              "raster chunks are sent in host order, which must be little-endian");

class ViewshedCall final : public grpc::ServerWriteReactor<v1::ViewshedResponse> {
 public:
  ViewshedCall(ServerEnv& env, grpc::CallbackServerContext* context, const v1::ViewshedRequest& request)
      : scope_(env, context, "ComputeViewshed"), request_(request) {}

  void start() {
    if (auto refused = scope_.admit(request_, held_bytes(request_))) return finish(*refused);
    if (request_.include_progress()) scope_.set_progress([this](double fraction) { on_progress(fraction); });
    handoff_.publish();  // gRPC may run OnCancel from now on
    scope_.env().pool.post([this, ticket = scope_.ticket()]() mutable {
      if (!ticket.take()) return;  // cancelled in the queue: finished, perhaps deleted
      computing_since_ = std::chrono::steady_clock::now();
      if (request_.include_progress()) on_progress(0.0);
      const grpc::Status status = compute();
      if (!status.ok()) return finish(status);
      {
        std::lock_guard lock(progress_mutex_);
        streaming_ = true;  // no progress write starts from now on
        if (progress_in_flight_) {
          stream_waiting_ = true;  // OnWriteDone of that write starts the stream
          return;
        }
      }
      write_next();
    });
  }

  void OnWriteDone(bool ok) override {
    handoff_.from_grpc();
    // The client went away, or DeadlineWatch ended a stream it did not read by the deadline.
    if (!ok) return finish(scope_.status_of(make_error(ErrorCode::kCancelled, "the client went away mid-stream")));
    {
      std::lock_guard lock(progress_mutex_);
      if (progress_in_flight_) {  // the write done was a progress message
        progress_in_flight_ = false;
        if (!stream_waiting_) return;  // still computing
        stream_waiting_ = false;
      }
    }
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
  // From the engine's workers: one progress message in flight at most, the
  // first at once, then every kProgressInterval; none once the stream began.
  void on_progress(double fraction) {
    const auto now = std::chrono::steady_clock::now();
    {
      std::lock_guard lock(progress_mutex_);
      if (streaming_ || progress_in_flight_ || fraction < progress_sent_ ||
          (progress_count_ > 0 && now - progress_at_ < kProgressInterval))
        return;
      progress_in_flight_ = true;
      progress_at_ = now;
      progress_sent_ = fraction;
      ++progress_count_;
      v1::ViewshedProgress* p = progress_message_.mutable_progress();
      p->set_fraction(std::clamp(fraction, 0.0, 1.0));
      p->set_seconds(std::chrono::duration<double>(now - computing_since_).count());
    }
    write(&progress_message_);
  }
  grpc::Status compute();
  void write_next();
  void write(const v1::ViewshedResponse* message) {
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
  const v1::ViewshedRequest request_;  // a copy: the call's own lives only until Finish
  std::mutex mutex_;
  bool finished_ = false;

  // Progress messages while computing (include_progress), guarded by progress_mutex_.
  static constexpr std::chrono::milliseconds kProgressInterval{250};
  std::mutex progress_mutex_;
  bool progress_in_flight_ = false;
  bool streaming_ = false;       // compute() is done: the write chain owns the stream
  bool stream_waiting_ = false;  // ... and waits for the progress write in flight
  int progress_count_ = 0;
  double progress_sent_ = 0.0;
  std::chrono::steady_clock::time_point progress_at_;
  std::chrono::steady_clock::time_point computing_since_;
  v1::ViewshedResponse progress_message_;

  // Phase 2 state, written by compute() before the first write, then only by
  // the write chain (one write in flight at a time).
  enum class Stage { kHeader, kRaster, kGeotiff, kPng, kSummary, kDone };
  Stage stage_ = Stage::kHeader;
  v1::ViewshedHeader header_;
  v1::ViewshedSummary summary_;
  std::string raster_;  // raw little-endian rows, when asked for
  std::string geotiff_, png_;
  std::size_t row_bytes_ = 0;
  std::size_t chunk_bytes_ = kDefaultChunkBytes;
  std::size_t cursor_ = 0;  // rows sent (raster) or bytes sent (files)
  v1::ViewshedResponse message_;
};

grpc::Status ViewshedCall::compute() {
  const v1::ViewshedRequest& req = request_;
  if (req.max_chunk_bytes() < 0)
    return scope_.status_of(
        make_error(ErrorCode::kInvalidArgument, "max_chunk_bytes: must be >= 0", "max_chunk_bytes"));
  chunk_bytes_ = chunk_bytes_for(req.max_chunk_bytes());
  if (req.observers_size() > 0) {
    ViewshedParts parts;
    const grpc::Status status = compute_many_viewshed(scope_, req, parts);
    if (!status.ok()) return status;
    header_ = std::move(parts.header);
    summary_ = std::move(parts.summary);
    raster_ = std::move(parts.raster);
    geotiff_ = std::move(parts.geotiff);
    png_ = std::move(parts.png);
    row_bytes_ = parts.row_bytes;
    return grpc::Status::OK;
  }
  auto dataset = scope_.dataset(req.dataset());
  if (!dataset.ok()) return scope_.status_of(dataset.error());
  const Dataset& d = **dataset;
  const ServerEnv& env = scope_.env();

  if (!req.has_observer())
    return scope_.status_of(make_error(ErrorCode::kInvalidArgument, "observer: required", "observer"));
  auto spec = to_point_spec(req.observer(), "observer");
  if (!spec.ok()) return scope_.status_of(spec.error());
  auto options = to_viewshed_options(req.options(), env.config.engine_threads);
  if (!options.ok()) return scope_.status_of(options.error());
  scope_.record().algorithm = std::string(visibility::algorithm_name(options->algorithm));
  auto spec_or = to_output_spec(req);
  if (!spec_or.ok()) return scope_.status_of(spec_or.error());
  const ViewshedOutputSpec& out = *spec_or;
  const v1::RasterKind kind = out.kind;
  // Only visibility at the target height goes back: exact may skip finding R3's OHF.
  options->visibility_only = !visibility::needs_heights(out.output);
  // A code raster needs only the mask: the fast sweep then codes the cells itself.
  options->mask_only = visibility::is_code_raster(out.output);

  // The plan: options and observer checked, the cells and blocks to read and the cost known.
  auto plan = visibility::plan_viewshed(*d.source, {*spec, *options});
  if (!plan.ok()) return scope_.status_of(rename_field(plan.error(), "options."));
  const std::uint64_t cells = plan->cost.cells;
  if (cells > env.config.limits.max_cells)
    return scope_.status_of(
        make_error(ErrorCode::kResourceExhausted,
                   "options.max_distance: the viewshed window has " + std::to_string(cells) +
                       " cells, more than limits.max_cells = " + std::to_string(env.config.limits.max_cells) +
                       "; give a smaller max_distance",
                   "options.max_distance"));
  const bool laid_out =
      out.geotiff.format == terrain::TiffFormat::kCog || out.geotiff.compression == terrain::TiffCompression::kNone;
  const std::uint64_t per_cell =
      MemoryBudget::kEncodingBytesPerCell + (laid_out ? MemoryBudget::kLayoutBytesPerCell : 0);
  // The worker's kept buffers serve this run; its own are kept when it is done (worker_memory.hpp).
  WorkspaceLease lease(scope_);
  if (auto s = lease.reserve(plan->cost.bytes, cells * per_cell,
                             planned_work("this viewshed", plan->cost, options->radial.ray_spacing));
      !s.ok())
    return scope_.status_of(s.error());

  auto run =
      visibility::run_viewshed(*plan, *d.source, &env.cache, scope_.control(), env.gpu, env.backend, lease.workspace());
  if (!run.ok()) return scope_.status_of(rename_field(run.error(), "options."));
  const visibility::ViewshedResult* const result = &run->result;
  const visibility::WorkStats& stats = result->stats;
  scope_.ohf_computed(stats);

  // The raster asked for, derived from the one OHF (as the CLI does), or
  // the mask the sweep made (mask_only); the default-coded mask for the
  // counts and the picture.
  const terrain::Grid<std::uint8_t>& mask = visibility::ensure_mask(run->result, options->threads);
  const visibility::AnswerCounts& counts = result->mask_counts;
  const terrain::Georeference& georef = run->georef;
  const bool is_mask = visibility::is_code_raster(out.output);
  std::optional<double> nodata;
  terrain::Grid<float> values;
  terrain::Grid<std::uint8_t> recoded;
  if (is_mask) {
    if (out.codes != visibility::ValueCodes{})
      recoded = visibility::visibility_codes(*result, options->target_height, out.codes, options->threads);
    nodata = static_cast<double>(out.codes.nodata);
  } else {
    values = visibility::float_raster(*result, out.output, options->target_height);
    nodata = out.float_nodata ? out.float_nodata : d.header().nodata;
  }
  const terrain::Grid<std::uint8_t>& codes = out.codes != visibility::ValueCodes{} ? recoded : mask;
  const int width = result->frame.window.width(), height = result->frame.window.height();
  row_bytes_ = static_cast<std::size_t>(width) * (is_mask ? 1 : sizeof(float));
  if (req.include_raster()) {
    raster_.resize(row_bytes_ * static_cast<std::size_t>(height));
    if (!raster_.empty())
      std::memcpy(raster_.data(), is_mask ? static_cast<const void*>(codes.data()) : values.data(), raster_.size());
  }
  if (req.include_geotiff()) {
    const terrain::ColourTable colours = visibility::code_colour_table(out.codes);
    auto bytes_or = is_mask ? geotiff_bytes(env.scratch, codes, georef, nodata, &colours, out.geotiff)
                            : geotiff_bytes(env.scratch, values, georef, nodata, out.geotiff);
    if (!bytes_or.ok()) return scope_.status_of(bytes_or.error());
    geotiff_ = std::move(*bytes_or);
  }
  if (req.include_png()) {
    // The CLI's picture, the dataset named as the client named it.
    const auto drawing = std::chrono::steady_clock::now();
    const geodesy::GridPoint eye = run->observer_in_source();
    const auto crs = geodesy::Crs::of(georef);  // none: grid coordinates
    const visibility::PreviewCaption caption{.dem = req.dataset(),
                                             .algorithm = scope_.record().algorithm,
                                             .crs = crs.ok() ? std::optional(*crs) : std::nullopt,
                                             .x = eye.x,
                                             .y = eye.y,
                                             .ground = eye.ground};
    const visibility::PreviewRaster shown = visibility::preview_raster(out.output);
    auto png = png_bytes(env.scratch, [&](const std::string& p) {
      return visibility::write_viewshed_picture(p, *result, shown, mask, caption);
    });
    if (!png.ok()) return scope_.status_of(png.error());
    png_ = std::move(*png);
    summary_.set_preview_seconds(std::chrono::duration<double>(std::chrono::steady_clock::now() - drawing).count());
  }
  if (auto s = check_control(scope_.control()); !s.ok()) return scope_.status_of(s.error());

  const visibility::ViewFrame& f = result->frame;
  header_.set_width(width);
  header_.set_height(height);
  fill_window(run->window, *header_.mutable_window());
  fill_transform(georef.transform, *header_.mutable_transform());
  header_.set_epsg(georef.epsg);
  header_.set_raster(kind);
  header_.set_sample_type(is_mask ? v1::SAMPLE_TYPE_UINT8 : v1::SAMPLE_TYPE_FLOAT32);
  if (nodata) header_.set_nodata(*nodata);
  fill_point(run->observer_in_source(), d.header().georef, *header_.mutable_observer());
  header_.set_cell_size_x_m(f.metres_per_col);
  header_.set_cell_size_y_m(f.metres_per_row);
  header_.set_algorithm(scope_.record().algorithm);
  header_.set_backend(stats.backend);

  const std::uint64_t visible = counts.visible, hidden = counts.hidden;
  summary_.set_visible_cells(visible);
  summary_.set_hidden_cells(hidden);
  summary_.set_evaluated_cells(visible + hidden);
  summary_.set_visible_area_km2(static_cast<double>(visible) * f.metres_per_col * f.metres_per_row / 1e6);
  fill_stats(result->stats, *summary_.mutable_stats());
  lease.workspace()->recycle(std::move(run->result));  // everything sent is copied out: its rasters serve the next call
  return grpc::Status::OK;
}

void ViewshedCall::write_next() {
  message_.Clear();
  const int rows_per_chunk =
      static_cast<int>(std::max<std::size_t>(1, chunk_bytes_ / std::max<std::size_t>(1, row_bytes_)));
  while (true) {
    switch (stage_) {
      case Stage::kHeader:
        *message_.mutable_header() = header_;
        stage_ = Stage::kRaster;
        cursor_ = 0;
        return write(&message_);
      case Stage::kRaster: {
        const int height = header_.height();
        if (raster_.empty() || static_cast<int>(cursor_) >= height) {
          stage_ = Stage::kGeotiff;
          cursor_ = 0;
          raster_.clear();
          raster_.shrink_to_fit();
          continue;
        }
        const int row0 = static_cast<int>(cursor_);
        const int rows = std::min(rows_per_chunk, height - row0);
        auto* chunk = message_.mutable_raster_chunk();
        chunk->set_row0(row0);
        chunk->set_rows(rows);
        chunk->set_data(raster_.data() + static_cast<std::size_t>(row0) * row_bytes_,
                        static_cast<std::size_t>(rows) * row_bytes_);
        cursor_ += static_cast<std::size_t>(rows);
        return write(&message_);
      }
      case Stage::kGeotiff:
      case Stage::kPng: {
        std::string& file = stage_ == Stage::kGeotiff ? geotiff_ : png_;
        if (cursor_ >= file.size()) {
          file.clear();
          file.shrink_to_fit();
          stage_ = stage_ == Stage::kGeotiff ? Stage::kPng : Stage::kSummary;
          cursor_ = 0;
          continue;
        }
        const std::size_t n = std::min(chunk_bytes_, file.size() - cursor_);
        auto* chunk = message_.mutable_file_chunk();
        chunk->set_kind(stage_ == Stage::kGeotiff ? v1::FileChunk::KIND_GEOTIFF : v1::FileChunk::KIND_PNG);
        chunk->set_offset(cursor_);
        chunk->set_total_size(file.size());
        chunk->set_data(file.data() + cursor_, n);
        cursor_ += n;
        return write(&message_);
      }
      case Stage::kSummary:
        *message_.mutable_summary() = summary_;
        stage_ = Stage::kDone;
        return write(&message_);
      case Stage::kDone:
        return finish(grpc::Status::OK);
    }
  }
}

}  // namespace

grpc::ServerWriteReactor<v1::ViewshedResponse>* start_viewshed_call(ServerEnv& env,
                                                                    grpc::CallbackServerContext* context,
                                                                    const v1::ViewshedRequest* request) {
  auto* call = new ViewshedCall(env, context, *request);
  call->start();
  return call;
}

}  // namespace horizon::server
