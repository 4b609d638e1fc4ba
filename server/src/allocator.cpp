#include "allocator.hpp"

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace horizon::server {

void tune_allocator() {
#if defined(__GLIBC__)
  mallopt(M_MMAP_THRESHOLD, static_cast<int>(kMappedFromBytes));
  mallopt(M_TRIM_THRESHOLD, static_cast<int>(kTrimAboveBytes));
#endif
}

HeapTrimmer::HeapTrimmer(const std::atomic<std::uint32_t>& live_calls)
    : live_calls_(live_calls), thread_([this] { run(); }) {}

HeapTrimmer::~HeapTrimmer() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_one();
  thread_.join();
}

void HeapTrimmer::idle() {
  {
    std::lock_guard lock(mutex_);
    wanted_ = true;
  }
  wake_.notify_one();
}

std::uint64_t HeapTrimmer::trims() const {
  std::lock_guard lock(mutex_);
  return trims_;
}

void HeapTrimmer::run() {
  std::unique_lock lock(mutex_);
  for (;;) {
    wake_.wait(lock, [this] { return wanted_ || stopping_; });
    if (stopping_) return;
    // Let the burst end; an idle() meanwhile is served by this same trim.
    if (wake_.wait_for(lock, kDelay, [this] { return stopping_; })) return;
    wanted_ = false;
    if (live_calls_.load() != 0) continue;  // busy again: the next idle() asks again
    lock.unlock();
#if defined(__GLIBC__)
    malloc_trim(0);
#endif
    lock.lock();
    ++trims_;
    if (wake_.wait_for(lock, kInterval - kDelay, [this] { return stopping_; })) return;
  }
}

}  // namespace horizon::server
