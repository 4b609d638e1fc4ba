#include "call_scope.hpp"

#include <algorithm>

#include "auth.hpp"
#include "grpc_status.hpp"

namespace horizon::server {

CallScope::CallScope(ServerEnv& env, grpc::CallbackServerContext* context, std::string_view method,
                     DefaultDeadline default_deadline)
    : env_(env), context_(context), started_(std::chrono::steady_clock::now()) {
  record_.method = method;
  env_.live_calls.fetch_add(1);
  env_.metrics.request_started();
  control_.cancel = &token_;
  // The client's deadline, as a steady-clock time; none (gRPC's "infinite") -> the default.
  const auto system_now = std::chrono::system_clock::now();
  const auto deadline = context->deadline();
  if (deadline < system_now + std::chrono::hours(24 * 365))
    control_.deadline =
        started_ + std::chrono::duration_cast<std::chrono::steady_clock::duration>(deadline - system_now);
  else if (default_deadline == DefaultDeadline::kApply) {
    control_.deadline = started_ + env.config.default_deadline;
    // Past it, the call ends even where the engine no longer polls (a stream its client does not drain).
    if (env.deadlines) watched_ = env.deadlines->watch(context, *control_.deadline);
  }
}

CallScope::~CallScope() {
  if (watched_) watched_->release();  // gRPC is done with the call: its context goes next
  if (!finished_) finish(grpc::Status(grpc::StatusCode::INTERNAL, "call ended without a status"));
  if (messages_.bytes() > 0) {
    messages_.release();
    env_.metrics.set_memory_reserved(env_.memory.reserved());
  }
  if (env_.live_calls.fetch_sub(1) == 1 && env_.trimmer) env_.trimmer->idle();
}

std::optional<grpc::Status> CallScope::admit(const google::protobuf::Message& request, std::uint64_t message_bytes,
                                             std::uint64_t work_bytes, std::string_view work_what) {
  auto refused = admission(request, message_bytes, work_bytes, work_what);
  if (refused) ticket_.take();  // never queued: a cancel has nothing to drop
  return refused;
}

std::optional<grpc::Status> CallScope::cancel() {
  token_.cancel();
  if (!ticket_.drop()) return std::nullopt;  // running, finished or never queued
  return status_of(make_error(ErrorCode::kCancelled, "cancelled before it started"));
}

std::optional<grpc::Status> CallScope::admission(const google::protobuf::Message& request, std::uint64_t message_bytes,
                                                 std::uint64_t work_bytes, std::string_view work_what) {
  if (!env_.datasets.loaded())
    return grpc::Status(grpc::StatusCode::UNAVAILABLE, "horizond is loading its datasets; retry shortly");
  // With TLS, a call that arrived on the plaintext health port is refused:
  // that port is for probes, and a token must not cross the wire in clear.
  if (env_.config.tls) {
    const auto auth = context_->auth_context();
    const auto type = auth ? auth->FindPropertyValues("transport_security_type") : std::vector<grpc::string_ref>();
    if (type.empty() || type.front() != "ssl")
      return grpc::Status(grpc::StatusCode::UNAUTHENTICATED,
                          "this port serves health checks only; call the TLS port (config listen)");
  }
  if (!env_.config.auth_tokens.empty()) {
    const auto& metadata = context_->client_metadata();
    const auto it = metadata.find("authorization");
    const std::string_view value =
        it == metadata.end() ? std::string_view() : std::string_view(it->second.data(), it->second.size());
    if (auto refused = check_bearer(value, env_.config.auth_tokens)) return refused;
  }
  if (env_.draining.load())
    return grpc::Status(grpc::StatusCode::UNAVAILABLE, "horizond is shutting down; retry on another replica");
  // A call that arrives with its deadline gone takes no slot.
  if (control_.deadline && *control_.deadline <= std::chrono::steady_clock::now())
    return grpc::Status(grpc::StatusCode::DEADLINE_EXCEEDED, "the call's deadline passed before it was admitted");
  const std::uint32_t before = env_.pending.fetch_add(1);
  admitted_ = true;
  if (before >= env_.config.limits.max_pending)
    return to_grpc_status(make_error(ErrorCode::kResourceExhausted,
                                     "horizond has " + std::to_string(before) +
                                         " requests in flight (limits.max_pending = " +
                                         std::to_string(env_.config.limits.max_pending) + "); retry later",
                                     "limits.max_pending"));
  // A request the budget could not take while it was parsed, or whose bytes
  // did not parse, arrives empty (parse_guard.hpp).
  if (auto refusal = proto::refused_parse(request)) return refused_status(*refusal);
  // What has arrived is already in memory; a call that cannot also hold its
  // answer, and what its request alone will make, is refused now rather than
  // queued, and frees its request at once.
  const std::uint64_t bytes = message_bytes + work_bytes;
  if (bytes > 0 && !env_.memory.try_reserve_new(bytes, messages_)) {
    std::string parts = "its messages " + mib_text(message_bytes);
    if (work_bytes > 0) parts += ", " + std::string(work_what) + " " + mib_text(work_bytes);
    return to_grpc_status(make_error(ErrorCode::kResourceExhausted,
                                     "this request needs about " + mib_text(bytes) + " while it waits and runs (" +
                                         parts + "), more than memory_budget_mb leaves free now (" +
                                         std::to_string(env_.memory.reserved() >> 20) +
                                         " MiB held); retry later or split the request",
                                     "memory_budget_mb"));
  }
  if (work_bytes > 0) memory_.absorb(messages_.split(work_bytes));
  if (bytes > 0) env_.metrics.set_memory_reserved(env_.memory.reserved());
  datasets_ = env_.datasets.snapshot();
  return std::nullopt;
}

Result<std::shared_ptr<const Dataset>> CallScope::dataset(const std::string& name) {
  record_.dataset = name.substr(0, kMaxDatasetName);
  if (!datasets_) datasets_ = env_.datasets.snapshot();
  return find_by_name(*datasets_, name, "dataset");
}

std::string planned_work(const std::string& what, const visibility::Cost& cost, double ray_spacing) {
  if (cost.sweep_bytes * 2 <= cost.bytes) return what;
  return what + " (" + std::to_string(cost.sweep_rays) +
         " sweep rays at options.ray_spacing = " + number_text(ray_spacing) + " cells)";
}

Status CallScope::reserve(std::uint64_t bytes, const std::string& what) {
  if (bytes <= memory_.bytes()) return Status::Ok();
  Reservation more;
  auto until = std::chrono::steady_clock::now() + kParseWait;
  if (control_.deadline) until = std::min(until, *control_.deadline);
  if (!env_.memory.reserve_after_parses(bytes - memory_.bytes(), more, until))
    return make_error(ErrorCode::kResourceExhausted,
                      what + " needs about " + mib_text(bytes) +
                          " of working memory, more than memory_budget_mb leaves free now (" +
                          std::to_string(env_.memory.reserved() >> 20) + " MiB held); retry later or ask less",
                      "memory_budget_mb");
  memory_.absorb(std::move(more));
  env_.metrics.set_memory_reserved(env_.memory.reserved());
  return Status::Ok();
}

grpc::Status refused_status(const proto::ParseRefusal& refusal) {
  return to_grpc_status(refusal.malformed
                            ? make_error(ErrorCode::kInvalidArgument, refusal.message, "request")
                            : make_error(ErrorCode::kResourceExhausted, refusal.message, "memory_budget_mb"));
}

bool cancel_reads_as_deadline(std::chrono::steady_clock::time_point now,
                              std::optional<std::chrono::steady_clock::time_point> deadline) {
  return deadline && now + kDeadlineRace >= *deadline;
}

grpc::Status CallScope::status_of(const Error& error) const {
  if (error.code == ErrorCode::kCancelled &&
      cancel_reads_as_deadline(std::chrono::steady_clock::now(), control_.deadline))
    return grpc::Status(grpc::StatusCode::DEADLINE_EXCEEDED, "the request's deadline passed before it finished");
  return to_grpc_status(without_server_paths(error, env_.config.data_root, env_.scratch));
}

Error without_server_paths(Error error, const std::filesystem::path& data_root, const std::filesystem::path& scratch) {
  const auto strip = [](std::string& text, const std::string& prefix, const std::string& with) {
    if (prefix.empty() || prefix == "/") return;
    for (auto at = text.find(prefix); at != std::string::npos; at = text.find(prefix, at + with.size()))
      text.replace(at, prefix.size(), with);
  };
  // parse_config made data_root canonical, and every dataset path is resolved inside it.
  std::string root = data_root.string();
  while (root.size() > 1 && root.back() == '/') root.pop_back();
  if (root.size() > 1) {                   // "" or "/": nothing to hide
    strip(error.message, root + "/", "");  // a file inside: relative to data_root
    strip(error.message, root, ".");       // the root itself
  }
  strip(error.message, scratch.string(), "<scratch>");
  // A path is no field of the request: the dataset named one.
  if (error.field.find('/') != std::string::npos) error.field = "dataset";
  return error;
}

void CallScope::ohf_computed(const visibility::WorkStats& stats) {
  record_.cells = stats.cells_evaluated;
  record_.backend = stats.backend;
  record_.gpu_fallback = stats.gpu_fallback;  // a fallback puts the request's line at level warn
  env_.metrics.ohf_computed(stats.backend, !stats.gpu_fallback.empty());
}

void CallScope::finish(const grpc::Status& status) {
  if (finished_) return;
  finished_ = true;
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count();
  record_.duration_ms = seconds * 1000.0;
  record_.status = grpc_code_name(status.error_code());
  record_.message = status.error_message();
  record_.server_fault = is_server_fault(status.error_code());
  // The books first, the log line last: whoever reads the line finds the
  // call counted, out of flight and its memory back.
  env_.metrics.request_finished(record_.method, record_.status, seconds, record_.cells, record_.boxes);
  if (admitted_) env_.pending.fetch_sub(1);
  memory_.release();
  env_.metrics.set_memory_reserved(env_.memory.reserved());
  env_.metrics.set_block_cache(env_.cache.stats());
  log_request(record_);
}

}  // namespace horizon::server
