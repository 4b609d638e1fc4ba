#include "deadline_watch.hpp"

namespace horizon::server {

void WatchedCall::release() {
  std::lock_guard lock(mutex_);
  context_ = nullptr;
}

void WatchedCall::cancel() {
  std::lock_guard lock(mutex_);
  if (!context_) return;
  context_->TryCancel();
  context_ = nullptr;
}

DeadlineWatch::DeadlineWatch() : thread_([this] { run(); }) {}

DeadlineWatch::~DeadlineWatch() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_one();
  thread_.join();
}

std::shared_ptr<WatchedCall> DeadlineWatch::watch(grpc::CallbackServerContext* context,
                                                  std::chrono::steady_clock::time_point deadline) {
  auto call = std::make_shared<WatchedCall>(context);
  bool nearest = false;
  {
    std::lock_guard lock(mutex_);
    nearest = entries_.empty() || deadline < entries_.top().deadline;
    entries_.push({deadline, call});
  }
  if (nearest) wake_.notify_one();
  return call;
}

void DeadlineWatch::run() {
  std::unique_lock lock(mutex_);
  while (!stopping_) {
    if (entries_.empty()) {
      wake_.wait(lock);
      continue;
    }
    const Entry next = entries_.top();
    if (std::chrono::steady_clock::now() < next.deadline) {
      wake_.wait_until(lock, next.deadline);  // or a nearer deadline, or stop
      continue;
    }
    entries_.pop();
    // A call that ended has let its handle go: nothing to do.
    if (auto call = next.call.lock()) {
      lock.unlock();
      call->cancel();
      lock.lock();
    }
  }
}

}  // namespace horizon::server
