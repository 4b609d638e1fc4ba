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

#include <grpcpp/server_context.h>
#include <grpcpp/support/server_callback.h>

#include "server_env.hpp"
#include "horizon/v1/visibility.pb.h"

namespace horizon::server {

// Starts the call; returns the reactor to hand to gRPC.
grpc::ServerWriteReactor<v1::ViewshedResponse>* start_viewshed_call(ServerEnv& env,
                                                                    grpc::CallbackServerContext* context,
                                                                    const v1::ViewshedRequest* request);

}  // namespace horizon::server
