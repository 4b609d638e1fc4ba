// horizon/terrain/block_cache.hpp — decoded elevation blocks shared by every
// request, under a byte budget.
//
//   terrain::BlockCache cache({.budget_bytes = 128 << 20, .io_threads = 2});
//   auto source = terrain::ElevationSource::open("srtm/", {});   // source.hpp
//   auto dem = (*source)->read(window, &cache, &control);        // decodes what is missing
//
// A block is the unit a source decodes: a tile or a run of strips of one of
// its files (source.hpp says which). The cache maps (source id, block index)
// to the decoded float cells and keeps the most recently used ones while
// they fit in the budget (LRU eviction); a request holding a block it was
// given keeps it alive after an eviction until the request lets go.
//
// Decoding runs on the cache's own I/O pool (Boost.Asio, `io_threads`
// threads), several blocks at once. fetch() asks for a request's blocks in
// one go and waits only for those: a block already resident is a hit; a
// block another request is decoding right now is joined (decoded once, both
// get it); the rest are posted to the pool. A load that fails (missing,
// truncated or corrupt file) fails the requests that asked for that block,
// with the loader's error (naming the file and the block), and nothing else:
// the failure is not kept, the other blocks are.
//
// Built blocks. Besides decoded elevations the cache keeps blocks that are
// computed rather than read: a pyramid's reduced levels over a source
// (source_pyramid.hpp). build() computes one on the calling thread (it
// usually reads elevation blocks through fetch() first, which an I/O thread
// must not wait on), and keeps, shares, joins and evicts it exactly like a
// decoded block, under the same budget and LRU order. Keys of built blocks
// use a namespace of their own (next_source_id()), so one key never names
// two kinds of block.
//
// Memory: the blocks the cache keeps never exceed budget_bytes (a block
// larger than the whole budget is handed to its requester and not kept).
// Blocks still held by requests after their eviction are counted apart
// (`held_bytes`), so what the process really holds is resident + held.
// Thread-safe; one mutex guards the map, and decoding runs outside it.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <vector>

#include "horizon/common/control.hpp"
#include "horizon/common/error.hpp"
#include "horizon/terrain/grid.hpp"

namespace horizon::terrain {

struct BlockKey {
  std::uint64_t source = 0;  // ElevationSource::id(): one namespace per opened source
  std::uint64_t block = 0;   // the source's block index
  friend bool operator==(const BlockKey&, const BlockKey&) = default;
};

// Decoded cells of one block; shared, immutable.
using Block = std::shared_ptr<const Grid<float>>;
// Decodes one block (called on an I/O thread; must be thread-safe).
using BlockLoader = std::function<Result<Grid<float>>()>;

// Cumulative counters, and the bytes held now.
struct BlockCacheStats {
  std::uint64_t budget_bytes = 0;
  std::uint64_t resident_bytes = 0;  // blocks the cache keeps
  std::uint64_t resident_blocks = 0;
  std::uint64_t peak_resident_bytes = 0;
  std::uint64_t held_bytes = 0;  // evicted blocks still held by requests
  std::uint64_t hits = 0;        // asked for and resident
  std::uint64_t joins = 0;       // asked for while another request decoded it
  std::uint64_t misses = 0;      // asked for, absent: a decode was started
  std::uint64_t evictions = 0;
  std::uint64_t failures = 0;       // decodes that returned an error
  std::uint64_t bytes_decoded = 0;  // float bytes of the blocks decoded
  std::uint64_t builds = 0;         // blocks computed by build() (also counted as misses)
};

// What one fetch() found.
struct FetchStats {
  std::uint64_t blocks = 0, hits = 0, joins = 0, misses = 0;
  std::uint64_t bytes_decoded = 0;  // by this fetch's own misses
  double wait_seconds = 0.0;        // waiting for decodes (its own and joined ones)
};

class BlockCache {
 public:
  struct Options {
    std::uint64_t budget_bytes = 256ull << 20;
    unsigned io_threads = 2;  // >= 1
  };
  struct Want {
    BlockKey key;
    BlockLoader load;  // used only when the block is neither resident nor being decoded
  };

  explicit BlockCache(Options options);
  ~BlockCache();  // waits for the decodes in flight
  BlockCache(const BlockCache&) = delete;
  BlockCache& operator=(const BlockCache&) = delete;

  // The blocks of `wants`, in order. Waits for missing ones, polling
  // `control` (may be null) every few milliseconds: once it says stop, the
  // control's error is returned (decodes already started still finish and
  // are kept for the next request). A failed decode's error is returned
  // after every other wanted block has settled.
  Result<std::vector<Block>> fetch(std::span<const Want> wants, const RunControl* control = nullptr,
                                   FetchStats* stats = nullptr);

  // The block `key`, computed by `make` on this thread when it is neither
  // resident nor being built (or decoded) by another thread, whose result
  // it then waits for, polling `control` (may be null). T is an immutable
  // value with `std::uint64_t bytes() const`, its size for the budget; a key
  // must always be built as the same T. A failure of `make` is returned to
  // this call and to the calls that joined it, and is not kept. `stats`
  // (may be null) counts one block: a hit, a join or a miss.
  template <class T, class Make>
  Result<std::shared_ptr<const T>> build(BlockKey key, Make&& make, const RunControl* control = nullptr,
                                         FetchStats* stats = nullptr) {
    Result<Shared> got = build_shared(
        key,
        [&make]() -> Result<Shared> {
          Result<T> made = make();
          if (!made.ok()) return made.error();
          const std::uint64_t bytes = made->bytes();
          return Shared{std::make_shared<const T>(std::move(*made)), bytes};
        },
        control, stats);
    if (!got.ok()) return got.error();
    return std::static_pointer_cast<const T>(std::move(got->value));
  }

  // A fresh id for a source's keys (never reused in this process).
  static std::uint64_t next_source_id();

  BlockCacheStats stats() const;
  std::uint64_t budget_bytes() const;
  // Bytes of one source's blocks the cache keeps now.
  std::uint64_t resident_bytes_of(std::uint64_t source) const;

 private:
  // A block of any kind, with its size for the budget.
  struct Shared {
    std::shared_ptr<const void> value;
    std::uint64_t bytes = 0;
  };
  Result<Shared> build_shared(BlockKey key, const std::function<Result<Shared>()>& make, const RunControl* control,
                              FetchStats* stats);

  struct State;
  std::shared_ptr<State> state_;  // shared with the I/O tasks and the blocks' deleters
};

}  // namespace horizon::terrain
