// call_scope.hpp — one RPC's bookkeeping, from admission to its log line.
//
// Every handler owns a CallScope. It admits the call (UNAUTHENTICATED
// without an accepted bearer token when auth_tokens_file is set, UNAVAILABLE
// while the datasets load or the daemon drains, DEADLINE_EXCEEDED when the
// deadline has already gone, RESOURCE_EXHAUSTED past limits.max_pending or
// when its messages do not fit in the memory budget), looks the
// dataset up (NOT_FOUND), gives the engine a RunControl (the call's cancel
// token, set by the reactor's OnCancel, and its deadline: the client's, or
// the configured default), reserves working memory, and on finish() writes
// the request's log line and metrics exactly once.
#pragma once

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include <google/protobuf/message.h>
#include <grpcpp/server_context.h>
#include <grpcpp/support/status.h>

#include "deadline_watch.hpp"
#include "horizon/common/control.hpp"
#include "horizon/common/error.hpp"
#include "horizon/visibility/plan.hpp"
#include "horizon/visibility/work_stats.hpp"
#include "request_log.hpp"
#include "server_env.hpp"

namespace horizon::server {

// How long before the daemon's copy of a deadline a client's cancel still
// reads as that deadline. A client's own timer cancels the call at its
// deadline; the daemon's copy is the same instant shifted by the header's
// trip, and the cancel takes that same trip, so it lands at the daemon's
// deadline give or take scheduling. In one CI run the daemon saw such a
// cancel 19.55 ms into a call with a 20 ms deadline, before its own copy passed.
inline constexpr std::chrono::milliseconds kDeadlineRace{50};

// The longest a started call waits in reserve() for parses to end. A parse
// of the largest request the limits take lasts milliseconds, and none starts
// while a call waits; this is slack for a loaded machine.
inline constexpr std::chrono::milliseconds kParseWait{1000};

// True when a cancellation seen at `now` is the deadline passing (or about to).
bool cancel_reads_as_deadline(std::chrono::steady_clock::time_point now,
                              std::optional<std::chrono::steady_clock::time_point> deadline);

// `error` as a client may see it: paths inside data_root made relative to it
// (and the root itself "."), the scratch directory "<scratch>", and a field
// that is a path (a source's error names its file) replaced by "dataset".
// Clients learn which file of a dataset failed, not where the server keeps it.
Error without_server_paths(Error error, const std::filesystem::path& data_root, const std::filesystem::path& scratch);

// The status of a request gRPC handed over unparsed (parse_guard.hpp):
// RESOURCE_EXHAUSTED naming memory_budget_mb, or INVALID_ARGUMENT naming
// the request when its bytes do not parse.
grpc::Status refused_status(const proto::ParseRefusal& refusal);

// Names a planned request for reserve()'s refusal: `what`, and the sweep's
// rays and the ray_spacing behind them when those are most of the cost.
std::string planned_work(const std::string& what, const visibility::Cost& cost, double ray_spacing);

// `name` in `set` (the datasets', or the meshes'), `kind` naming both the
// field and the thing ("dataset", "mesh"): kInvalidArgument for an empty
// name or one longer than any that can be configured (not echoed),
// kNotFound for an unknown one.
template <class Set>
Result<typename Set::mapped_type> find_by_name(const Set& set, const std::string& name, const std::string& kind) {
  if (name.empty()) return make_error(ErrorCode::kInvalidArgument, kind + ": a " + kind + " name is required", kind);
  if (name.size() > kMaxDatasetName)
    return make_error(ErrorCode::kInvalidArgument,
                      kind + ": a " + kind + " name is at most " + std::to_string(kMaxDatasetName) + " bytes, got " +
                          std::to_string(name.size()),
                      kind);
  const auto it = set.find(name);
  if (it == set.end())
    return make_error(ErrorCode::kNotFound, kind + " '" + name + "' is not held by this daemon", kind);
  return it->second;
}

// Whether a call without a deadline of its own gets default_deadline_ms
// (requests) or none (sessions, which end by idleness or the client).
enum class DefaultDeadline { kApply, kNone };

class CallScope {
 public:
  CallScope(ServerEnv& env, grpc::CallbackServerContext* context, std::string_view method,
            DefaultDeadline default_deadline = DefaultDeadline::kApply);
  ~CallScope();
  CallScope(const CallScope&) = delete;
  CallScope& operator=(const CallScope&) = delete;

  // Ok, or the status to finish with at once. `request`: as gRPC handed it
  // over (a request whose parse the memory budget refused, parse_guard.hpp,
  // is refused here). `message_bytes`: what the call's messages hold while
  // it waits and runs (the request as received, the answer it will build),
  // reserved here, before the call queues, and held until it ends.
  // `work_bytes`: the part of the call's working memory its request alone
  // fixes (CullBoxes: its boxes' conversion; LineOfSight: its lines' plans),
  // `work_what` naming it ("converting these 9 boxes"); reserved here too,
  // as the first step of reserve()'s. A call admitted has it, so that calls
  // queued behind a running one cannot take what it needs to start.
  std::optional<grpc::Status> admit(const google::protobuf::Message& request, std::uint64_t message_bytes = 0,
                                    std::uint64_t work_bytes = 0, std::string_view work_what = {});
  // The call's place in the worker queue, for the task that runs it
  // (worker_pool.hpp): the task runs the call only if ticket().take().
  QueueTicket ticket() const { return ticket_; }
  // The dataset by name: kInvalidArgument for an empty name, kNotFound for an unknown one.
  Result<std::shared_ptr<const Dataset>> dataset(const std::string& name);
  // Holds `bytes` of working memory for the rest of the call
  // (kResourceExhausted when it does not fit). A call may reserve in steps,
  // each the whole it needs so far: a part at admission (admit's
  // work_bytes), the whole once planned; each step takes only what the call
  // does not hold yet. Called from the call's worker: where only requests
  // being parsed hold what it lacks, it waits for them to end, up to
  // kParseWait and never past the call's deadline
  // (MemoryBudget::reserve_after_parses).
  Status reserve(std::uint64_t bytes, const std::string& what);
  // Memory that serves the call, held with what reserve() holds (a worker's
  // kept buffers, worker_memory.hpp): reserve() takes only what it lacks beyond it.
  void hold(Reservation&& held) { memory_.absorb(std::move(held)); }
  // Up to `bytes` of what the call holds, moved out for someone who keeps
  // memory the call made past its end (the worker, its buffers).
  Reservation hand_over(std::uint64_t bytes) { return memory_.split(bytes); }

  const RunControl* control() const { return &control_; }
  // What the engine's progress reports call, from any worker thread (before the work is posted).
  void set_progress(std::function<void(double)> progress) { control_.progress = std::move(progress); }
  // OnCancel: stops the engine (the cancel token it polls) and, when the call
  // was still waiting for a worker, gives the status to finish it with now.
  std::optional<grpc::Status> cancel();
  RequestRecord& record() { return record_; }
  ServerEnv& env() { return env_; }
  // Records an OHF the call computed: its cells, where it ran and any GPU
  // fallback on the request's log line, and in the backend metrics.
  void ohf_computed(const visibility::WorkStats& stats);

  // An engine error as the status to send. A cancellation at the deadline
  // (within kDeadlineRace of it) reads DEADLINE_EXCEEDED: gRPC cancels a call
  // whose deadline passed, and so does the client's own timer.
  grpc::Status status_of(const Error& error) const;
  // Logs and counts the call. Once; later calls do nothing.
  void finish(const grpc::Status& status);

 private:
  std::optional<grpc::Status> admission(const google::protobuf::Message& request, std::uint64_t message_bytes,
                                        std::uint64_t work_bytes, std::string_view work_what);

  ServerEnv& env_;
  grpc::CallbackServerContext* context_;
  const std::chrono::steady_clock::time_point started_;
  CancelToken token_;
  RunControl control_;
  RequestRecord record_;
  std::shared_ptr<WatchedCall> watched_;  // under env.deadlines when the default deadline applies
  Reservation messages_;                  // admit()'s, for the messages
  Reservation memory_;                    // reserve()'s, from admit()'s work_bytes on
  QueueTicket ticket_;
  bool admitted_ = false;
  bool finished_ = false;
  std::shared_ptr<const DatasetSet> datasets_;  // held for the whole call (a reload never pulls a dataset away)
};

}  // namespace horizon::server
