// session_service.hpp — horizon.v1.SessionService: clip-map sessions for
// moving clients over one bidirectional stream (protos/horizon/v1/session.proto).
//
// Each stream is a SessionCall: it admits like any call (token, loading,
// draining, limits.max_pending: a session holds one pending slot for its
// life) but gets no default deadline; takes one of sessions.max places;
// reserves its clip-map, trace scratch and boxes in the memory budget before
// anything is allocated; then runs the engine's ClipSession (its answers on
// the worker pool, its loading on the session's own loader thread).
//
// The SessionRegistry knows every live session: it bounds their number,
// shares the source pyramids sessions read (one per dataset and reduction,
// so their blocks are shared in the block cache), ends sessions idle for
// sessions.idle_ms (a sweeper thread), and ends them all with UNAVAILABLE
// when the daemon drains.
#pragma once

#include <atomic>
#include <condition_variable>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <thread>
#include <tuple>

#include "horizon/terrain/source_pyramid.hpp"
#include "horizon/v1/session.grpc.pb.h"
#include "server_env.hpp"

namespace horizon::server {

class SessionCall;

class SessionRegistry {
 public:
  explicit SessionRegistry(ServerEnv& env);
  ~SessionRegistry();
  SessionRegistry(const SessionRegistry&) = delete;
  SessionRegistry& operator=(const SessionRegistry&) = delete;

  // Takes one of sessions.max places for `call`; false when all are taken.
  bool enter(SessionCall* call);
  void leave(SessionCall* call);
  std::size_t open_count() const;

  // The pyramid of `source` with `reduction`, as make() would build it, kept
  // for later sessions while its dataset is served.
  Result<std::shared_ptr<const terrain::SourcePyramid>> pyramid(
      const std::shared_ptr<const terrain::ElevationSource>& source, terrain::Reduction reduction,
      const terrain::SourcePyramidOptions& options);

  // Ends every session with UNAVAILABLE ("draining"); later enters fail.
  void drain();

 private:
  void sweep();

  ServerEnv& env_;
  // Recursive: ending a call from drain() or the sweeper may finish it, and a
  // finishing call leaves the registry on the same thread.
  mutable std::recursive_mutex mutex_;
  std::set<SessionCall*> calls_;
  bool draining_ = false;
  using PyramidKey = std::tuple<std::uint64_t, int, int, int>;  // source id, reduction, levels, block
  std::map<PyramidKey, std::shared_ptr<const terrain::SourcePyramid>> pyramids_;
  std::condition_variable_any wake_;
  bool stop_ = false;
  std::thread sweeper_;
};

class SessionService final : public v1::SessionService::CallbackService {
 public:
  SessionService(ServerEnv& env, SessionRegistry& registry) : env_(env), registry_(registry) {}
  grpc::ServerBidiReactor<v1::SessionRequest, v1::SessionResponse>* Session(
      grpc::CallbackServerContext* context) override;

 private:
  ServerEnv& env_;
  SessionRegistry& registry_;
};

}  // namespace horizon::server
