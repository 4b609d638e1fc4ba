// worker_pool.hpp — where computations run: a Boost.Asio thread pool, so
// gRPC's own threads only receive, translate and send. (Asio stays inside
// worker_pool.cpp; this header is cheap to include.)
#pragma once

#include <atomic>
#include <functional>
#include <memory>

namespace horizon::server {

// A call's place in the worker queue. Whichever comes first wins: the worker
// that dequeues the call takes it and runs it, or the call's cancellation
// (client gone, deadline passed) drops it and finishes it at once, so that a
// call whose deadline passes in the queue gives its limits.max_pending slot
// back then, not when a worker reaches it. The task holds the ticket, not
// the call: after a drop the call may already be deleted. Copies share one
// state.
class QueueTicket {
 public:
  bool take() { return settle(kTaken); }  // the worker: true = run the call
  bool drop() { return settle(kDropped); }  // the cancellation: true = finish the call now

 private:
  enum : int { kQueued, kTaken, kDropped };
  bool settle(int to) {
    int expected = kQueued;
    return state_->compare_exchange_strong(expected, to);
  }
  std::shared_ptr<std::atomic<int>> state_ = std::make_shared<std::atomic<int>>(kQueued);
};

class WorkerPool {
 public:
  // `threads` workers; 0 = all hardware threads.
  explicit WorkerPool(unsigned threads);
  ~WorkerPool();
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  // Queues `task`; it runs on a worker thread. Tasks must not throw.
  void post(std::function<void()> task);
  // Waits for every queued task, then stops the workers. Idempotent.
  void join();
  unsigned threads() const { return threads_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  unsigned threads_;
};

}  // namespace horizon::server
