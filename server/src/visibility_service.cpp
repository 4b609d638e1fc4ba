#include "visibility_service.hpp"

#include "memory_budget.hpp"
#include "unary_call.hpp"
#include "viewshed_call.hpp"

namespace horizon::server {

grpc::ServerWriteReactor<v1::ViewshedResponse>* VisibilityService::ComputeViewshed(grpc::CallbackServerContext* context,
                                                                                   const v1::ViewshedRequest* request) {
  return start_viewshed_call(env_, context, request);
}

grpc::ServerUnaryReactor* VisibilityService::LineOfSight(grpc::CallbackServerContext* context,
                                                         const v1::LineOfSightRequest* request,
                                                         v1::LineOfSightResponse* response) {
  // request and response stay valid until the call finishes.
  return UnaryCall::start(
      env_, context, "LineOfSight", *request, held_bytes(*request),
      [request, response](CallScope& scope) { return run_line_of_sight(scope, *request, *response); });
}

grpc::ServerUnaryReactor* VisibilityService::CullBoxes(grpc::CallbackServerContext* context,
                                                       const v1::CullBoxesRequest* request,
                                                       v1::CullBoxesResponse* response) {
  // The boxes as received, and the answer's, one per box.
  const std::uint64_t messages =
      held_bytes(*request) + static_cast<std::uint64_t>(request->boxes_size()) * MemoryBudget::kResponseBytesPerBox;
  return UnaryCall::start(env_, context, "CullBoxes", *request, messages,
                          [request, response](CallScope& scope) { return run_cull_boxes(scope, *request, *response); });
}

grpc::ServerUnaryReactor* VisibilityService::RegionVisibility(grpc::CallbackServerContext* context,
                                                              const v1::RegionVisibilityRequest* request,
                                                              v1::RegionVisibilityResponse* response) {
  // The request as received, and a verdict per box.
  const std::uint64_t messages =
      held_bytes(*request) + static_cast<std::uint64_t>(request->boxes_size()) * sizeof(v1::RegionBoxVerdict);
  return UnaryCall::start(env_, context, "RegionVisibility", *request, messages, [request, response](CallScope& scope) {
    return run_region_visibility(scope, *request, *response);
  });
}

}  // namespace horizon::server
