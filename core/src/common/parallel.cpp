// Fork-join loop: the calling thread plus (threads - 1) helpers pull indices
// from a shared atomic counter, so uneven work items balance themselves.
#include "horizon/common/parallel.hpp"

#include <algorithm>
#include <atomic>
#include <thread>
#include <vector>

namespace horizon {

unsigned resolve_thread_count(unsigned requested) {
  if (requested > 0) return requested;
  return std::max(1u, std::thread::hardware_concurrency());
}

void parallel_for(std::size_t count, unsigned threads, const std::function<void(std::size_t)>& body) {
  if (count == 0) return;
  const std::size_t workers = std::min<std::size_t>(resolve_thread_count(threads), count);
  std::atomic<std::size_t> next{0};
  auto run = [&] {
    for (std::size_t i = next.fetch_add(1, std::memory_order_relaxed); i < count;
         i = next.fetch_add(1, std::memory_order_relaxed))
      body(i);
  };
  if (workers <= 1) {
    run();
    return;
  }
  std::vector<std::jthread> helpers;
  helpers.reserve(workers - 1);
  for (std::size_t t = 1; t < workers; ++t) helpers.emplace_back(run);
  run();
}  // jthreads join here

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
