// viewshed_call.hpp — the server-streaming ComputeViewshed call.
//
// Phases: (1) on the worker pool: validate, resolve, check limits, reserve
// memory, compute the OHF (the engine polls the call's cancel token and
// deadline), derive the raster and encode the requested files; (2) stream:
// header, raster chunks, file chunks, summary, one write at a time (the next
// message is built only when the previous one is sent, so at most one chunk
// is copied at a time). A failed write (client gone, call cancelled) ends the
// call CANCELLED. Finish is called exactly once; the reactor deletes itself
// in OnDone.
#pragma once

#include <algorithm>
#include <cstddef>

#include <grpcpp/server_context.h>
#include <grpcpp/support/server_callback.h>

#include "horizon/v1/visibility.pb.h"
#include "server_env.hpp"

namespace horizon::server {

// A stream's largest payload per message, from a request's max_chunk_bytes
// (0: 1 MiB; clamped to [4 KiB, 3 MiB], far under gRPC's 4 MiB default
// receive limit). Negative values are the caller's INVALID_ARGUMENT.
inline constexpr int kDefaultChunkBytes = 1 << 20;
inline constexpr int kMinChunkBytes = 4 << 10;
inline constexpr int kMaxChunkBytes = 3 << 20;
inline std::size_t chunk_bytes_for(int requested) {
  return requested > 0 ? static_cast<std::size_t>(std::clamp(requested, kMinChunkBytes, kMaxChunkBytes))
                       : static_cast<std::size_t>(kDefaultChunkBytes);
}

// Starts the call; returns the reactor to hand to gRPC.
grpc::ServerWriteReactor<v1::ViewshedResponse>* start_viewshed_call(ServerEnv& env,
                                                                    grpc::CallbackServerContext* context,
                                                                    const v1::ViewshedRequest* request);

}  // namespace horizon::server
