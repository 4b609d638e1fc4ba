// horizon/common/parallel.hpp — a minimal fork-join loop for the engine.
//
// The engine is called from the CLI (one request, use every core) and from the
// daemon (many requests on an Asio pool, each using few threads). Callers pass
// the thread count they want; 0 means std::thread::hardware_concurrency().
//
// Every call runs on one process-wide executor: hardware_concurrency - 1
// worker threads, started on the first parallel_for that wants more than one
// thread and kept for the life of the process, so a call costs a few wake-ups,
// not thread starts. The calling thread always works on its own call, so a
// call never waits for a free worker to make progress; when the workers are
// busy with other calls it simply gets fewer of them. A body may itself call
// parallel_for (nested calls complete; they share the same workers).
#pragma once

#include <cstddef>
#include <functional>

#include "horizon/common/control.hpp"

namespace horizon {

// Number of worker threads for `requested` (0 = all hardware threads, >= 1).
unsigned resolve_thread_count(unsigned requested);

// Runs body(i) for every i in [0, count), distributing indices dynamically over
// at most `threads` threads (the calling thread is one of them, and the others
// are executor workers; never more than hardware_concurrency in all, and fewer
// while other calls hold workers). Returns when all are done. body must not
// throw: an exception out of body terminates the process. Work items should be
// coarse (>= ~10 us each; waking a worker costs a few microseconds).
void parallel_for(std::size_t count, unsigned threads, const std::function<void(std::size_t)>& body);

// parallel_for under a RunControl (may be null): before each item it polls the
// control, and once that says stop (cancelled, deadline passed) every item not
// yet begun is skipped. After each item, progress moves linearly from `from`
// to `to`. Returns Ok, or the control's kCancelled / kDeadlineExceeded; on an
// error the caller discards its partial output.
Status parallel_for(std::size_t count, unsigned threads, const RunControl* control,
                    const std::function<void(std::size_t)>& body, double from = 0.0, double to = 1.0);

}  // namespace horizon
