// memory_budget.hpp — the daemon's resident-memory budget, enforced.
//
// Everything large the daemon holds is reserved here first: the shared block
// cache (its whole budget, at start); gRPC's receive buffers for requests
// still on the wire (config receive_buffer_mb, at start: gRPC enforces it
// as its resource quota); on a software rasteriser, the images the GL
// contexts hold (gl_image_budget.hpp); each request's messages when it is
// admitted, before it queues for a worker (the request as gRPC handed it
// over, arena_allocator.hpp's held_bytes, and for CullBoxes its answer,
// kResponseBytesPerBox a box), and with them what the request alone fixes
// of its working set (CullBoxes and RegionVisibility their boxes'
// conversion, kCullBytesPerBox / region::kBytesPerBox a box, LineOfSight its
// lines' plans), so that calls queued behind a running one cannot hold what
// it needs to start; and each request's working set before any work (grown
// from that share to the plan's whole): the engine's part from the
// request's plan (visibility/plan.hpp: the cells read, the OHF, the
// algorithm's tables, per box and per profile sample), the server's own
// part from what it will send
// (kEncodingBytesPerCell for a raster's encodings, kMessageBytesPerBox and
// kMessageBytesPerLine for the messages); and the workers' buffers kept
// from one run to the next (worker_memory.hpp). A reservation that does not
// fit is refused: the request gets RESOURCE_EXHAUSTED. What is left outside the
// accounting (code, libraries, allocator slack) is the fixed kBaseBytes
// the budget sets aside at start. The parse of each request holds a bound of
// what it allocates until it is parsed (ParseAllowanceOfBudget); a call that
// has started and finds the budget short only by what parses hold waits for
// them to end (reserve_after_parses), and no parse starts and no call is
// admitted meanwhile, so that a flood of arriving requests cannot starve the
// calls already admitted.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>

#include "parse_guard.hpp"

namespace horizon::server {

class MemoryBudget;

// Holds bytes of a budget until destroyed. Movable, not copyable.
class Reservation {
 public:
  Reservation() = default;
  Reservation(Reservation&& other) noexcept : budget_(other.budget_), bytes_(other.bytes_) { other.budget_ = nullptr; }
  Reservation& operator=(Reservation&& other) noexcept;
  Reservation(const Reservation&) = delete;
  Reservation& operator=(const Reservation&) = delete;
  ~Reservation() { release(); }

  std::uint64_t bytes() const { return budget_ ? bytes_ : 0; }
  void release();
  // Takes over `more` (of the same budget, or empty): this one then holds
  // both, and `more` nothing.
  void absorb(Reservation&& more);
  // Moves `bytes` of this one (at most what it holds) into a reservation of
  // their own: a call handing a part of its memory to someone who keeps it.
  Reservation split(std::uint64_t bytes);

 private:
  friend class MemoryBudget;
  Reservation(MemoryBudget* budget, std::uint64_t bytes) : budget_(budget), bytes_(bytes) {}
  MemoryBudget* budget_ = nullptr;
  std::uint64_t bytes_ = 0;
};

class MemoryBudget {
 public:
  // Process overhead outside the accounting: code, libraries and allocator slack.
  static constexpr std::uint64_t kBaseBytes = 48ull << 20;
  // A viewshed's encodings per output cell: the derived raster (4), the mask
  // (1), the streamed copy (4), GeoTIFF/PNG bytes (<= 7).
  static constexpr std::uint64_t kEncodingBytesPerCell = 16;
  // More per output cell when the GeoTIFF is a COG (its overviews, a third
  // of the raster, built before it is written, and the file laid out anew)
  // or left uncompressed (up to 4 bytes a cell more than deflate's).
  static constexpr std::uint64_t kLayoutBytesPerCell = 4;
  // A session's box per pose: the request and response messages.
  static constexpr std::uint64_t kMessageBytesPerBox = 160;
  // A CullBoxes answer per box, on the call's arena (tested against the real message).
  static constexpr std::uint64_t kResponseBytesPerBox = 64;
  // A sight line's result message, and one profile sample's.
  static constexpr std::uint64_t kMessageBytesPerLine = 512;
  static constexpr std::uint64_t kMessageBytesPerSample = 96;

  explicit MemoryBudget(std::uint64_t total_bytes)
      : total_(total_bytes),
        available_(static_cast<std::int64_t>(total_bytes) - static_cast<std::int64_t>(kBaseBytes)) {}

  // A reservation of `bytes`, or an empty one (bytes() == 0 and ok == false) when it does not fit.
  bool try_reserve(std::uint64_t bytes, Reservation& out);

  // Unscoped form for an account that grows and shrinks (the GL contexts'
  // images, gl_image_budget.hpp): takes `bytes` or nothing; give() returns
  // bytes taken so.
  bool try_take(std::uint64_t bytes);
  void give(std::uint64_t bytes) { give_back(bytes); }

  // A parse's hold (ParseAllowanceOfBudget): as try_take, but refused while
  // a call waits in reserve_after_parses; give_parse() returns it.
  bool try_take_parse(std::uint64_t bytes);
  void give_parse(std::uint64_t bytes);
  // try_reserve for a call being admitted: refused too while a call that has
  // started waits in reserve_after_parses (the memory a parse gives back is
  // that call's).
  bool try_reserve_new(std::uint64_t bytes, Reservation& out);
  // try_reserve for a call that has started: where the bytes do not fit now
  // but would without what parses hold, waits for those parses to end (new
  // ones are refused meanwhile), until `until` at the latest. False at once
  // when even that would not make room.
  bool reserve_after_parses(std::uint64_t bytes, Reservation& out, std::chrono::steady_clock::time_point until);

  std::uint64_t total() const { return total_; }
  // Bytes reserved now (without the base).
  std::uint64_t reserved() const;

 private:
  friend class Reservation;
  void give_back(std::uint64_t bytes) { available_.fetch_add(static_cast<std::int64_t>(bytes)); }

  const std::uint64_t total_;
  std::atomic<std::int64_t> available_;
  std::atomic<std::int64_t> parsing_{0};   // held by parses now
  std::atomic<std::uint32_t> waiting_{0};  // calls in reserve_after_parses
  std::mutex parse_mutex_;                 // for parse_ended_
  std::condition_variable parse_ended_;
};

// The budget as the allowance of the requests' parsing (protos/guard/
// parse_guard.hpp): a request is parsed only when the bound of what parsing
// it allocates fits, and holds that bound until it is parsed; admission
// then reserves what it really holds.
class ParseAllowanceOfBudget final : public proto::ParseAllowance {
 public:
  explicit ParseAllowanceOfBudget(MemoryBudget& budget) : budget_(budget) {}
  bool take(std::uint64_t bytes) override { return budget_.try_take_parse(bytes); }
  void give(std::uint64_t bytes) override { budget_.give_parse(bytes); }

 private:
  MemoryBudget& budget_;
};

}  // namespace horizon::server
