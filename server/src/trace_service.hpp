// trace_service.hpp — horizon.v1.TraceService: what a camera sees over a
// dataset, per pixel (protos/horizon/v1/trace.proto). The method hands the
// call to its reactor (trace_call.cpp), which translates (trace_translate),
// plans, admits and runs core's trace/ on the worker pool, then streams.
#pragma once

#include <grpcpp/server_context.h>
#include <grpcpp/support/server_callback.h>

#include "horizon/v1/trace.grpc.pb.h"
#include "server_env.hpp"

namespace horizon::server {

// Starts a TraceCamera call (trace_call.cpp); returns the reactor to hand to gRPC.
//
// Phases, as ComputeViewshed's (viewshed_call.hpp): (1) on the worker pool:
// translate, bound every cost before any read (limits.max_trace_pixels,
// limits.max_boxes, limits.max_cells against the plan's read cells, the
// engine's box-test and edit-cell limits in plan_trace), reserve the plan's
// bytes and the channels' in the memory budget, trace through the shared
// block cache under the call's RunControl, and build the channels; (2) the
// stream: header, each channel's row chunks, the footprint GeoTIFF's bytes,
// one write at a time. A failed write ends the call CANCELLED. Finish is
// called exactly once; the reactor deletes itself in OnDone.
grpc::ServerWriteReactor<v1::TraceResponse>* start_trace_call(ServerEnv& env, grpc::CallbackServerContext* context,
                                                              const v1::TraceRequest* request);

class TraceService final : public v1::TraceService::CallbackService {
 public:
  explicit TraceService(ServerEnv& env) : env_(env) {}

  grpc::ServerWriteReactor<v1::TraceResponse>* TraceCamera(grpc::CallbackServerContext* context,
                                                           const v1::TraceRequest* request) override {
    return start_trace_call(env_, context, request);
  }

 private:
  ServerEnv& env_;
};

}  // namespace horizon::server
