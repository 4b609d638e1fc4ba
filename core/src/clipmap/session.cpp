#include "horizon/clipmap/session.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>
#include <unordered_set>

#include "horizon/geodesy/crs.hpp"
#include "horizon/visibility/view_frame.hpp"

namespace horizon::clipmap {
namespace {

std::string entry_field(std::size_t i, const char* name) {
  return "boxes[" + std::to_string(i) + "]" + (name[0] ? std::string(".") + name : std::string());
}

}  // namespace

Result<std::unique_ptr<ClipSession>> ClipSession::open(std::shared_ptr<const terrain::ElevationSource> source,
                                                       terrain::BlockCache& cache,
                                                       std::shared_ptr<const terrain::SourcePyramid> pyramid,
                                                       const SessionOptions& options, const SessionPose& first,
                                                       const RunControl* control) {
  if (options.rays < 64 || options.rays > 65536)
    return make_error(ErrorCode::kInvalidArgument, "rays must be in [64, 65536], got " + std::to_string(options.rays),
                      "rays");
  if (options.max_boxes < 1)
    return make_error(ErrorCode::kInvalidArgument, "max_boxes must be at least 1", "max_boxes");
  if (!(options.curvature_coefficient >= 0.0 && options.curvature_coefficient <= 1.0))
    return make_error(ErrorCode::kInvalidArgument,
                      "curvature_coefficient must be in [0, 1], got " + number_text(options.curvature_coefficient),
                      "curvature_coefficient");
  std::unique_ptr<ClipSession> s(new ClipSession());
  s->source_ = std::move(source);
  s->cache_ = &cache;
  s->options_ = options;
  s->options_.shape.reduction =
      options.mode == ClipMode::kConservative ? terrain::Reduction::kMin : terrain::Reduction::kMean;
  auto map = Clipmap::make(s->source_->width(), s->source_->height(), s->options_.shape);
  if (!map.ok()) return map.error();
  s->map_ = *map;
  auto updater = ClipmapUpdater::make(s->map_, std::move(pyramid), options.updater);
  if (!updater.ok()) return updater.error();
  ClipPose clip;
  auto eye = s->eye_for(first, clip);
  if (!eye.ok()) return eye.error();
  auto loaded = updater->update_all(clip, control);
  if (!loaded.ok()) return loaded.error();
  if (options.asynchronous)
    s->async_ = std::make_unique<AsyncClipmapUpdater>(std::move(*updater));
  else
    s->sync_ = std::make_unique<ClipmapUpdater>(std::move(*updater));
  return s;
}

ClipSession::~ClipSession() = default;

std::uint64_t ClipSession::bytes() const {
  const double cell = 1.0;  // rings do not depend on the unit, only on cells
  const double diagonal = std::hypot(source_->width(), source_->height());
  const std::uint64_t rings = ring_edges(diagonal, cell, options_.rays, options_.shape).size();
  const std::uint64_t scratch = static_cast<std::uint64_t>(options_.rays) * rings * sizeof(double);
  const std::uint64_t per_box = sizeof(Entry) + sizeof(visibility::BoxFootprint) + 4 * sizeof(void*) + 16;
  return map_->bytes() + scratch + entries_.size() * per_box;
}

Result<ClipEye> ClipSession::eye_for(const SessionPose& pose, ClipPose& clip) const {
  const terrain::DemHeader& h = source_->header();
  if (!std::isfinite(pose.east_per_s) || !std::isfinite(pose.north_per_s))
    return make_error(ErrorCode::kInvalidArgument, "pose velocity is not a finite number", "velocity");
  auto located = geodesy::locate_point(h.georef, h.width, h.height, pose.position, "pose", h.source);
  if (!located.ok()) return located.error();
  // The ground under the eye from the source itself: the 2 x 2 cells around it.
  const int c0 = std::clamp(static_cast<int>(std::floor(located->col)), 0, std::max(0, h.width - 2));
  const int r0 = std::clamp(static_cast<int>(std::floor(located->row)), 0, std::max(0, h.height - 2));
  auto cells = source_->read({c0, r0, std::min(c0 + 2, h.width), std::min(r0 + 2, h.height)}, cache_);
  if (!cells.ok()) return cells.error();
  geodesy::GridPoint local = *located;
  local.col -= c0;
  local.row -= r0;
  auto placed = geodesy::place_on_ground(*cells, local, pose.position, "pose", c0, r0);
  if (!placed.ok()) return placed.error();
  auto metres = visibility::metric_cell_size(h.georef, located->x, located->y, h.source);
  if (!metres.ok()) return metres.error();
  ClipEye eye{located->col, located->row, placed->elevation, metres->per_col, metres->per_row,
              options_.curvature_coefficient / (2.0 * geodesy::kEarthRadiusMetres)};
  const double north_row = h.georef.transform.pixel_height < 0 ? -1.0 : 1.0;  // rows run south on a north-up grid
  clip.col = eye.col;
  clip.row = eye.row;
  clip.col_per_s = pose.east_per_s / metres->per_col;
  clip.row_per_s = north_row * pose.north_per_s / metres->per_row;
  return eye;
}

Result<std::vector<visibility::BoxFootprint>> ClipSession::resolve(std::span<const SessionBox> boxes) const {
  std::vector<visibility::BoxSpec> specs;
  specs.reserve(boxes.size());
  for (const SessionBox& b : boxes) specs.push_back(b.box);
  const terrain::DemHeader& h = source_->header();
  return visibility::resolve_boxes(h.georef, h.width, h.height, h.source, specs);
}

Status ClipSession::add_boxes(std::span<const SessionBox> boxes) {
  if (entries_.size() + boxes.size() > options_.max_boxes)
    return make_error(ErrorCode::kResourceExhausted,
                      "adding " + std::to_string(boxes.size()) + " boxes to the session's " +
                          std::to_string(entries_.size()) + " would pass its limit of " +
                          std::to_string(options_.max_boxes),
                      "boxes");
  std::unordered_set<std::uint64_t> seen;
  for (std::size_t i = 0; i < boxes.size(); ++i)
    if (index_.count(boxes[i].id) || !seen.insert(boxes[i].id).second)
      return make_error(ErrorCode::kInvalidArgument,
                        entry_field(i, "id") + ": box " + std::to_string(boxes[i].id) + " is already registered",
                        entry_field(i, "id"));
  auto footprints = resolve(boxes);
  if (!footprints.ok()) return footprints.error();
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    index_[boxes[i].id] = entries_.size();
    entries_.push_back({boxes[i].id});
    footprints_.push_back((*footprints)[i]);
  }
  return Status::Ok();
}

Status ClipSession::move_boxes(std::span<const SessionBox> boxes) {
  std::unordered_set<std::uint64_t> seen;
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    if (!index_.count(boxes[i].id))
      return make_error(ErrorCode::kNotFound, entry_field(i, "id") + ": no box " + std::to_string(boxes[i].id),
                        entry_field(i, "id"));
    if (!seen.insert(boxes[i].id).second)
      return make_error(ErrorCode::kInvalidArgument,
                        entry_field(i, "id") + ": box " + std::to_string(boxes[i].id) + " is moved twice",
                        entry_field(i, "id"));
  }
  auto footprints = resolve(boxes);
  if (!footprints.ok()) return footprints.error();
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    const std::size_t at = index_[boxes[i].id];
    footprints_[at] = (*footprints)[i];
    entries_[at].reported = false;
  }
  return Status::Ok();
}

Status ClipSession::remove_boxes(std::span<const std::uint64_t> ids) {
  std::unordered_set<std::uint64_t> seen;
  for (std::size_t i = 0; i < ids.size(); ++i)
    if (!index_.count(ids[i]) || !seen.insert(ids[i]).second)
      return make_error(ErrorCode::kNotFound, "remove[" + std::to_string(i) + "]: no box " + std::to_string(ids[i]),
                        "remove[" + std::to_string(i) + "]");
  for (std::uint64_t id : ids) {
    const std::size_t at = index_[id];
    index_.erase(id);
    if (at + 1 != entries_.size()) {
      entries_[at] = entries_.back();
      footprints_[at] = footprints_.back();
      index_[entries_[at].id] = at;
    }
    entries_.pop_back();
    footprints_.pop_back();
  }
  return Status::Ok();
}

Result<SessionAnswer> ClipSession::answer(const SessionPose& pose, const RunControl* control) {
  const auto start = std::chrono::steady_clock::now();
  ClipPose clip;
  auto eye = eye_for(pose, clip);
  if (!eye.ok()) return eye.error();
  SessionAnswer out;
  out.seq = pose.seq;
  out.eye_elevation = eye->elevation;
  clip.seq = ++answers_ + 1;  // open() published at 1
  if (async_) {
    async_->post(clip);
    const LoaderStats now = async_->stats();
    out.subtiles_loaded = now.subtiles_loaded - last_loader_.subtiles_loaded;
    out.bytes_loaded = now.bytes_loaded - last_loader_.bytes_loaded;
    if (now.last_error) out.loader_error = now.last_error;
    last_loader_ = now;
  } else {
    auto report = sync_->update(clip, control);
    if (!report.ok()) return report.error();
    out.subtiles_loaded = report->subtiles_loaded;
    out.bytes_loaded = report->bytes_loaded;
  }

  ClipmapReader view(*map_);
  for (int k = 0; k < map_->shape().levels; ++k) {
    const LevelState state = view.level(k);
    out.levels.push_back({state, clip.seq > state.pose ? clip.seq - state.pose : 0});
  }
  ClipCullOptions cull;
  cull.mode = options_.mode;
  cull.rays = options_.rays;
  cull.threads = options_.threads;
  auto culled = cull_on_clipmap(view, *eye, footprints_, cull, control);
  if (!culled.ok()) return culled.error();
  for (std::size_t i = 0; i < entries_.size(); ++i) {
    Entry& e = entries_[i];
    const visibility::BoxVisibility& b = culled->boxes[i];
    if (!e.reported || b.state != e.state) out.changes.push_back({e.id, b.state, b.ohf_min});
    e.reported = true;
    e.state = b.state;
  }
  out.boxes = entries_.size();
  out.visible = culled->visible_count;
  out.cull = culled->stats;
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

}  // namespace horizon::clipmap
