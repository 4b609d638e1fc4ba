// allocator.hpp — how the daemon's heap gives memory back.
//
// glibc's malloc keeps freed memory for reuse: a flood of large calls leaves
// the heap as large as its peak, fragmented across the threads' arenas, long
// after the calls are gone (a 24-client flood of 100 000-box calls left
// 80 MB more than the daemon started with, with nothing reserved). So:
// - every block of 64 KiB or more is mapped on its own (a large call's arena
//   blocks, raster buffers, gRPC's large slices): freeing it unmaps it. The
//   thresholds are fixed, which also stops glibc raising the mapping
//   threshold after each large free;
// - when the daemon falls idle (its last call gone) and is still idle a
//   moment later, HeapTrimmer hands the free pages inside every arena back to
//   the system (malloc_trim), at most once a second: a client calling 60
//   times a second idles the daemon between calls, and must not pay a trim
//   each time.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <mutex>
#include <thread>

namespace horizon::server {

// Block size from which allocations are mapped on their own.
inline constexpr std::size_t kMappedFromBytes = 64 << 10;
// Free heap top above which the heap is trimmed at each free.
inline constexpr std::size_t kTrimAboveBytes = 1 << 20;

// Sets the thresholds (glibc; elsewhere nothing). Call once, before any thread starts.
void tune_allocator();

// A thread that trims the heap a little after the daemon falls idle.
class HeapTrimmer {
 public:
  // How long after idle() the heap is trimmed: time for gRPC to free the last
  // call's messages, and for a burst of calls to end together.
  static constexpr std::chrono::milliseconds kDelay{100};
  // The least time between two trims.
  static constexpr std::chrono::milliseconds kInterval{1000};

  // `live_calls`: the daemon's count of calls (ServerEnv::live_calls); a trim
  // is skipped when it is not 0 by the end of kDelay. Must outlive the trimmer.
  explicit HeapTrimmer(const std::atomic<std::uint32_t>& live_calls);
  ~HeapTrimmer();  // stops the thread
  HeapTrimmer(const HeapTrimmer&) = delete;
  HeapTrimmer& operator=(const HeapTrimmer&) = delete;

  // The daemon has no call left: trim after kDelay (calls coalesce). Cheap; any thread.
  void idle();
  // Trims done so far.
  std::uint64_t trims() const;

 private:
  void run();

  mutable std::mutex mutex_;
  std::condition_variable wake_;
  bool wanted_ = false, stopping_ = false;
  std::uint64_t trims_ = 0;
  const std::atomic<std::uint32_t>& live_calls_;
  std::thread thread_;
};

}  // namespace horizon::server
