// memory_budget.hpp — the daemon's resident-memory budget, enforced.
//
// Everything large the daemon holds is reserved here first: each resident
// dataset (its elevation grid) and each request's working set, estimated from
// the cells it will compute before any work (MemoryBudget::kViewshedBytesPerCell
// and friends cover the OHF, the terrain crop, the output raster, its encodings
// and the copy being streamed). A reservation that does not fit is refused:
// the request gets RESOURCE_EXHAUSTED, a dataset load fails. What is left
// outside the accounting (code, gRPC buffers, allocator slack) is the fixed
// kBaseBytes the budget sets aside at start.
#pragma once

#include <atomic>
#include <cstdint>

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

 private:
  friend class MemoryBudget;
  Reservation(MemoryBudget* budget, std::uint64_t bytes) : budget_(budget), bytes_(bytes) {}
  MemoryBudget* budget_ = nullptr;
  std::uint64_t bytes_ = 0;
};

class MemoryBudget {
 public:
  // Process overhead outside the accounting: code, libraries, gRPC and allocator slack.
  static constexpr std::uint64_t kBaseBytes = 48ull << 20;
  // Working set of a viewshed per window cell: OHF + terrain crop (8), the
  // derived raster (4), the mask (1), the streamed copy (4), GeoTIFF/PNG (<= 7).
  static constexpr std::uint64_t kViewshedBytesPerCell = 24;
  // Culling per window cell: OHF + terrain (8) and the min-pyramid (~5.4).
  static constexpr std::uint64_t kCullBytesPerCell = 14;
  // Culling per box: request and response messages, spec, footprint, result.
  static constexpr std::uint64_t kCullBytesPerBox = 256;

  explicit MemoryBudget(std::uint64_t total_bytes)
      : total_(total_bytes), available_(static_cast<std::int64_t>(total_bytes) - static_cast<std::int64_t>(kBaseBytes)) {}

  // A reservation of `bytes`, or an empty one (bytes() == 0 and ok == false) when it does not fit.
  bool try_reserve(std::uint64_t bytes, Reservation& out);

  std::uint64_t total() const { return total_; }
  // Bytes reserved now (without the base).
  std::uint64_t reserved() const;

 private:
  friend class Reservation;
  void give_back(std::uint64_t bytes) { available_.fetch_add(static_cast<std::int64_t>(bytes)); }

  const std::uint64_t total_;
  std::atomic<std::int64_t> available_;
};

}  // namespace horizon::server
