#include "signals.hpp"

#include <csignal>
#include <thread>

#include <boost/asio/io_context.hpp>
#include <boost/asio/signal_set.hpp>

namespace horizon::server {

struct SignalWatcher::Impl {
  boost::asio::io_context io;
  boost::asio::signal_set signals{io, SIGTERM, SIGINT, SIGHUP};
  std::function<void()> on_stop, on_reload;
  bool stopping = false;
  std::thread thread;

  void arm() {
    signals.async_wait([this](const boost::system::error_code& ec, int signal) {
      if (ec) return;  // cancelled: the watcher is going away
      if (signal == SIGHUP) {
        on_reload();
      } else if (!stopping) {
        stopping = true;
        on_stop();
      }
      arm();
    });
  }
};

SignalWatcher::SignalWatcher(std::function<void()> on_stop, std::function<void()> on_reload)
    : impl_(std::make_unique<Impl>()) {
  impl_->on_stop = std::move(on_stop);
  impl_->on_reload = std::move(on_reload);
  impl_->arm();
  impl_->thread = std::thread([this] { impl_->io.run(); });
}

SignalWatcher::~SignalWatcher() {
  impl_->io.post([this] { impl_->signals.cancel(); impl_->io.stop(); });
  impl_->thread.join();
}

}  // namespace horizon::server
