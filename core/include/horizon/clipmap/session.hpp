// horizon/clipmap/session.hpp — one moving client's state: its clip-map,
// its registered object boxes, and what it was last told about each.
//
//   auto session = clipmap::ClipSession::open(source, cache, pyramid, options, first_pose);
//   session->add_boxes(boxes);                         // ids chosen by the client
//   for (pose : flight) {
//     auto answer = session->answer(pose);             // the boxes whose visibility changed
//     ...                                              // answer->levels: versions, staleness
//   }
//
// Poses. A pose is a position (dataset CRS or WGS84, height above ground or
// absolute, as geodesy::PointSpec), a ground velocity in metres per second
// east and north, and the client's sequence number. open() loads every level
// around the first pose before it returns, so the first answer has data.
// Each answer() hands the pose to the loader (SessionOptions::asynchronous:
// a thread of the session's own, which never makes answer() wait for I/O;
// otherwise the levels due are updated before answering) and culls every box
// against one snapshot of the clip-map (clip_cull.hpp). The eye's ground is
// read from the source itself (through the block cache), not from a level,
// so a lagging level can never lower the eye.
//
// Modes. Fast and conservative sessions cull against their clip-map
// (clip_cull.hpp). An exact session keeps no clip-map: each answer is R3's,
// computed on the full-resolution source around the eye out to the boxes'
// reach (visibility/plan.hpp, Algorithm::kExact, through the block cache:
// it waits for the terrain it needs and never falls back). It costs what a
// CullBoxes request of the same boxes costs; an answer whose plan needs more
// than SessionOptions::exact_bytes of engine memory is refused
// (kResourceExhausted "boxes") before anything is read.
//
// Boxes follow culling's rule (visibility/cull.hpp). A box whose footprint
// is not wholly on the dataset is registered and answered kOutOfRange at
// every pose (never culled, no work). A box whose footprint meets a void
// (no terrain, so no answer there) is decided on the rest: visible stays
// visible, and hidden becomes kUndetermined (the void might hold the point
// that shows it); whether it meets one is found when the box is added or
// moved: from its own cells, or for a footprint over 64 x 64 cells from the
// min pyramid's in conservative mode (which may also count a void just
// beside it; fast mode does not check such a footprint). Exact sessions
// answer as a CullBoxes request under the default nodata policy, which is
// the same rule.
//
// Viewsheds. With SessionOptions::viewshed_radius, each answer also says
// which cells within that radius of the eye are seen (clip_viewshed.hpp on
// the same snapshot; R3's in exact mode), counted and as a mask; its cells
// are bounded (ClipViewshed::kMaxCells) and held in the session's memory.
//
// Answers. The first answer, and the first after a box is added or moved,
// reports that box; after that only boxes whose visibility changed are
// reported. Each answer says which pose it answers, each level's version and
// the answers since it was last published (staleness), the samples that fell
// back to a coarser level, and the work done. A synchronous session fails
// an answer whose update cannot read the terrain; an asynchronous one
// answers from what is resident and says what the loader could not read.
//
// Boxes are added, moved and removed by id, a delta at a time: a delta with
// any bad entry (unknown or repeated id, bad box, over max_boxes) changes
// nothing, and the error names the entry ("add[3].id"). A box off the map is
// not a bad entry (it is answered out of range, above).
//
// One client drives a session: its methods are not to be called
// concurrently (the loader thread is the session's own business).
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <unordered_map>
#include <vector>

#include "horizon/clipmap/clip_cull.hpp"
#include "horizon/clipmap/clip_viewshed.hpp"
#include "horizon/clipmap/clipmap.hpp"
#include "horizon/clipmap/clipmap_updater.hpp"
#include "horizon/geodesy/observer.hpp"
#include "horizon/gpu/context_pool.hpp"
#include "horizon/terrain/source.hpp"
#include "horizon/terrain/source_pyramid.hpp"
#include "horizon/visibility/cull.hpp"
#include "horizon/visibility/plan.hpp"

namespace horizon::clipmap {

struct SessionOptions {
  ClipmapShape shape;  // its reduction is set from mode (mean for fast, min for conservative)
  UpdaterOptions updater;
  ClipMode mode = ClipMode::kFast;
  int rays = 1024;
  unsigned threads = 1;                    // culling threads per answer (0: all cores)
  bool asynchronous = true;                // load on the session's loader thread
  std::size_t max_boxes = 100000;          // registered at once
  double curvature_coefficient = 0.85714;  // as visibility::ViewshedOptions
  // A viewshed summary with every answer: the cells within this many metres
  // of the eye seen and hidden (clip_viewshed.hpp; exact mode: R3's). 0: none.
  double viewshed_radius = 0.0;
  // Exact mode: the most engine memory one answer may take (visibility::Cost::bytes).
  std::uint64_t exact_bytes = std::uint64_t{512} << 20;
  // Trace on the GPU (fast and conservative modes; exact refuses it,
  // "backend"): each answer borrows a context of `gpu` for its trace and
  // viewshed (clip_cull.hpp: the same answers as the CPU trace). An answer
  // that cannot (no pool, or its GL work failed) is traced on the CPU and
  // says why in SessionAnswer::gpu_fallback.
  bool use_gpu = false;
  gpu::ContextPool* gpu = nullptr;
};

struct SessionPose {
  geodesy::PointSpec position;
  double east_per_s = 0.0, north_per_s = 0.0;  // ground velocity, metres per second
  std::uint64_t seq = 0;                       // the client's number for it
};

struct SessionBox {
  std::uint64_t id = 0;
  visibility::BoxSpec box;
};

// Changes to a session's boxes, applied in this order: remove, move, add.
struct BoxDelta {
  std::vector<SessionBox> add;   // new ids (or ids removed by the same delta)
  std::vector<SessionBox> move;  // ids in the session: new footprints or heights, reported at the next answer
  std::vector<std::uint64_t> remove;
};

struct BoxChange {
  std::uint64_t id = 0;
  visibility::Visibility state = visibility::Visibility::kSeen;
  float ohf_min = 0.0f;
};

// The cells within SessionOptions::viewshed_radius of the eye, from the
// same snapshot (or, exact mode, the same source) as the boxes' answer.
struct ViewshedSummary {
  terrain::Window window;            // source cells of `mask`
  terrain::Grid<std::uint8_t> mask;  // visibility::kVisible / kHidden / kNoAnswer (beyond the radius, voids)
  std::uint64_t visible_cells = 0, hidden_cells = 0;
  double seconds = 0.0;
};

struct LevelReport {
  LevelState state;
  std::uint64_t staleness = 0;  // answers since the level was last published
};

struct SessionAnswer {
  std::uint64_t seq = 0;       // the pose answered
  double eye_elevation = 0.0;  // absolute metres
  std::vector<BoxChange> changes;
  std::size_t boxes = 0, visible = 0;
  std::vector<LevelReport> levels;
  ClipCullStats cull;
  std::uint64_t subtiles_loaded = 0, bytes_loaded = 0;  // by this answer's update (asynchronous: since the last answer)
  // Asynchronous loading: the last read the loader could not make (a missing
  // or corrupt tile). The answer still stands, on the levels resident.
  std::optional<Error> loader_error;
  std::optional<ViewshedSummary> viewshed;  // with SessionOptions::viewshed_radius
  // SessionOptions::use_gpu: why this answer was traced on the CPU (empty
  // when it ran on the GPU; cull.gpu says where it ran).
  std::string gpu_fallback;
  double seconds = 0.0;
};

class ClipSession {
 public:
  // Bytes one registered box holds: its entry, box, footprint, index slot,
  // and its share of the trace's spans, box pieces (the CPU culls two a
  // box at most, else the table of horizons, reserved with the scratch)
  // and the answer.
  static constexpr std::uint64_t kBytesPerBox = 264;

  // `pyramid` must be of `source`, factor 2, with the mode's reduction and
  // enough levels (pyramid_options_for(options.shape)). Errors name the
  // option or the pose field at fault.
  static Result<std::unique_ptr<ClipSession>> open(std::shared_ptr<const terrain::ElevationSource> source,
                                                   terrain::BlockCache& cache,
                                                   std::shared_ptr<const terrain::SourcePyramid> pyramid,
                                                   const SessionOptions& options, const SessionPose& first,
                                                   const RunControl* control = nullptr);
  ~ClipSession();

  const SessionOptions& options() const { return options_; }
  std::size_t box_count() const { return entries_.size(); }
  // Memory the session holds: clip-map, boxes, trace scratch.
  std::uint64_t bytes() const;

  // The whole delta, or nothing: errors name the entry ("add[3].id",
  // "move[0].id", "remove[2]", "add[5].z_max"; "add" past max_boxes).
  Status apply(const BoxDelta& delta);
  Status add_boxes(std::span<const SessionBox> boxes);
  Status move_boxes(std::span<const SessionBox> boxes);
  Status remove_boxes(std::span<const std::uint64_t> ids);

  // What a session of these options over a width x height source holds
  // (clip-map and trace scratch, or exact_bytes in exact mode; `boxes`
  // boxes), before it is opened; the shape's and backend's errors as open()
  // would give them.
  static Result<std::uint64_t> bytes_for(const SessionOptions& options, int width, int height, std::size_t boxes);

  Result<SessionAnswer> answer(const SessionPose& pose, const RunControl* control = nullptr);

 private:
  struct Entry {
    std::uint64_t id = 0;
    bool on_void = false;  // its footprint meets a void: never hidden, undetermined instead (cull.hpp's rule)
    bool reported = false;
    visibility::Visibility state = visibility::Visibility::kSeen;
  };
  ClipSession() = default;
  Result<std::vector<visibility::BoxFootprint>> resolve(std::span<const SessionBox> boxes, const char* list) const;
  Result<ClipEye> eye_for(const SessionPose& pose, ClipPose& clip) const;
  Result<bool> touches_void(const visibility::BoxFootprint& footprint) const;
  Result<ClipCullResult> cull_exact(const SessionPose& pose, const RunControl* control);
  Result<ViewshedSummary> viewshed_exact(const SessionPose& pose, const RunControl* control);
  Result<ClipCullResult> cull_clipmap(const ClipEye& eye, const RunControl* control, gpu::Lease* gl,
                                      SessionAnswer& out);
  Result<ViewshedSummary> viewshed_clipmap(const ClipEye& eye, const RunControl* control, gpu::Lease* gl,
                                           SessionAnswer& out);

  std::shared_ptr<const terrain::ElevationSource> source_;
  terrain::BlockCache* cache_ = nullptr;
  SessionOptions options_;
  std::shared_ptr<Clipmap> map_;
  std::shared_ptr<const terrain::SourcePyramid> pyramid_;
  std::unique_ptr<ClipmapUpdater> sync_;
  std::unique_ptr<AsyncClipmapUpdater> async_;
  LoaderStats last_loader_;
  std::uint64_t answers_ = 0;
  std::vector<Entry> entries_;
  std::vector<visibility::BoxFootprint> footprints_;  // entries_' boxes, same order
  std::vector<visibility::BoxSpec> specs_;            // and as the client gave them (exact mode plans from them)
  visibility::Workspace workspace_;                   // exact mode's buffers between answers
  ClipCullScratch scratch_;
  std::unordered_map<std::uint64_t, std::size_t> index_;
};

}  // namespace horizon::clipmap
