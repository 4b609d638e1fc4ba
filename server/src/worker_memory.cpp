#include "worker_memory.hpp"

#include <algorithm>
#include <utility>

namespace horizon::server {

WorkerMemory& worker_memory() {
  thread_local WorkerMemory memory;
  return memory;
}

WorkspaceLease::WorkspaceLease(CallScope& scope) : scope_(scope), memory_(worker_memory()) {
  // The kept buffers' bytes become the call's: counted once, whoever holds them.
  kept_ = memory_.kept.bytes();
  engine_ = kept_;
  scope_.env().kept_bytes.fetch_sub(kept_);
  scope_.hold(std::move(memory_.kept));
}

Status WorkspaceLease::reserve(std::uint64_t engine_bytes, std::uint64_t other_bytes, const std::string& what) {
  Status s = scope_.reserve(std::max(engine_bytes, kept_) + other_bytes, what);
  if (s.ok()) {
    engine_ = std::max(engine_bytes, kept_);
    return s;
  }
  if (kept_ == 0 || engine_bytes >= kept_) return s;
  // Buffers larger than this run needs: freed, and asked again without them.
  scope_.hand_over(kept_).release();
  memory_.workspace = visibility::Workspace();
  kept_ = engine_ = 0;
  s = scope_.reserve(engine_bytes + other_bytes, what);
  if (s.ok()) engine_ = engine_bytes;
  return s;
}

WorkspaceLease::~WorkspaceLease() {
  ServerEnv& env = scope_.env();
  memory_.workspace.trim();
  const std::uint64_t want = memory_.workspace.kept_bytes();
  // Claimed at once, so that two workers ending together cannot both pass the cap.
  const std::uint64_t total = env.kept_bytes.fetch_add(want) + want;
  // The buffers were the call's engine memory, as far as it reserved that;
  // past it (a plan that undercounts) the budget is asked for the rest.
  Reservation kept = scope_.hand_over(std::min(want, engine_)), lacking;
  if (total <= env.config.worker_kept_bytes &&
      (kept.bytes() == want || env.memory.try_reserve(want - kept.bytes(), lacking))) {
    kept.absorb(std::move(lacking));
    memory_.kept = std::move(kept);
  } else {
    env.kept_bytes.fetch_sub(want);
    kept.release();  // the call's share goes with the buffers it paid for
    memory_.workspace = visibility::Workspace();
  }
  env.metrics.set_worker_kept(env.kept_bytes.load());
  env.metrics.set_memory_reserved(env.memory.reserved());
}

}  // namespace horizon::server
