// worker_memory.hpp — a worker thread's engine workspace, inside memory_budget_mb.
//
// A worker keeps the buffers of its last run for the next
// (visibility::Workspace: the read window, the OHF, the terrain and the mask,
// at most Workspace::kMaxKeptBytes each), so that a run writes into memory
// already mapped. Those buffers stay resident between calls, so the budget
// holds them as it holds a call's working set: each worker's `kept`
// reservation, whose sum is the metric horizon_worker_kept_bytes. The workers
// together keep at most config worker_kept_mb (default a quarter of the
// budget); past it, or when the budget cannot take them, a call's buffers are
// freed when it ends.
//
// A call that runs the engine with the workspace holds a WorkspaceLease on
// its worker thread from before it reserves its working set until it is done
// with the engine's rasters:
// - The lease hands the worker's kept reservation to the call: the buffers
//   serve the call's run, so they are counted once.
// - reserve() splits the working set into the engine's buffers (the plan's
//   cost, which the kept buffers serve) and the rest (encodings, boxes): the
//   call holds the larger of its engine part and the kept buffers, plus the
//   rest. When the budget refuses and the kept buffers are larger than the
//   run needs, they are freed and it asks again, so keeping buffers never
//   refuses a call that would fit without them.
// - When the lease ends, what the workspace then keeps moves from the call's
//   engine part into the worker's `kept` (from the budget, where the call
//   reserved less), or is freed past worker_kept_mb or when the budget cannot
//   take it. The call keeps the rest until it ends (a viewshed streams its
//   encodings after its engine is done).
#pragma once

#include <cstdint>
#include <string>

#include "call_scope.hpp"
#include "horizon/common/error.hpp"
#include "horizon/visibility/plan.hpp"
#include "memory_budget.hpp"

namespace horizon::server {

struct WorkerMemory {
  visibility::Workspace workspace;
  Reservation kept;  // the budget's hold on `workspace`'s buffers
};

// The calling worker thread's. Its reservation is given back when the thread
// ends (the pool's threads end before the budget goes: daemon.cpp).
WorkerMemory& worker_memory();

class WorkspaceLease {
 public:
  explicit WorkspaceLease(CallScope& scope);
  ~WorkspaceLease();
  WorkspaceLease(const WorkspaceLease&) = delete;
  WorkspaceLease& operator=(const WorkspaceLease&) = delete;

  // The workspace to hand the engine's run.
  visibility::Workspace* workspace() { return &memory_.workspace; }
  // CallScope::reserve of the call's whole so far: `engine_bytes` its plan's
  // buffers (which the kept buffers serve), `other_bytes` the rest.
  Status reserve(std::uint64_t engine_bytes, std::uint64_t other_bytes, const std::string& what);

 private:
  CallScope& scope_;
  WorkerMemory& memory_;
  std::uint64_t kept_ = 0;    // the worker's kept bytes when the call took them over
  std::uint64_t engine_ = 0;  // the call's engine part: max(engine_bytes, kept_)
};

}  // namespace horizon::server
