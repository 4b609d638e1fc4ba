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
// publish() before gRPC may call it back once its method handler returns,
// and calls from_grpc() first in each callback. In a TSan build these are
// __tsan_release and __tsan_acquire: on the Handoff itself for what came
// before a hand-off, and on a token shared with the handing thread for what
// gRPC did inside it (StartWrite serialises the message there), since the
// reactor may already be deleted when that call returns. In any other build
// Handoff is empty and they compile to nothing. They claim no more order
// than gRPC gives: a callback acquires only what was released before it ran.
#pragma once

#if defined(__SANITIZE_THREAD__)
#define HORIZON_TSAN_HANDOFF 1
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer)
#define HORIZON_TSAN_HANDOFF 1
#endif
#endif

#ifdef HORIZON_TSAN_HANDOFF
#include <memory>

#include <sanitizer/tsan_interface.h>
#endif

namespace horizon::server {

class Handoff {
 public:
  // Runs `start`, which hands the reactor to gRPC: what this thread did
  // before it and in it (serialising a message, filling gRPC's call ops)
  // happens before the callback gRPC runs for it. `start` may end in the
  // reactor's deletion (Finish); nothing of the reactor is touched after it.
  template <class Start>
  void to_grpc(Start&& start) {
#ifdef HORIZON_TSAN_HANDOFF
    const std::shared_ptr<char> token = token_;
    __tsan_release(this);
    start();
    __tsan_release(token.get());
#else
    start();
#endif
  }

  // What this thread did so far happens before the reactor's next callback.
  void publish() const {
#ifdef HORIZON_TSAN_HANDOFF
    __tsan_release(const_cast<Handoff*>(this));
#endif
  }

  // First in each callback gRPC runs for the reactor.
  void from_grpc() const {
#ifdef HORIZON_TSAN_HANDOFF
    __tsan_acquire(const_cast<Handoff*>(this));  // orders the read of token_ too
    __tsan_acquire(token_.get());
#endif
  }

 private:
#ifdef HORIZON_TSAN_HANDOFF
  std::shared_ptr<char> token_ = std::make_shared<char>();
#endif
};

}  // namespace horizon::server
