// horizon/clipmap/clipmap_updater.hpp — keeps a clip-map around a moving
// clip centre: each level on its own schedule, loading only what moved in.
//
//   auto pyramid = terrain::SourcePyramid::make(source, cache, terrain::Reduction::kMean,
//                                               clipmap::pyramid_options_for(shape));
//   auto updater = clipmap::ClipmapUpdater::make(map, *pyramid, {});
//   updater->update({.col = 5120.5, .row = 880.0, .col_per_s = 8.3});   // a pose, on this thread
//
//   clipmap::AsyncClipmapUpdater loader(std::move(*updater));          // or on a loader thread
//   loader.post(pose);                                                  // latest pose wins
//
// Poses are in source grid coordinates (cell centres at integers), velocity
// in cells per second. The clip centre is the pose led along its velocity by
// UpdaterOptions::lead_seconds, so the levels fill ahead of the client.
//
// Schedule (the patent's asynchronous levels): pose number p (counted from 1)
// brings level k to the clip centre when p is a multiple of every[k]; by
// default every[k] = 2^(k+1), at most 64 (finest every 2nd pose, the next
// every 4th, ...). A level that has never been loaded is loaded at the first
// pose whatever its schedule, and a full-extent level is loaded once and
// never again. Bringing a level to the centre means: take the origin
// Clipmap::origin_for() gives; if it differs from the level's (or the level
// has gaps), read the level's missing sub-tiles from the pyramid (level 0
// from the source itself, through the block cache), without any lock, in
// runs along sub-tile rows; then publish them and the origin at once. A
// move of (dx, dy) sub-tiles reads about (|dx| + |dy|) n / t of them;
// nothing resident is read again.
//
// update_all() brings every level to the centre at once, whatever the
// schedule: a session's first pose, and the prior art's synchronous update
// (all levels, every pose) that benchmarks compare against.
//
// Errors: a read that fails (missing tile, corrupt file, cancelled) fails
// the update with the source's message and publishes nothing for that level;
// levels already published in that update stay published.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "horizon/clipmap/clipmap.hpp"
#include "horizon/common/control.hpp"
#include "horizon/terrain/source_pyramid.hpp"

namespace horizon::clipmap {

struct ClipPose {
  double col = 0.0, row = 0.0;              // source grid coordinates of the client
  double col_per_s = 0.0, row_per_s = 0.0;  // its velocity, cells per second
  std::uint64_t seq = 0;                    // recorded as LevelState::pose; 0: the updater's own count
};

struct UpdaterOptions {
  std::vector<int> every;     // per level, poses between updates (>= 1); empty: 2^(k+1), at most 64
  double lead_seconds = 0.5;  // clip centre = position + velocity * lead_seconds; >= 0
};

// What one update did.
struct UpdateReport {
  std::uint64_t pose = 0;             // its number
  std::vector<int> levels;            // levels published, finest first
  std::uint64_t subtiles_loaded = 0;  // all levels
  std::uint64_t cells_loaded = 0;     // samples read from the pyramid and source
  std::uint64_t bytes_loaded = 0;     // cells_loaded * 4
  double seconds = 0.0;
};

// The SourcePyramid options a shape needs (factor 2, enough levels).
terrain::SourcePyramidOptions pyramid_options_for(const ClipmapShape& shape);

class ClipmapUpdater {
 public:
  // The pyramid must be of the clip-map's source (same size), factor 2,
  // with the clip-map's reduction and at least levels - 1 reduced levels.
  static Result<ClipmapUpdater> make(std::shared_ptr<Clipmap> map,
                                     std::shared_ptr<const terrain::SourcePyramid> pyramid,
                                     const UpdaterOptions& options = {});

  const Clipmap& map() const { return *map_; }
  std::uint64_t poses() const { return pose_; }

  // Counts pose p = poses() + 1 and brings the levels due at p to it.
  Result<UpdateReport> update(const ClipPose& pose, const RunControl* control = nullptr);
  // Counts a pose and brings every level to it.
  Result<UpdateReport> update_all(const ClipPose& pose, const RunControl* control = nullptr);

 private:
  ClipmapUpdater(std::shared_ptr<Clipmap> map, std::shared_ptr<const terrain::SourcePyramid> pyramid,
                 std::vector<int> every, double lead);
  Result<UpdateReport> run(const ClipPose& pose, bool all, const RunControl* control);
  Status bring(int k, double col, double row, std::uint64_t seq, const RunControl* control, UpdateReport& report);

  std::shared_ptr<Clipmap> map_;
  std::shared_ptr<const terrain::SourcePyramid> pyramid_;
  std::vector<int> every_;
  std::vector<bool> loaded_;
  double lead_;
  std::uint64_t pose_ = 0;
};

// Totals of an AsyncClipmapUpdater.
struct LoaderStats {
  std::uint64_t posted = 0;   // poses given to post()
  std::uint64_t applied = 0;  // poses the loader updated for
  std::uint64_t skipped = 0;  // poses replaced by a newer one before the loader took them
  std::uint64_t subtiles_loaded = 0, bytes_loaded = 0;
  std::optional<Error> last_error;  // of the most recent update that failed
};

// A ClipmapUpdater on a thread of its own. post() never waits for loading:
// it leaves the pose for the loader, replacing one not yet taken (latest
// pose wins), and the loader updates for each pose it takes. The
// destructor stops the thread after the update in progress.
class AsyncClipmapUpdater {
 public:
  explicit AsyncClipmapUpdater(ClipmapUpdater updater);
  ~AsyncClipmapUpdater();
  AsyncClipmapUpdater(const AsyncClipmapUpdater&) = delete;
  AsyncClipmapUpdater& operator=(const AsyncClipmapUpdater&) = delete;

  void post(const ClipPose& pose);
  // Waits until every posted pose has been taken and its update finished.
  void wait_idle();
  LoaderStats stats() const;

 private:
  void loop();

  ClipmapUpdater updater_;
  mutable std::mutex mutex_;
  std::condition_variable wake_, idle_;
  std::optional<ClipPose> pending_;
  bool busy_ = false, stop_ = false;
  CancelToken cancel_;
  LoaderStats stats_;
  std::thread thread_;
};

}  // namespace horizon::clipmap
