// horizon/common/control.hpp — cancellation, deadlines and progress for long
// computations.
//
// Every algorithm that can run longer than a few milliseconds takes a
// `const RunControl*` (may be null). It polls `should_stop()` between units of
// work (a ray batch, a row of targets): the cost is one relaxed atomic load and,
// when a deadline is set, one steady_clock read per poll. On stop the algorithm
// returns ErrorCode::kCancelled or kDeadlineExceeded and its partial output is
// discarded by the caller.
#pragma once

#include <atomic>
#include <chrono>
#include <functional>
#include <optional>

#include "horizon/common/error.hpp"

namespace horizon {

class CancelToken {
 public:
  void cancel() { cancelled_.store(true, std::memory_order_relaxed); }
  bool cancelled() const { return cancelled_.load(std::memory_order_relaxed); }

 private:
  std::atomic<bool> cancelled_{false};
};

struct RunControl {
  const CancelToken* cancel = nullptr;                                // may be null
  std::optional<std::chrono::steady_clock::time_point> deadline;      // absent: none
  // Called with the fraction done in [0, 1], from any worker thread, at most
  // every few milliseconds. Must be thread-safe and cheap. May be empty.
  std::function<void(double)> progress;

  // Ok, or the kCancelled / kDeadlineExceeded error to return.
  Status check() const;
};

// Null-safe helpers used inside the engine.
inline Status check_control(const RunControl* control) {
  return control ? control->check() : Status::Ok();
}
inline void report_progress(const RunControl* control, double fraction) {
  if (control && control->progress) control->progress(fraction);
}

}  // namespace horizon
