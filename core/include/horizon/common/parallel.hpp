// horizon/common/parallel.hpp — a minimal fork-join loop for the engine.
//
// The engine is called from the CLI (one request, use every core) and from the
// daemon (many requests on an Asio pool, each using few threads). Callers pass
// the thread count they want; 0 means std::thread::hardware_concurrency().
#pragma once

#include <cstddef>
#include <functional>

#include "horizon/common/control.hpp"

namespace horizon {

// Number of worker threads for `requested` (0 = all hardware threads, >= 1).
unsigned resolve_thread_count(unsigned requested);

// Runs body(i) for every i in [0, count), distributing indices dynamically over
// `threads` threads (the calling thread is one of them). Returns when all are
// done. body must not throw. Work items should be coarse (>= ~50 us each).
void parallel_for(std::size_t count, unsigned threads, const std::function<void(std::size_t)>& body);

// parallel_for under a RunControl (may be null): before each item it polls the
// control, and once that says stop (cancelled, deadline passed) every item not
// yet begun is skipped. After each item, progress moves linearly from `from`
// to `to`. Returns Ok, or the control's kCancelled / kDeadlineExceeded; on an
// error the caller discards its partial output.
Status parallel_for(std::size_t count, unsigned threads, const RunControl* control,
                    const std::function<void(std::size_t)>& body, double from = 0.0, double to = 1.0);

}  // namespace horizon
