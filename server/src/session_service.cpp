#include "session_service.hpp"

#include <chrono>
#include <deque>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "call_scope.hpp"
#include "grpc_status.hpp"
#include "handoff.hpp"
#include "horizon/clipmap/clipmap_updater.hpp"
#include "horizon/clipmap/session.hpp"
#include "request_log.hpp"
#include "session_translate.hpp"

namespace horizon::server {

using Clock = std::chrono::steady_clock;

namespace {

constexpr std::string_view kSessionIdKey = "horizon-session-id";

// The client's id when it sent a valid one, else a fresh random one.
std::string session_id(const grpc::CallbackServerContext* context) {
  const auto& metadata = context->client_metadata();
  const auto it = metadata.find(grpc::string_ref(kSessionIdKey.data(), kSessionIdKey.size()));
  if (it != metadata.end() && !it->second.empty() && it->second.size() <= 64) {
    std::string id(it->second.data(), it->second.size());
    if (std::all_of(id.begin(), id.end(), [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_'; }))
      return id;
  }
  thread_local std::mt19937_64 rng(std::random_device{}());
  static constexpr char kHex[] = "0123456789abcdef";
  std::string id(32, '0');
  for (char& c : id) c = kHex[rng() & 15];
  return id;
}

v1::SessionResponse rejection(const std::string& what, std::uint64_t seq, const Error& error) {
  v1::SessionResponse r;
  v1::Rejected* m = r.mutable_rejected();
  m->set_what(what);
  m->set_seq(seq);
  m->set_code(static_cast<int>(to_grpc_status(error).error_code()));
  m->set_message(error.message);
  m->set_field(error.field);
  return r;
}

Error prefixed(Error e, const std::string& prefix) {
  if (!e.field.empty() && e.field.rfind(prefix, 0) != 0) e.field = prefix + e.field;
  return e;
}

}  // namespace

// One session stream. The state below is guarded by mutex_; gRPC's read
// chain owns in_, the write chain out_, and the worker that holds busy_
// owns session_. pump() decides what runs next; it starts writes, work and
// Finish only after releasing the lock, because gRPC may run a reaction
// inline.
class SessionCall final : public grpc::ServerBidiReactor<v1::SessionRequest, v1::SessionResponse> {
 public:
  SessionCall(ServerEnv& env, SessionRegistry& registry, grpc::CallbackServerContext* context)
      : env_(env),
        registry_(registry),
        context_(context),
        scope_(env, context, "Session", DefaultDeadline::kNone),
        id_(session_id(context)),
        last_activity_(Clock::now()) {}

  void start() {
    if (auto refused = scope_.admit(in_)) return finish_now(*refused);  // nothing read yet: in_ is empty
    if (env_.config.sessions.max == 0 || !registry_.enter(this))
      return finish_now(to_grpc_status(make_error(
          ErrorCode::kResourceExhausted,
          "this daemon holds its limit of " + std::to_string(env_.config.sessions.max) +
              " sessions (sessions.max); retry later or on another replica",
          "sessions.max")));
    entered_ = true;
    context_->AddInitialMetadata(std::string(kSessionIdKey), id_);
    handoff_.to_grpc([&] {
      StartSendInitialMetadata();
      StartRead(&in_);
    });
  }

  void OnReadDone(bool ok) override {
    handoff_.from_grpc();
    std::unique_lock lock(mutex_);
    last_activity_ = Clock::now();
    if (!ok) {
      read_closed_ = true;
    } else if (auto refusal = proto::refused_parse(in_)) {
      // Not parsed: the memory budget could not take it, or its bytes do not parse (parse_guard.hpp).
      end_locked(refused_status(*refusal));
      in_.Clear();
    } else {
      switch (in_.kind_case()) {
        case v1::SessionRequest::kOpen:
          if (open_seen_) end_locked(bad("open: a session is opened once, by the first message", "open"));
          else ops_.push_back(std::move(in_));
          open_seen_ = true;
          break;
        case v1::SessionRequest::kPose:
          if (!open_seen_) {
            end_locked(bad("the first message must be open", "open"));
          } else {
            if (pose_) ++dropped_;  // latest pose wins
            pose_ = std::move(*in_.mutable_pose());
          }
          break;
        case v1::SessionRequest::kBoxes:
          if (!open_seen_) end_locked(bad("the first message must be open", "open"));
          else ops_.push_back(std::move(in_));
          break;
        default:
          end_locked(bad("a SessionRequest must hold open, pose or boxes", "kind"));
      }
      in_.Clear();
    }
    const bool more = ok && !ending_;
    pump(lock);
    if (more) {
      handoff_.to_grpc([&] { StartRead(&in_); });
    }
  }

  void OnWriteDone(bool ok) override {
    handoff_.from_grpc();
    std::unique_lock lock(mutex_);
    writing_ = false;
    if (!ok) end_locked(grpc::Status(grpc::StatusCode::CANCELLED, "the client went away mid-stream"));
    pump(lock);
  }

  void OnCancel() override {
    handoff_.from_grpc();
    const auto dropped = scope_.cancel();
    std::unique_lock lock(mutex_);
    end_locked(dropped ? *dropped
                       : scope_.status_of(make_error(ErrorCode::kCancelled, "the session was cancelled")));
    pump(lock);
    handoff_.publish();  // gRPC runs OnDone only after this returns, even when pump finished the call
  }

  void OnDone() override {
    handoff_.from_grpc();
    if (entered_) registry_.leave(this);
    delete this;
  }

  // From the registry: end with `status` once the work in hand is done.
  void end(const grpc::Status& status) {
    std::unique_lock lock(mutex_);
    end_locked(status);
    pump(lock);
  }
  void expire_if_idle(Clock::time_point now, std::chrono::milliseconds idle) {
    std::unique_lock lock(mutex_);
    if (busy_ || now - last_activity_ < idle) return;
    end_locked(grpc::Status(grpc::StatusCode::UNAVAILABLE, "session idle for " + std::to_string(idle.count()) +
                                                               " ms (sessions.idle_ms); open a new one"));
    pump(lock);
  }

 private:
  static grpc::Status bad(const std::string& message, const std::string& field) {
    return to_grpc_status(make_error(ErrorCode::kInvalidArgument, message, field));
  }
  void end_locked(const grpc::Status& status) {
    if (!ending_) ending_ = status;
  }

  // Decides what runs next (called with the lock held; releases it).
  void pump(std::unique_lock<std::mutex>& lock) {
    if (finished_) return;
    bool write = false, work = false;
    std::optional<grpc::Status> finish;
    if (!writing_ && !outbox_.empty()) {
      out_ = std::move(outbox_.front());
      outbox_.pop_front();
      writing_ = write = true;
    }
    // A pose is answered only once the last answer has gone out: under
    // backpressure newer poses replace it meanwhile.
    const bool pose_ready = pose_ && !writing_ && outbox_.empty();
    if (!busy_ && !ending_ && (!ops_.empty() || pose_ready)) busy_ = work = true;
    if (!busy_ && !writing_ && outbox_.empty()) {
      if (ending_) finish = *ending_;
      else if (read_closed_ && ops_.empty() && !pose_) finish = grpc::Status::OK;
    }
    if (finish) finished_ = true;
    lock.unlock();
    if (write) {
      handoff_.to_grpc([&] { StartWrite(&out_); });
    }
    if (work) env_.pool.post([this] { run(); });
    if (finish) {
      // The place is free before the client hears the status: a client that
      // opens again at once must find it.
      if (entered_) registry_.leave(this);
      entered_ = false;
      scope_.record().boxes = boxes_;
      scope_.finish(*finish);
      handoff_.to_grpc([&] { Finish(*finish); });
    }
  }

  void finish_now(const grpc::Status& status) {
    {
      std::lock_guard lock(mutex_);
      finished_ = true;
    }
    scope_.finish(status);
    handoff_.to_grpc([&] { Finish(status); });
  }

  // On a worker: the box deltas and open in order, then the newest pose.
  void run() {
    std::deque<v1::SessionRequest> ops;
    std::optional<v1::Pose> pose;
    std::uint64_t dropped = 0;
    {
      std::lock_guard lock(mutex_);
      ops.swap(ops_);
      if (pose_ && !writing_ && outbox_.empty()) {
        pose.swap(pose_);
        dropped = dropped_;
        dropped_ = 0;
      }
    }
    std::vector<v1::SessionResponse> replies;
    std::optional<grpc::Status> fatal;
    for (v1::SessionRequest& op : ops) {
      if (op.has_open()) {
        if (auto failed = open(op.open(), replies)) {
          fatal = std::move(*failed);
          break;
        }
      } else if (session_) {
        if (auto rejected = apply(op.boxes())) replies.push_back(std::move(*rejected));
      }
    }
    if (!fatal && pose && session_) answer(*pose, dropped, replies);
    std::unique_lock lock(mutex_);
    for (auto& r : replies) outbox_.push_back(std::move(r));
    if (fatal) end_locked(*fatal);
    busy_ = false;
    last_activity_ = Clock::now();  // idleness counts from the last answer too
    pump(lock);
  }

  // Opens the session and answers its first pose; the status to end with when it cannot.
  std::optional<grpc::Status> open(const v1::OpenSession& request, std::vector<v1::SessionResponse>& replies) {
    auto fail = [&](Error e) -> std::optional<grpc::Status> {
      return scope_.status_of(
          without_server_paths(prefixed(std::move(e), "open."), env_.config.data_root, env_.scratch));
    };
    auto dataset = scope_.dataset(request.dataset());
    if (!dataset.ok()) return fail(dataset.error());
    const auto& source = (*dataset)->source;
    auto options = to_session_options(request, env_.config.sessions, env_.config.engine_threads, source->width(),
                                      source->height(), env_.gpu);
    if (!options.ok()) return fail(options.error());
    if (!request.has_first_pose())
      return fail(make_error(ErrorCode::kInvalidArgument, "open.first_pose: required", "first_pose"));
    auto first = to_session_pose(request.first_pose(), "first_pose");
    if (!first.ok()) return fail(first.error());
    if (static_cast<std::uint64_t>(request.boxes_size()) > env_.config.sessions.max_boxes)
      return fail(make_error(ErrorCode::kResourceExhausted,
                             "open.boxes: " + std::to_string(request.boxes_size()) + " boxes, more than a session's " +
                                 std::to_string(env_.config.sessions.max_boxes) + " (sessions.max_boxes)",
                             "boxes"));
    auto boxes = to_session_boxes(request.boxes(), "boxes");
    if (!boxes.ok()) return fail(boxes.error());
    // The cost, bounded and reserved before anything is allocated.
    auto bytes = clipmap::ClipSession::bytes_for(*options, source->width(), source->height(), boxes->size());
    if (!bytes.ok()) return fail(bytes.error());
    const std::uint64_t reserve = *bytes + boxes->size() * MemoryBudget::kMessageBytesPerBox;
    if (!env_.memory.try_reserve(reserve, memory_))
      return fail(make_error(ErrorCode::kResourceExhausted,
                             "the session needs " + std::to_string(reserve >> 20) +
                                 " MiB (its clip-map, trace and boxes), more than the daemon's memory budget has "
                                 "free; ask for fewer or smaller levels, or retry later",
                             "clipmap"));
    auto pyramid = registry_.pyramid(source, clipmap::reduction_for(options->mode),
                                     clipmap::pyramid_options_for(options->shape));
    if (!pyramid.ok()) return fail(pyramid.error());
    auto session = clipmap::ClipSession::open(source, env_.cache, *pyramid, *options, *first, scope_.control());
    if (!session.ok()) return fail(session.error());
    session_ = std::move(*session);
    if (Status added = session_->add_boxes(*boxes); !added.ok()) {
      Error e = added.error();  // "add[3].id" -> "open.boxes[3].id"
      for (std::string* text : {&e.field, &e.message})
        if (text->rfind("add", 0) == 0) text->replace(0, 3, "boxes");
      return fail(e);
    }
    boxes_ = session_->box_count();
    reserved_boxes_ = boxes->size();
    v1::SessionResponse r;
    v1::SessionOpened* m = r.mutable_opened();
    m->set_session_id(id_);
    fill_shape(session_->options(), *m->mutable_clipmap());
    m->set_memory_bytes(memory_.bytes());
    m->set_width(static_cast<std::uint32_t>(source->width()));
    m->set_height(static_cast<std::uint32_t>(source->height()));
    replies.push_back(std::move(r));
    answer(request.first_pose(), 0, replies);
    return std::nullopt;
  }

  std::optional<v1::SessionResponse> apply(const v1::BoxDelta& delta) {
    auto reject = [&](Error e) {
      return rejection("boxes", 0, without_server_paths(std::move(e), env_.config.data_root, env_.scratch));
    };
    auto add = to_session_boxes(delta.add(), "boxes.add");
    if (!add.ok()) return reject(add.error());
    auto move = to_session_boxes(delta.move(), "boxes.move");
    if (!move.ok()) return reject(move.error());
    clipmap::BoxDelta d;
    d.add = std::move(*add);
    d.move = std::move(*move);
    d.remove.assign(delta.remove().begin(), delta.remove().end());
    // Growth is reserved first; a delta that does not fit changes nothing.
    const std::size_t after = session_->box_count() + d.add.size();
    if (after > reserved_boxes_ && after <= env_.config.sessions.max_boxes) {
      Reservation more;
      const std::uint64_t bytes =
          (after - reserved_boxes_) * (MemoryBudget::kMessageBytesPerBox + clipmap::ClipSession::kBytesPerBox);
      if (!env_.memory.try_reserve(bytes, more))
        return reject(make_error(ErrorCode::kResourceExhausted,
                                 "boxes.add: no room in the daemon's memory budget for " +
                                     std::to_string(d.add.size()) + " more boxes",
                                 "boxes.add"));
      box_memory_.push_back(std::move(more));
      reserved_boxes_ = after;
    }
    if (Status s = session_->apply(d); !s.ok()) {
      Error e = s.error();  // "add[3].id" -> "boxes.add[3].id"
      if (e.message.rfind(e.field, 0) == 0) e.message = "boxes." + e.message;
      e.field = "boxes." + e.field;
      return reject(e);
    }
    boxes_ = std::max<std::uint64_t>(boxes_, session_->box_count());
    return std::nullopt;
  }

  void answer(const v1::Pose& request, std::uint64_t dropped, std::vector<v1::SessionResponse>& replies) {
    auto pose = to_session_pose(request, "pose");
    if (!pose.ok()) return replies.push_back(rejection("pose", request.seq(), pose.error()));
    auto answered = session_->answer(*pose, scope_.control());
    if (!answered.ok()) {
      Error e = without_server_paths(answered.error(), env_.config.data_root, env_.scratch);
      if (e.code == ErrorCode::kCancelled || e.code == ErrorCode::kDeadlineExceeded) {
        std::lock_guard lock(mutex_);
        end_locked(scope_.status_of(e));
        return;
      }
      return replies.push_back(rejection("pose", request.seq(), e));
    }
    v1::SessionResponse r;
    fill_answer(*answered, dropped, *r.mutable_answer());
    replies.push_back(std::move(r));
  }

  ServerEnv& env_;
  SessionRegistry& registry_;
  grpc::CallbackServerContext* context_;
  Handoff handoff_;
  CallScope scope_;
  const std::string id_;
  bool entered_ = false;

  std::mutex mutex_;
  v1::SessionRequest in_;
  v1::SessionResponse out_;
  std::deque<v1::SessionRequest> ops_;
  std::optional<v1::Pose> pose_;
  std::uint64_t dropped_ = 0;
  std::deque<v1::SessionResponse> outbox_;
  bool open_seen_ = false, read_closed_ = false, writing_ = false, busy_ = false, finished_ = false;
  std::optional<grpc::Status> ending_;
  Clock::time_point last_activity_;

  // The worker's (busy_ serialises them).
  std::unique_ptr<clipmap::ClipSession> session_;
  Reservation memory_;
  std::vector<Reservation> box_memory_;
  std::size_t reserved_boxes_ = 0;
  std::uint64_t boxes_ = 0;
};

grpc::ServerBidiReactor<v1::SessionRequest, v1::SessionResponse>* SessionService::Session(
    grpc::CallbackServerContext* context) {
  auto* call = new SessionCall(env_, registry_, context);
  call->start();
  return call;
}

// --- SessionRegistry ---

SessionRegistry::SessionRegistry(ServerEnv& env) : env_(env), sweeper_([this] { sweep(); }) {}

SessionRegistry::~SessionRegistry() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  sweeper_.join();
}

bool SessionRegistry::enter(SessionCall* call) {
  std::lock_guard lock(mutex_);
  if (draining_ || calls_.size() >= env_.config.sessions.max) return false;
  calls_.insert(call);
  return true;
}

void SessionRegistry::leave(SessionCall* call) {
  std::lock_guard lock(mutex_);
  calls_.erase(call);
}

std::size_t SessionRegistry::open_count() const {
  std::lock_guard lock(mutex_);
  return calls_.size();
}

Result<std::shared_ptr<const terrain::SourcePyramid>> SessionRegistry::pyramid(
    const std::shared_ptr<const terrain::ElevationSource>& source, terrain::Reduction reduction,
    const terrain::SourcePyramidOptions& options) {
  std::lock_guard lock(mutex_);
  // Forget pyramids of datasets no longer served (a reload replaced them).
  const auto served = env_.datasets.snapshot();
  for (auto it = pyramids_.begin(); it != pyramids_.end();) {
    const std::uint64_t id = std::get<0>(it->first);
    const bool live = std::any_of(served->begin(), served->end(),
                                  [&](const auto& entry) { return entry.second->source->id() == id; });
    it = live ? std::next(it) : pyramids_.erase(it);
  }
  const PyramidKey key{source->id(), static_cast<int>(reduction), options.levels, options.block_cells};
  if (auto it = pyramids_.find(key); it != pyramids_.end()) return it->second;
  auto made = terrain::SourcePyramid::make(source, env_.cache, reduction, options);
  if (!made.ok()) return made.error();
  pyramids_[key] = *made;
  return *made;
}

void SessionRegistry::drain() {
  std::lock_guard lock(mutex_);
  draining_ = true;
  // A copy: a call may leave while it is ended. The others cannot go away
  // meanwhile: leaving takes this lock, and a call finishes after it leaves.
  const std::vector<SessionCall*> calls(calls_.begin(), calls_.end());
  for (SessionCall* call : calls)
    call->end(grpc::Status(grpc::StatusCode::UNAVAILABLE,
                           "draining: horizond is shutting down; re-open the session on another replica from its "
                           "last pose"));
}

void SessionRegistry::sweep() {
  const std::chrono::milliseconds idle(env_.config.sessions.idle_ms);
  const auto period = std::clamp(idle / 4, std::chrono::milliseconds(25), std::chrono::milliseconds(1000));
  std::unique_lock lock(mutex_);
  while (!stop_) {
    wake_.wait_for(lock, period, [this] { return stop_; });
    if (stop_) break;
    const auto now = Clock::now();
    const std::vector<SessionCall*> calls(calls_.begin(), calls_.end());  // as in drain()
    for (SessionCall* call : calls) call->expire_if_idle(now, idle);
  }
}

}  // namespace horizon::server
