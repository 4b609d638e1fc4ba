// horizon/clipmap/clipmap.hpp — an elevation clip-map: a stack of fixed-size,
// toroidally addressed levels around a moving clip centre (US 7,626,591,
// applied to elevation instead of imagery).
//
//   auto map = clipmap::Clipmap::make(source_width, source_height, {.levels = 8, .level_size = 1024});
//   clipmap::ClipmapUpdater updater(map, source, cache, ...);   // fills it (clipmap_updater.hpp)
//   {
//     clipmap::ClipmapReader view(*map);     // one consistent snapshot while it lives
//     float z = view.sample(3, col, row);    // level 3, with coarse fallback
//   }
//
// Levels. Level k holds n x n samples (n = level_size, a power of two) of the
// source's level-k pyramid (terrain/source_pyramid.hpp: cell (i, j) reduces
// source cells [i 2^k, (i+1) 2^k) x [j 2^k, (j+1) 2^k)), so its samples are
// 2^k source cells apart and its centres sit at source grid coordinate
// i 2^k + (2^k - 1) / 2. Each level is a torus of (n/t) x (n/t) sub-tiles of
// t x t samples (t = subtile) with an origin of its own, a multiple of t in
// level cells: the level covers level cells [origin, origin + n) per axis,
// and level cell (i, j) lives in slot (i mod n, j mod n) (stored in 4 x 4
// bricks, one cache line each: sample_index()), so moving the
// origin by one sub-tile makes room for exactly the newly revealed sub-tiles
// and nothing resident moves. A level with n >= its width and height is a
// full-extent level: origin (0, 0) for good, always complete once loaded.
// The coarsest level must be one (make() refuses a shape whose levels do
// not reach), so a sample always has a level to fall back to.
//
// Tags. Every slot records which world sub-tile it holds (or none). A slot
// not yet overwritten after its level moved still holds the old sub-tile's
// samples, and its tag says so: reads check the tag and never return
// another sub-tile's terrain.
//
// Validity grid. One byte per finest-level sub-tile position of the source
// (t x t source cells) holds the finest level whose resident sub-tile covers
// it (kNoLevel before the first load). A sample asked at level k reads at
// max(k, validity) and steps coarser while a cell it needs is not resident;
// each step counts as a fallback.
//
// Snapshots and writers. The loader (ClipmapUpdater) reads new sub-tiles
// from the source without any lock and publishes a level's whole update
// (origin, samples, tags, validity, version) under the clip-map's write lock.
// A ClipmapReader holds the read lock for its life: everything it reads is
// one consistent state, and each level's version says which. Publishing
// waits for readers to finish; readers never wait for loading.
#pragma once

#include <cstdint>
#include <limits>
#include <memory>
#include <shared_mutex>
#include <span>
#include <vector>

#include "horizon/common/error.hpp"
#include "horizon/terrain/grid.hpp"
#include "horizon/terrain/pyramid.hpp"

namespace horizon::clipmap {

struct ClipmapShape {
  static constexpr int kMaxLevels = 10;  // the source pyramid's reach with 512-cell blocks, plus level 0
  int levels = 8;                        // L: 1..kMaxLevels
  int level_size = 1024;                 // n: a power of two in [64, 4096]
  int subtile = 64;                      // t: a power of two in [8, n/2]
  // Samples of the levels: mean (fast, continuous LOD), min (occluders that
  // are never above the terrain: conservative culling) or max.
  terrain::Reduction reduction = terrain::Reduction::kMean;
};

// The fewest levels of `level_size` samples whose coarsest covers a source
// of width x height cells (at most ClipmapShape::kMaxLevels).
inline int levels_to_cover(int level_size, int width, int height) {
  const long long longest = width > height ? width : height;
  int levels = 1;
  while (levels < ClipmapShape::kMaxLevels && (static_cast<long long>(level_size) << (levels - 1)) < longest) ++levels;
  return levels;
}

// A level's place: level cells [col0, col0 + n) x [row0, row0 + n).
struct LevelOrigin {
  int col0 = 0, row0 = 0;
  friend bool operator==(const LevelOrigin&, const LevelOrigin&) = default;
};

// What a reader knows of one level.
struct LevelState {
  LevelOrigin origin;
  bool full_extent = false;
  std::uint64_t version = 0;           // publications so far (0: never loaded)
  std::uint64_t pose = 0;              // the pose number its last publication was made for
  std::uint64_t resident_subtiles = 0;
};

// A sub-tile of one level, by its level-cell corner / t.
struct SubtileKey {
  int tx = 0, ty = 0;
  friend bool operator==(const SubtileKey&, const SubtileKey&) = default;
};

// One level's update, prepared by the loader: the new origin and the
// samples of the sub-tiles that were not resident (t x t each, row-major,
// NaN outside the source).
struct LevelUpdate {
  int level = 0;
  LevelOrigin origin;
  std::uint64_t pose = 0;
  std::vector<SubtileKey> keys;
  std::vector<float> samples;  // keys.size() * t * t
};

class ClipmapReader;

class Clipmap {
 public:
  static constexpr std::uint8_t kNoLevel = 0xff;

  // Checks the shape against a source of width x height cells; errors name
  // the field ("clipmap.levels", "clipmap.level_size", "clipmap.subtile").
  static Result<std::shared_ptr<Clipmap>> make(int source_width, int source_height, const ClipmapShape& shape);
  // make()'s checks alone, and the bytes such a clip-map holds: what a
  // server reserves before it allocates one.
  static Status check(int source_width, int source_height, const ClipmapShape& shape);
  static std::uint64_t bytes_for(int source_width, int source_height, const ClipmapShape& shape);

  const ClipmapShape& shape() const { return shape_; }
  // A number no other clip-map made in this process has: with a level's
  // version it names that level's contents (what a GPU copy is keyed by).
  std::uint64_t id() const { return id_; }
  int source_width() const { return width_; }
  int source_height() const { return height_; }
  int level_width(int k) const { return ((width_ - 1) >> k) + 1; }
  int level_height(int k) const { return ((height_ - 1) >> k) + 1; }
  bool full_extent(int k) const { return shape_.level_size >= level_width(k) && shape_.level_size >= level_height(k); }
  // Bytes the levels, tags and validity grid hold (fixed at make()).
  std::uint64_t bytes() const;

  // The origin level k takes for a clip centre at source grid coordinates
  // (col, row): the multiple of t nearest to centring the window on it, or
  // (0, 0) for a full-extent level.
  LevelOrigin origin_for(int k, double col, double row) const;
  // The sub-tiles of level k's window at `origin` that lie in the source
  // and are not resident now (the ones an update to it must load), in rows.
  std::vector<SubtileKey> missing_subtiles(int k, const LevelOrigin& origin) const;

  // Installs an update: moves the level's origin, drops the tags of slots
  // that leave its window, writes the new sub-tiles, refreshes validity and
  // bumps the level's version. Takes the write lock.
  void publish(const LevelUpdate& update);

 private:
  friend class ClipmapReader;
  struct Level {
    LevelOrigin origin;
    bool loaded_once = false;
    bool complete = false;           // every window sub-tile inside the source is resident
    std::uint64_t version = 0, pose = 0, resident = 0;
    std::vector<float> samples;      // n * n, slot-addressed
    std::vector<SubtileKey> tags;    // (n/t)^2, kEmptyTag when none
  };
  static constexpr SubtileKey kEmptyTag{std::numeric_limits<int>::min(), std::numeric_limits<int>::min()};

  Clipmap(int width, int height, const ClipmapShape& shape);
  int slot_of(int tx, int ty) const { return (ty & (tiles_ - 1)) * tiles_ + (tx & (tiles_ - 1)); }
  // Where level cell (i, j) lives in a level's samples: toroidal (i, j mod n)
  // and in 4 x 4 bricks of 64 bytes, so that a bilinear sample's four cells
  // and a ray's next ones mostly share a cache line.
  std::size_t sample_index(int i, int j) const {
    const unsigned mask = static_cast<unsigned>(shape_.level_size - 1);
    const unsigned u = static_cast<unsigned>(i) & mask, v = static_cast<unsigned>(j) & mask;
    return (static_cast<std::size_t>(v >> 2) << (log_n_ + 2)) + ((u >> 2) << 4) + ((v & 3u) << 2) + (u & 3u);
  }
  bool in_window(const LevelOrigin& o, int tx, int ty) const;
  bool resident(int k, int tx, int ty) const;  // caller holds a lock
  bool inside_source(int k, int tx, int ty) const;
  void refresh_validity(int k, int tx, int ty);  // under the write lock

  ClipmapShape shape_;
  std::uint64_t id_;
  int width_, height_;
  int tiles_;     // n / t
  int log_t_;     // log2 t
  int log_n_;     // log2 n
  int valid_w_, valid_h_;
  std::vector<Level> levels_;
  std::vector<std::uint8_t> validity_;  // valid_w_ * valid_h_
  mutable std::shared_mutex mutex_;
};

// Counts a reader keeps of what its samples did.
struct SampleStats {
  std::uint64_t samples = 0;
  std::uint64_t fallbacks = 0;  // samples read at a coarser level than asked
};

// A consistent read-only view of a clip-map: holds its read lock.
class ClipmapReader {
 public:
  explicit ClipmapReader(const Clipmap& map);
  ClipmapReader(const ClipmapReader&) = delete;
  ClipmapReader& operator=(const ClipmapReader&) = delete;

  const Clipmap& map() const { return map_; }
  LevelState level(int k) const;

  // True when level k's cell (i, j) (level cells) is resident.
  bool resident(int k, int i, int j) const;
  // Level k's cell (i, j); NaN outside the source. The cell must be resident.
  float cell(int k, int i, int j) const;

  // The terrain at source grid coordinates (col, row), interpolated
  // bilinearly between the level-k centres around it, from level k or the
  // first coarser level where all four are resident. NaN outside the source
  // (and where the level's reduction gives NaN: a block of voids). Adds to
  // `stats`; `*used` (may be null) gets the level read.
  float sample(int k, double col, double row, SampleStats& stats, int* used = nullptr) const;
  // out[i] = sample(k, cols[i], rows[i], stats) for i < count, the same
  // values and counts, faster where level k is complete (no tag or
  // validity look-ups inside its window).
  void sample_many(int k, std::size_t count, const double* cols, const double* rows, float* out,
                   SampleStats& stats) const;

  // The least level-k cell (or coarser, as sample() falls back) among those
  // meeting source cells [col0, col1] x [row0, row1] (inclusive, clipped to
  // the source): on a min clip-map a height no point of the rectangle's
  // terrain is below. +infinity when the rectangle misses the source;
  // -infinity where a void meets it or no level holds it (nothing bounds it).
  float lowest(int k, int col0, int row0, int col1, int row1, SampleStats& stats) const;

  // Level k as its slots hold it, for a copy elsewhere (a GPU texture):
  // samples[v n + u] is slot (u, v), where level cell (i, j) lives when
  // u = i mod n and v = j mod n (NaN where nothing was ever written), and
  // resident[ty (n/t) + tx] is 1 where sub-tile slot (tx, ty) holds a
  // sub-tile of the level's window (cell (i, j) is resident exactly when it
  // lies in the window and its slot's byte is 1). Both hold n^2 and
  // (n/t)^2 entries.
  void copy_level(int k, float* samples, std::uint8_t* resident) const;

 private:
  int level_for(int k, double col, double row) const;
  const Clipmap& map_;
  std::shared_lock<std::shared_mutex> lock_;
};

}  // namespace horizon::clipmap
