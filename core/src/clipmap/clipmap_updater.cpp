#include "horizon/clipmap/clipmap_updater.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>

namespace horizon::clipmap {

terrain::SourcePyramidOptions pyramid_options_for(const ClipmapShape& shape) {
  terrain::SourcePyramidOptions options;
  options.factor = 2;
  options.block_cells = std::max(512, 1 << std::max(shape.levels - 1, 1));
  options.levels = std::max(shape.levels - 1, 1);
  return options;
}

Result<ClipmapUpdater> ClipmapUpdater::make(std::shared_ptr<Clipmap> map,
                                            std::shared_ptr<const terrain::SourcePyramid> pyramid,
                                            const UpdaterOptions& options) {
  const ClipmapShape& shape = map->shape();
  if (pyramid->factor() != 2 || pyramid->levels() < shape.levels - 1 || pyramid->reduction() != shape.reduction ||
      pyramid->level_width(0) != map->source_width() || pyramid->level_height(0) != map->source_height())
    return make_error(ErrorCode::kInvalidArgument,
                      "the clip-map's pyramid must be of its source, factor 2, with its reduction and at least " +
                          std::to_string(shape.levels - 1) + " levels",
                      "pyramid");
  if (!(options.lead_seconds >= 0.0) || !std::isfinite(options.lead_seconds))
    return make_error(ErrorCode::kInvalidArgument,
                      "clipmap.lead_seconds must be a finite number >= 0, got " + number_text(options.lead_seconds),
                      "clipmap.lead_seconds");
  std::vector<int> every = options.every;
  if (every.empty()) {
    for (int k = 0; k < shape.levels; ++k) every.push_back(std::min(64, 2 << k));
  } else if (static_cast<int>(every.size()) != shape.levels) {
    return make_error(ErrorCode::kInvalidArgument,
                      "clipmap.schedule has " + std::to_string(every.size()) + " entries for " +
                          std::to_string(shape.levels) + " levels",
                      "clipmap.schedule");
  }
  for (std::size_t k = 0; k < every.size(); ++k)
    if (every[k] < 1)
      return make_error(ErrorCode::kInvalidArgument,
                        "clipmap.schedule[" + std::to_string(k) + "] must be >= 1 pose, got " + std::to_string(every[k]),
                        "clipmap.schedule[" + std::to_string(k) + "]");
  return ClipmapUpdater(std::move(map), std::move(pyramid), std::move(every), options.lead_seconds);
}

ClipmapUpdater::ClipmapUpdater(std::shared_ptr<Clipmap> map, std::shared_ptr<const terrain::SourcePyramid> pyramid,
                               std::vector<int> every, double lead)
    : map_(std::move(map)),
      pyramid_(std::move(pyramid)),
      every_(std::move(every)),
      loaded_(every_.size(), false),
      lead_(lead) {}

Result<UpdateReport> ClipmapUpdater::update(const ClipPose& pose, const RunControl* control) {
  return run(pose, false, control);
}
Result<UpdateReport> ClipmapUpdater::update_all(const ClipPose& pose, const RunControl* control) {
  return run(pose, true, control);
}

Result<UpdateReport> ClipmapUpdater::run(const ClipPose& pose, bool all, const RunControl* control) {
  const auto start = std::chrono::steady_clock::now();
  UpdateReport report;
  report.pose = ++pose_;
  const double col = pose.col + pose.col_per_s * lead_, row = pose.row + pose.row_per_s * lead_;
  for (int k = 0; k < map_->shape().levels; ++k) {
    const bool due = all || !loaded_[static_cast<std::size_t>(k)] ||
                     (!map_->full_extent(k) && pose_ % static_cast<std::uint64_t>(every_[static_cast<std::size_t>(k)]) == 0);
    if (!due) continue;
    HORIZON_RETURN_IF_ERROR(bring(k, col, row, pose.seq ? pose.seq : pose_, control, report));
    loaded_[static_cast<std::size_t>(k)] = true;
  }
  report.bytes_loaded = report.cells_loaded * sizeof(float);
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return report;
}

Status ClipmapUpdater::bring(int k, double col, double row, std::uint64_t seq, const RunControl* control,
                             UpdateReport& report) {
  const LevelOrigin origin = map_->origin_for(k, col, row);
  LevelOrigin current;
  std::uint64_t version = 0;
  {
    ClipmapReader view(*map_);
    current = view.level(k).origin;
    version = view.level(k).version;
  }
  LevelUpdate update;
  update.level = k;
  update.origin = origin;
  update.pose = seq;
  update.keys = map_->missing_subtiles(k, origin);
  if (update.keys.empty() && origin == current && version > 0) return Status::Ok();

  const int t = map_->shape().subtile;
  const std::size_t tile_cells = static_cast<std::size_t>(t) * static_cast<std::size_t>(t);
  update.samples.assign(update.keys.size() * tile_cells, std::numeric_limits<float>::quiet_NaN());
  const int w = map_->level_width(k), h = map_->level_height(k);
  // Runs of consecutive sub-tiles along a sub-tile row, read as one window each.
  for (std::size_t first = 0; first < update.keys.size();) {
    std::size_t last = first;
    while (last + 1 < update.keys.size() && update.keys[last + 1].ty == update.keys[first].ty &&
           update.keys[last + 1].tx == update.keys[last].tx + 1)
      ++last;
    const terrain::Window want{update.keys[first].tx * t, update.keys[first].ty * t,
                               std::min((update.keys[last].tx + 1) * t, w), std::min((update.keys[first].ty + 1) * t, h)};
    auto cells = pyramid_->read(k, want, control);
    if (!cells.ok()) return cells.error();
    report.cells_loaded += want.cell_count();
    for (std::size_t i = first; i <= last; ++i) {
      float* dst = update.samples.data() + i * tile_cells;
      const int c0 = update.keys[i].tx * t - want.col0;
      const int width = std::min(t, want.width() - c0);
      for (int r = 0; r < want.height(); ++r)
        std::memcpy(dst + static_cast<std::size_t>(r) * static_cast<std::size_t>(t), cells->row(r) + c0,
                    static_cast<std::size_t>(width) * sizeof(float));
    }
    first = last + 1;
  }
  report.subtiles_loaded += update.keys.size();
  map_->publish(update);
  report.levels.push_back(k);
  return Status::Ok();
}

// --- AsyncClipmapUpdater ---

AsyncClipmapUpdater::AsyncClipmapUpdater(ClipmapUpdater updater)
    : updater_(std::move(updater)), thread_([this] { loop(); }) {}

AsyncClipmapUpdater::~AsyncClipmapUpdater() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  cancel_.cancel();
  wake_.notify_all();
  thread_.join();
}

void AsyncClipmapUpdater::post(const ClipPose& pose) {
  {
    std::lock_guard lock(mutex_);
    ++stats_.posted;
    if (pending_) ++stats_.skipped;
    pending_ = pose;
  }
  wake_.notify_one();
}

void AsyncClipmapUpdater::wait_idle() {
  std::unique_lock lock(mutex_);
  idle_.wait(lock, [this] { return !pending_ && !busy_; });
}

LoaderStats AsyncClipmapUpdater::stats() const {
  std::lock_guard lock(mutex_);
  return stats_;
}

void AsyncClipmapUpdater::loop() {
  RunControl control;
  control.cancel = &cancel_;
  std::unique_lock lock(mutex_);
  for (;;) {
    wake_.wait(lock, [this] { return stop_ || pending_.has_value(); });
    if (stop_) break;
    const ClipPose pose = *pending_;
    pending_.reset();
    busy_ = true;
    lock.unlock();
    auto report = updater_.update(pose, &control);
    lock.lock();
    busy_ = false;
    ++stats_.applied;
    if (report.ok()) {
      stats_.subtiles_loaded += report->subtiles_loaded;
      stats_.bytes_loaded += report->bytes_loaded;
    } else {
      stats_.last_error = report.error();
    }
    if (!pending_) idle_.notify_all();
  }
  busy_ = false;
  idle_.notify_all();
}

}  // namespace horizon::clipmap
