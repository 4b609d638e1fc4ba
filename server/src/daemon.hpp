// daemon.hpp — horizond's life cycle.
//
//   start()          gRPC server listening (health NOT_SERVING, reflection on),
//                    metrics endpoint up; logs {"event":"listening",...} with the ports
//   load_datasets()  reads the configured DEMs, prepares the meshes -> health SERVING
//   reload(config)   SIGHUP: a new dataset set (and mesh set) swapped in; calls in flight keep theirs;
//                    other changed keys logged ("reload_needs_restart") and left as they were
//   shutdown()       SIGTERM/SIGINT: health NOT_SERVING, no new calls, calls in
//                    flight get config.shutdown_grace to finish (then they are
//                    cancelled, which the engine notices), workers joined
// (gRPC's server builder stays inside daemon.cpp.)
#pragma once

#include <memory>

#include "config.hpp"
#include "horizon/common/control.hpp"
#include "horizon/common/error.hpp"

namespace horizon::server {

class Daemon {
 public:
  explicit Daemon(Config config);
  ~Daemon();
  Daemon(const Daemon&) = delete;
  Daemon& operator=(const Daemon&) = delete;

  Status start();
  // `cancel` (may be null) stops a long preparation of the meshes: a
  // SIGTERM while loading ends the load with kCancelled.
  Status load_datasets(const CancelToken* cancel = nullptr);
  Status reload(const Config& config, const CancelToken* cancel = nullptr);
  void shutdown();

  // The gRPC port actually bound (the configured one, or the one chosen for
  // port 0); 0 before start().
  int port() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace horizon::server
