// deadline_watch.hpp — ends calls whose default deadline passes outside the
// engine.
//
// gRPC enforces a deadline the client sent; the daemon's default deadline
// (config default_deadline_ms, for calls that carry none) lives only in the
// call's RunControl, which the engine polls. Once the engine is done, a call
// can still wait on its client: a viewshed stream whose reader never drains
// it, a large answer the client never reads. DeadlineWatch cancels such a
// call (ServerContext::TryCancel) when its default deadline passes, so that
// its limits.max_pending slot and its memory come back then. One thread,
// sleeping until the nearest deadline.
#pragma once

#include <chrono>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <queue>
#include <thread>
#include <vector>

#include <grpcpp/server_context.h>

namespace horizon::server {

// A call under watch. release() before the call's context goes away (gRPC's
// OnDone): after it returns, the watch never touches the context.
class WatchedCall {
 public:
  explicit WatchedCall(grpc::CallbackServerContext* context) : context_(context) {}
  void release();
  // Cancels the call unless released.
  void cancel();

 private:
  std::mutex mutex_;
  grpc::CallbackServerContext* context_;
};

class DeadlineWatch {
 public:
  DeadlineWatch();
  ~DeadlineWatch();  // stops the thread; calls still watched are left alone
  DeadlineWatch(const DeadlineWatch&) = delete;
  DeadlineWatch& operator=(const DeadlineWatch&) = delete;

  // Cancels `context`'s call at `deadline` unless the returned handle is released first.
  std::shared_ptr<WatchedCall> watch(grpc::CallbackServerContext* context,
                                     std::chrono::steady_clock::time_point deadline);

 private:
  struct Entry {
    std::chrono::steady_clock::time_point deadline;
    std::weak_ptr<WatchedCall> call;
    bool operator>(const Entry& o) const { return deadline > o.deadline; }
  };
  void run();

  std::mutex mutex_;
  std::condition_variable wake_;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<>> entries_;
  bool stopping_ = false;
  std::thread thread_;
};

}  // namespace horizon::server
