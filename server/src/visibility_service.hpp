// visibility_service.hpp — horizon.v1.VisibilityService. Each method only
// hands the call to its handler (viewshed_call, line_of_sight_call,
// cull_call, region_call); the handlers translate and run the engine on the worker pool.
#pragma once

#include "arena_allocator.hpp"
#include "horizon/v1/visibility.grpc.pb.h"
#include "server_env.hpp"

namespace horizon::server {

class VisibilityService final : public v1::VisibilityService::CallbackService {
 public:
  explicit VisibilityService(ServerEnv& env) : env_(env) {
    SetMessageAllocatorFor_CullBoxes(&cull_messages_);
    SetMessageAllocatorFor_LineOfSight(&line_messages_);
  }

  grpc::ServerWriteReactor<v1::ViewshedResponse>* ComputeViewshed(grpc::CallbackServerContext* context,
                                                                  const v1::ViewshedRequest* request) override;
  grpc::ServerUnaryReactor* LineOfSight(grpc::CallbackServerContext* context, const v1::LineOfSightRequest* request,
                                        v1::LineOfSightResponse* response) override;
  grpc::ServerUnaryReactor* CullBoxes(grpc::CallbackServerContext* context, const v1::CullBoxesRequest* request,
                                      v1::CullBoxesResponse* response) override;
  grpc::ServerUnaryReactor* RegionVisibility(grpc::CallbackServerContext* context,
                                             const v1::RegionVisibilityRequest* request,
                                             v1::RegionVisibilityResponse* response) override;

 private:
  ServerEnv& env_;
  // The batched calls' messages live on one arena per call (arena_allocator.hpp).
  ArenaAllocator<v1::CullBoxesRequest, v1::CullBoxesResponse> cull_messages_;
  ArenaAllocator<v1::LineOfSightRequest, v1::LineOfSightResponse> line_messages_;
};

class CallScope;
// The unary handlers' work, run on the pool.
grpc::Status run_line_of_sight(CallScope& scope, const v1::LineOfSightRequest& request,
                               v1::LineOfSightResponse& response);
grpc::Status run_cull_boxes(CallScope& scope, const v1::CullBoxesRequest& request, v1::CullBoxesResponse& response);
grpc::Status run_region_visibility(CallScope& scope, const v1::RegionVisibilityRequest& request,
                                   v1::RegionVisibilityResponse& response);

}  // namespace horizon::server
