// handoff.hpp — where a call passes between threads through gRPC, said so
// that ThreadSanitizer can see it.
//
// A reactor hands work to gRPC from one thread (StartWrite, StartRead,
// Finish, or returning from the method handler) and gRPC runs its
// callbacks (OnWriteDone, OnReadDone, OnCancel, OnDone) on another. The
// completion queue between them orders the two, but Debian builds gRPC
// without ThreadSanitizer, so TSan cannot see that order and reads every
// later touch of the reactor, of the messages gRPC serialised from it and of
// what its destructor frees as a data race.
//
// Each reactor holds a Handoff. It wraps each hand-off in to_grpc(), calls
// publish() before gRPC may call it back once its method handler returns
// and at the end of an OnCancel that does not finish the call (gRPC runs
// OnDone only after OnCancel has returned, but TSan cannot see that), and
// calls from_grpc() first in each callback. In a TSan build these are
// __tsan_release and __tsan_acquire on the Handoff, and from_grpc() also
// waits until no other thread is still inside a hand-off: gRPC may run
// OnWriteDone or OnDone before the StartWrite or Finish that caused it has
// returned on the thread that called it, and what gRPC did inside that call
// (filling its call ops, reading the response) must be ordered before the
// next write reuses them or the reactor and gRPC's call state go away. That
// wait is real synchronisation, so TSan sees it; it never blocks long, since
// gRPC's Finish and StartWrite only queue work, and it relies on gRPC never
// running a reactor's OnDone inside that reactor's own Finish (it schedules
// OnDone for reactors it does not inline). In any other build Handoff is
// empty and all of this compiles to nothing. It claims no more order than
// gRPC gives: a callback acquires only what was released before it ran.
#pragma once

#if defined(__SANITIZE_THREAD__)
#define HORIZON_TSAN_HANDOFF 1
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer)
#define HORIZON_TSAN_HANDOFF 1
#endif
#endif

#ifdef HORIZON_TSAN_HANDOFF
#include <atomic>
#include <thread>

#include <sanitizer/tsan_interface.h>
#endif

namespace horizon::server {

class Handoff {
 public:
  // Runs `start`, which hands the reactor to gRPC: what this thread did
  // before it and in it (serialising a message, filling gRPC's call ops)
  // happens before the callback gRPC runs for it.
  template <class Start>
  void to_grpc(Start&& start) {
#ifdef HORIZON_TSAN_HANDOFF
    in_flight_.fetch_add(1, std::memory_order_relaxed);
    ++handing_off_on_this_thread;
    __tsan_release(this);
    start();
    __tsan_release(this);
    --handing_off_on_this_thread;
    in_flight_.fetch_sub(1, std::memory_order_release);
#else
    start();
#endif
  }

  // What this thread did so far happens before the reactor's next callback.
  void publish() {
#ifdef HORIZON_TSAN_HANDOFF
    __tsan_release(this);
#endif
  }

  // First in each callback gRPC runs for the reactor, OnDone included.
  void from_grpc() {
#ifdef HORIZON_TSAN_HANDOFF
    // Not when gRPC runs the callback inside this thread's own hand-off.
    if (handing_off_on_this_thread == 0)
      while (in_flight_.load(std::memory_order_acquire) != 0) std::this_thread::yield();
    __tsan_acquire(this);
#endif
  }

 private:
#ifdef HORIZON_TSAN_HANDOFF
  std::atomic<int> in_flight_{0};
  static inline thread_local int handing_off_on_this_thread = 0;
#endif
};

}  // namespace horizon::server
