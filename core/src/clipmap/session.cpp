#include "horizon/clipmap/session.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <unordered_set>

#include "horizon/geodesy/crs.hpp"
#include "horizon/visibility/view_frame.hpp"

namespace horizon::clipmap {
namespace {

std::string entry_field(const char* list, std::size_t i, const char* name) {
  return std::string(list) + "[" + std::to_string(i) + "]" + (name[0] ? std::string(".") + name : std::string());
}

}  // namespace

Result<std::unique_ptr<ClipSession>> ClipSession::open(std::shared_ptr<const terrain::ElevationSource> source,
                                                       terrain::BlockCache& cache,
                                                       std::shared_ptr<const terrain::SourcePyramid> pyramid,
                                                       const SessionOptions& options, const SessionPose& first,
                                                       const RunControl* control) {
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
  s->options_.shape.reduction = reduction_for(options.mode);
  // Checks rays, shape and backend.
  auto bytes = bytes_for(s->options_, s->source_->width(), s->source_->height(), 0);
  if (!bytes.ok()) return bytes.error();
  s->pyramid_ = pyramid;
  if (options.mode == ClipMode::kExact) {
    ClipPose clip;
    auto eye = s->eye_for(first, clip);  // the first pose's errors at open, as in the other modes
    if (!eye.ok()) return eye.error();
    return s;
  }
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

namespace {

// The check open() makes of options that need no source, and the trace's scratch.
Result<std::uint64_t> scratch_bytes(const SessionOptions& options, int width, int height) {
  HORIZON_RETURN_IF_ERROR(check_rays(options.rays));
  // Per traced column, one slope a ring out to the source's diagonal (rings do not depend on the cell's unit).
  const std::uint64_t rings = ring_edges(std::hypot(width, height), 1.0, options.rays, options.shape).size();
  return static_cast<std::uint64_t>(options.rays) * rings * sizeof(double);
}
}  // namespace

Result<std::uint64_t> ClipSession::bytes_for(const SessionOptions& options, int width, int height, std::size_t boxes) {
  if (!(options.viewshed_radius >= 0.0) || !std::isfinite(options.viewshed_radius))
    return make_error(ErrorCode::kInvalidArgument, "viewshed_radius must be a number of metres >= 0 (0: none)",
                      "viewshed_radius");
  // A pose's viewshed mask: at most ClipViewshed::kMaxCells bytes (a larger one is refused when answered).
  const std::uint64_t mask = options.viewshed_radius > 0.0 ? ClipViewshed::kMaxCells : 0;
  if (options.mode == ClipMode::kExact) {
    if (options.use_gpu)
      return make_error(ErrorCode::kInvalidArgument, "exact sessions run on the CPU: the GPU traces clip-maps only",
                        "backend");
    return options.exact_bytes + mask + boxes * kBytesPerBox;
  }
  HORIZON_RETURN_IF_ERROR(Clipmap::check(width, height, options.shape));
  auto scratch = scratch_bytes(options, width, height);
  if (!scratch.ok()) return scratch.error();
  return Clipmap::bytes_for(width, height, options.shape) + *scratch + mask + boxes * kBytesPerBox;
}

std::uint64_t ClipSession::bytes() const {
  auto bytes = bytes_for(options_, source_->width(), source_->height(), entries_.size());
  return bytes.ok() ? *bytes : map_ ? map_->bytes() : options_.exact_bytes;
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
  ClipEye eye{located->col,    located->row,    placed->elevation,
              metres->per_col, metres->per_row, options_.curvature_coefficient / (2.0 * geodesy::kEarthRadiusMetres)};
  const double north_row = h.georef.transform.pixel_height < 0 ? -1.0 : 1.0;  // rows run south on a north-up grid
  clip.col = eye.col;
  clip.row = eye.row;
  clip.col_per_s = pose.east_per_s / metres->per_col;
  clip.row_per_s = north_row * pose.north_per_s / metres->per_row;
  return eye;
}

Result<std::vector<visibility::BoxFootprint>> ClipSession::resolve(std::span<const SessionBox> boxes,
                                                                   const char* list) const {
  std::vector<visibility::BoxSpec> specs;
  specs.reserve(boxes.size());
  for (const SessionBox& b : boxes) specs.push_back(b.box);
  const terrain::DemHeader& h = source_->header();
  auto footprints =
      visibility::resolve_boxes(h.georef, h.width, h.height, h.source, specs, visibility::OffMap::kAnswer);
  if (footprints.ok()) return footprints;
  Error e = footprints.error();  // "boxes[3].z_max" -> "add[3].z_max"
  for (std::string* text : {&e.field, &e.message})
    for (std::size_t at = text->find("boxes["); at != std::string::npos; at = text->find("boxes[", at + 1))
      text->replace(at, 5, list);
  return e;
}

Result<bool> ClipSession::touches_void(const visibility::BoxFootprint& f) const {
  // Small footprints: their own cells. Larger ones (conservative mode): the
  // min pyramid's cells over them, where -inf marks a void somewhere in the
  // block, which errs only towards "visible". A footprint off the map has
  // no cells here: it meets none.
  if (!f.on_map) return false;
  constexpr std::uint64_t kMaxCells = 64 * 64;
  if (f.cells.cell_count() <= kMaxCells) {
    auto cells = source_->read(f.cells, cache_);
    if (!cells.ok()) return cells.error();
    for (int r = 0; r < cells->height(); ++r)
      for (int c = 0; c < cells->width(); ++c)
        if (std::isnan(cells->elevation.at(c, r))) return true;
    return false;
  }
  if (!pyramid_ || pyramid_->reduction() != terrain::Reduction::kMin) return false;
  int level = 1;
  while (level < pyramid_->levels() && (static_cast<std::uint64_t>(f.cells.width() >> level) + 1) *
                                               (static_cast<std::uint64_t>(f.cells.height() >> level) + 1) >
                                           kMaxCells)
    ++level;
  const terrain::Window w{f.cells.col0 >> level, f.cells.row0 >> level, ((f.cells.col1 - 1) >> level) + 1,
                          ((f.cells.row1 - 1) >> level) + 1};
  auto cells = pyramid_->read(level, w);
  if (!cells.ok()) return cells.error();
  for (int r = 0; r < cells->height(); ++r)
    for (int c = 0; c < cells->width(); ++c)
      if (cells->at(c, r) == -std::numeric_limits<float>::infinity()) return true;
  return false;
}

Status ClipSession::apply(const BoxDelta& delta) {
  // Checked whole against the state after each step (remove, move, add), then applied.
  std::unordered_set<std::uint64_t> removed, moved, added;
  for (std::size_t i = 0; i < delta.remove.size(); ++i)
    if (!index_.count(delta.remove[i]) || !removed.insert(delta.remove[i]).second)
      return make_error(ErrorCode::kNotFound,
                        entry_field("remove", i, "") + ": no box " + std::to_string(delta.remove[i]) + " to remove",
                        entry_field("remove", i, ""));
  for (std::size_t i = 0; i < delta.move.size(); ++i) {
    const std::uint64_t id = delta.move[i].id;
    if (!index_.count(id) || removed.count(id))
      return make_error(ErrorCode::kNotFound, entry_field("move", i, "id") + ": no box " + std::to_string(id),
                        entry_field("move", i, "id"));
    if (!moved.insert(id).second)
      return make_error(ErrorCode::kInvalidArgument,
                        entry_field("move", i, "id") + ": box " + std::to_string(id) + " is moved twice",
                        entry_field("move", i, "id"));
  }
  for (std::size_t i = 0; i < delta.add.size(); ++i) {
    const std::uint64_t id = delta.add[i].id;
    if ((index_.count(id) && !removed.count(id)) || !added.insert(id).second)
      return make_error(ErrorCode::kInvalidArgument,
                        entry_field("add", i, "id") + ": box " + std::to_string(id) + " is already registered",
                        entry_field("add", i, "id"));
  }
  const std::size_t after = entries_.size() - removed.size() + delta.add.size();
  if (after > options_.max_boxes)
    return make_error(ErrorCode::kResourceExhausted,
                      "the session would hold " + std::to_string(after) + " boxes, more than its limit of " +
                          std::to_string(options_.max_boxes),
                      "add");
  auto moved_footprints = resolve(delta.move, "move");
  if (!moved_footprints.ok()) return moved_footprints.error();
  auto added_footprints = resolve(delta.add, "add");
  if (!added_footprints.ok()) return added_footprints.error();
  // Boxes over voids, as culling has them (cull.hpp): known before anything changes.
  std::vector<bool> moved_voids, added_voids;
  for (const auto& [footprints, voids] :
       {std::pair{&*moved_footprints, &moved_voids}, std::pair{&*added_footprints, &added_voids}})
    for (const visibility::BoxFootprint& f : *footprints) {
      auto v = touches_void(f);
      if (!v.ok()) return v.error();
      voids->push_back(*v);
    }

  for (std::uint64_t id : delta.remove) {
    const std::size_t at = index_[id];
    index_.erase(id);
    if (at + 1 != entries_.size()) {
      entries_[at] = entries_.back();
      footprints_[at] = footprints_.back();
      specs_[at] = specs_.back();
      index_[entries_[at].id] = at;
    }
    entries_.pop_back();
    footprints_.pop_back();
    specs_.pop_back();
  }
  for (std::size_t i = 0; i < delta.move.size(); ++i) {
    const std::size_t at = index_[delta.move[i].id];
    footprints_[at] = (*moved_footprints)[i];
    specs_[at] = delta.move[i].box;
    entries_[at].reported = false;
    entries_[at].on_void = moved_voids[i];
  }
  for (std::size_t i = 0; i < delta.add.size(); ++i) {
    index_[delta.add[i].id] = entries_.size();
    entries_.push_back({delta.add[i].id});
    entries_.back().on_void = added_voids[i];
    footprints_.push_back((*added_footprints)[i]);
    specs_.push_back(delta.add[i].box);
  }
  return Status::Ok();
}

Status ClipSession::add_boxes(std::span<const SessionBox> boxes) {
  BoxDelta d;
  d.add.assign(boxes.begin(), boxes.end());
  return apply(d);
}
Status ClipSession::move_boxes(std::span<const SessionBox> boxes) {
  BoxDelta d;
  d.move.assign(boxes.begin(), boxes.end());
  return apply(d);
}
Status ClipSession::remove_boxes(std::span<const std::uint64_t> ids) {
  BoxDelta d;
  d.remove.assign(ids.begin(), ids.end());
  return apply(d);
}

Result<ClipCullResult> ClipSession::cull_exact(const SessionPose& pose, const RunControl* control) {
  ClipCullResult out;
  if (specs_.empty()) return out;
  const auto start = std::chrono::steady_clock::now();
  visibility::CullQuery query{pose.position, specs_, {}};
  query.options.viewshed.algorithm = visibility::Algorithm::kExact;
  query.options.viewshed.curvature_coefficient = options_.curvature_coefficient;
  query.options.viewshed.threads = options_.threads;
  auto plan = visibility::plan_cull_boxes(*source_, std::move(query));
  if (!plan.ok()) return plan.error();
  if (plan->cost.bytes > options_.exact_bytes)
    return make_error(ErrorCode::kResourceExhausted,
                      "an exact answer from this pose needs " + std::to_string(plan->cost.bytes >> 20) +
                          " MiB of working memory, more than the session's " +
                          std::to_string(options_.exact_bytes >> 20) +
                          " MiB: the boxes reach too far for exact mode; use conservative mode or fewer, nearer boxes",
                      "boxes");
  auto run = visibility::run_cull_boxes(*plan, *source_, cache_, control, nullptr, nullptr, &workspace_);
  if (!run.ok()) return run.error();
  workspace_.trim();
  out.boxes = std::move(run->result.boxes);
  out.visible_count = run->result.visible_count;
  out.stats.samples = run->result.stats.terrain_samples;
  out.stats.box_tests = run->result.pyramid_cells_read;
  out.stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

Result<ViewshedSummary> ClipSession::viewshed_exact(const SessionPose& pose, const RunControl* control) {
  const auto start = std::chrono::steady_clock::now();
  visibility::ViewshedQuery query{pose.position, {}};
  query.options.algorithm = visibility::Algorithm::kExact;
  query.options.max_distance = options_.viewshed_radius;
  query.options.curvature_coefficient = options_.curvature_coefficient;
  query.options.threads = options_.threads;
  auto plan = visibility::plan_viewshed(*source_, query);
  if (!plan.ok()) return plan.error();
  if (plan->cost.bytes > options_.exact_bytes || plan->cost.cells > ClipViewshed::kMaxCells)
    return make_error(ErrorCode::kResourceExhausted,
                      "an exact viewshed of " + number_text(options_.viewshed_radius) + " m needs " +
                          std::to_string(plan->cost.bytes >> 20) + " MiB of working memory and " +
                          std::to_string(plan->cost.cells) + " cells, more than the session's " +
                          std::to_string(options_.exact_bytes >> 20) + " MiB or " +
                          std::to_string(ClipViewshed::kMaxCells) + " cells",
                      "viewshed_radius");
  auto run = visibility::run_viewshed(*plan, *source_, cache_, control, nullptr, nullptr, &workspace_);
  if (!run.ok()) return run.error();
  ViewshedSummary out;
  out.window = run->window;
  out.mask = visibility::visibility_mask(run->result, 0.0);
  for (int r = 0; r < out.mask.height(); ++r)
    for (int c = 0; c < out.mask.width(); ++c) {
      out.visible_cells += out.mask.at(c, r) == visibility::kVisible;
      out.hidden_cells += out.mask.at(c, r) == visibility::kHidden;
    }
  workspace_.recycle(std::move(run->result));
  workspace_.trim();
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

// One snapshot's cull, on `gl` when given; a GL failure (field "gpu") runs
// it again on the CPU and says why.
Result<ClipCullResult> ClipSession::cull_clipmap(const ClipEye& eye, const RunControl* control, gpu::Lease* gl,
                                                 SessionAnswer& out) {
  ClipmapReader view(*map_);
  for (int k = 0; k < map_->shape().levels; ++k) {
    const LevelState state = view.level(k);
    out.levels.push_back({state, answers_ + 1 > state.pose ? answers_ + 1 - state.pose : 0});
  }
  ClipCullOptions cull;
  cull.mode = options_.mode;
  cull.rays = options_.rays;
  cull.threads = options_.threads;
  auto culled = cull_on_clipmap(view, eye, footprints_, cull, control, &scratch_, gl);
  if (gl && !culled.ok() && culled.error().field == "gpu") {
    out.gpu_fallback = culled.error().message;
    culled = cull_on_clipmap(view, eye, footprints_, cull, control, &scratch_);
  }
  return culled;
}

Result<ViewshedSummary> ClipSession::viewshed_clipmap(const ClipEye& eye, const RunControl* control, gpu::Lease* gl,
                                                      SessionAnswer& out) {
  ClipmapReader view(*map_);
  ClipViewshedOptions vo;
  vo.mode = options_.mode;
  vo.rays = options_.rays;
  vo.threads = options_.threads;
  vo.radius = options_.viewshed_radius;
  auto seen = viewshed_on_clipmap(view, eye, vo, control, &scratch_, gl);
  if (gl && !seen.ok() && seen.error().field == "gpu") {
    out.gpu_fallback = seen.error().message;
    seen = viewshed_on_clipmap(view, eye, vo, control, &scratch_);
  }
  if (!seen.ok()) return seen.error();
  return ViewshedSummary{seen->window, std::move(seen->mask), seen->visible_cells, seen->hidden_cells,
                         seen->stats.seconds};
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
  if (options_.mode == ClipMode::kExact) {
    // No clip-map: nothing to load or report per level.
  } else if (async_) {
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

  // A context for the trace and the viewshed, held for the answer.
  std::optional<Result<gpu::Lease>> lease;
  gpu::Lease* gl = nullptr;
  if (options_.use_gpu) {
    if (!options_.gpu) {
      out.gpu_fallback = "no GPU contexts to trace on";
    } else {
      lease.emplace(options_.gpu->borrow());
      if (lease->ok())
        gl = &**lease;
      else
        out.gpu_fallback = lease->error().message;
    }
  }
  Result<ClipCullResult> culled = ClipCullResult{};
  if (options_.mode == ClipMode::kExact) {
    culled = cull_exact(pose, control);
  } else {
    culled = cull_clipmap(*eye, control, gl, out);
  }
  if (!culled.ok()) return culled.error();
  if (options_.viewshed_radius > 0.0) {
    gpu::Lease* viewshed_gl = out.gpu_fallback.empty() ? gl : nullptr;  // not again after a GL failure
    auto seen = options_.mode == ClipMode::kExact ? viewshed_exact(pose, control)
                                                  : viewshed_clipmap(*eye, control, viewshed_gl, out);
    if (!seen.ok()) return seen.error();
    out.viewshed = std::move(*seen);
  }
  for (std::size_t i = 0; i < entries_.size(); ++i) {
    Entry& e = entries_[i];
    visibility::BoxVisibility& b = culled->boxes[i];
    if (e.on_void && b.state == visibility::Visibility::kOccluded) {
      b.state = visibility::Visibility::kUndetermined;
      ++culled->visible_count;  // may be seen
    }
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
