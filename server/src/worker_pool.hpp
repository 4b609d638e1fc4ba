// worker_pool.hpp — where computations run: a Boost.Asio thread pool, so
// gRPC's own threads only receive, translate and send. (Asio stays inside
// worker_pool.cpp; this header is cheap to include.)
#pragma once

#include <functional>
#include <memory>

namespace horizon::server {

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
