// signals.hpp — the daemon's signals, handled with Boost.Asio on a thread of
// their own (no work in a signal handler):
//   SIGTERM, SIGINT  -> on_stop (once; later ones are ignored while draining)
//   SIGHUP           -> on_reload
// The callbacks run on the signal thread and should only hand work over.
#pragma once

#include <functional>
#include <memory>

namespace horizon::server {

class SignalWatcher {
 public:
  SignalWatcher(std::function<void()> on_stop, std::function<void()> on_reload);
  ~SignalWatcher();  // stops watching; the default dispositions come back
  SignalWatcher(const SignalWatcher&) = delete;
  SignalWatcher& operator=(const SignalWatcher&) = delete;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace horizon::server
