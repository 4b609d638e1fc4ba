// Fork-join loop on a process-wide pool. A call is a Job on the caller's
// stack: the caller posts up to (threads - 1) helper slots to the pool, then
// pulls indices from the job's atomic counter itself, so uneven work items
// balance themselves and a call never waits for a free worker to make
// progress. When its indices run out the caller withdraws the slots no worker
// has taken and waits only for the helpers still inside body(). A waiting
// caller therefore only waits on threads that are running its own items, which
// is why a nested parallel_for (a body that calls parallel_for, on a worker or
// on the caller) completes: the waits follow the nesting and cannot form a
// cycle.
#include "horizon/common/parallel.hpp"

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <deque>
#include <mutex>
#include <thread>
#include <vector>

namespace horizon {
namespace {

struct Job {
  std::size_t count = 0;
  const std::function<void(std::size_t)>* body = nullptr;
  std::atomic<std::size_t> next{0};
  std::size_t slots = 0;             // helper slots posted and not yet taken (pool mutex)
  std::size_t running = 0;           // helpers that took a slot and have not finished (pool mutex)
  std::condition_variable finished;  // running reached 0 (pool mutex)
};

// Pulls indices until they run out. noexcept: a throwing body terminates the
// process (on whichever thread it ran) instead of unwinding past a Job that
// other threads still use.
void drain(Job& job) noexcept {
  for (std::size_t i = job.next.fetch_add(1, std::memory_order_relaxed); i < job.count;
       i = job.next.fetch_add(1, std::memory_order_relaxed))
    (*job.body)(i);
}

// hardware_concurrency - 1 workers, started on first use; with the caller a
// single call reaches every hardware thread. The pool is never destroyed:
// its idle workers block on a condition variable until the process ends, so
// no static destructor can join a worker that is still inside someone's body
// or leave a late parallel_for without a pool.
class Pool {
 public:
  static Pool& instance() {
    static Pool* const pool = new Pool(resolve_thread_count(0) - 1);
    return *pool;
  }

  // Runs job on the caller and up to `helpers` workers; returns when done.
  void run(Job& job, std::size_t helpers) {
    helpers = std::min(helpers, workers_.size());
    if (helpers > 0) {
      std::lock_guard lock(mutex_);
      job.slots = helpers;
      pending_.push_back(&job);
    }
    for (std::size_t i = 0; i < helpers; ++i) wake_.notify_one();
    drain(job);
    if (helpers == 0) return;
    std::unique_lock lock(mutex_);
    if (job.slots > 0) {
      job.slots = 0;
      pending_.erase(std::find(pending_.begin(), pending_.end(), &job));
    }
    job.finished.wait(lock, [&] { return job.running == 0; });
  }

 private:
  explicit Pool(std::size_t workers) {
    workers_.reserve(workers);
    for (std::size_t i = 0; i < workers; ++i) workers_.emplace_back([this] { work(); });
  }

  [[noreturn]] void work() {
    std::unique_lock lock(mutex_);
    for (;;) {
      wake_.wait(lock, [&] { return !pending_.empty(); });
      Job& job = *pending_.front();
      if (--job.slots == 0) pending_.pop_front();
      ++job.running;
      lock.unlock();
      drain(job);
      lock.lock();
      // Notified under the mutex: the caller cannot see running == 0, return
      // and destroy the Job until this thread lets go of the mutex.
      if (--job.running == 0) job.finished.notify_one();
    }
  }

  std::mutex mutex_;
  std::condition_variable wake_;  // pending_ became non-empty
  std::deque<Job*> pending_;      // jobs with helper slots left, oldest first
  std::vector<std::thread> workers_;
};

}  // namespace

unsigned resolve_thread_count(unsigned requested) {
  if (requested > 0) return requested;
  return std::max(1u, std::thread::hardware_concurrency());
}

void parallel_for(std::size_t count, unsigned threads, const std::function<void(std::size_t)>& body) {
  if (count == 0) return;
  Job job;
  job.count = count;
  job.body = &body;
  const std::size_t helpers = std::min<std::size_t>(resolve_thread_count(threads), count) - 1;
  if (helpers == 0) {
    drain(job);
    return;
  }
  Pool::instance().run(job, helpers);
}

Status parallel_for(std::size_t count, unsigned threads, const RunControl* control,
                    const std::function<void(std::size_t)>& body, double from, double to) {
  std::atomic<bool> stop{false};
  std::atomic<std::size_t> done{0};
  parallel_for(count, threads, [&](std::size_t i) {
    if (stop.load(std::memory_order_relaxed)) return;
    if (!check_control(control).ok()) {
      stop = true;
      return;
    }
    body(i);
    report_progress(control, from + (to - from) * double(++done) / double(count));
  });
  return check_control(control);
}

}  // namespace horizon
