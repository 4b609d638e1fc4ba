#include "visibility_service.hpp"

#include <string>

#include "horizon/region/region_plan.hpp"
#include "horizon/visibility/plan.hpp"
#include "memory_budget.hpp"
#include "unary_call.hpp"
#include "viewshed_call.hpp"

namespace horizon::server {
namespace {

std::string converting_boxes(std::uint64_t n) {
  return "converting these " + std::to_string(n) + " boxes";
}
std::string planning_lines(std::uint64_t n) {
  return "planning these " + std::to_string(n) + " sight lines";
}

}  // namespace

grpc::ServerWriteReactor<v1::ViewshedResponse>* VisibilityService::ComputeViewshed(grpc::CallbackServerContext* context,
                                                                                   const v1::ViewshedRequest* request) {
  return start_viewshed_call(env_, context, request);
}

grpc::ServerUnaryReactor* VisibilityService::LineOfSight(grpc::CallbackServerContext* context,
                                                         const v1::LineOfSightRequest* request,
                                                         v1::LineOfSightResponse* response) {
  // The request as received; the lines' plans, their fixed part. request
  // and response stay valid until the call finishes.
  const std::uint64_t n = static_cast<std::uint64_t>(request->lines_size());
  const std::uint64_t plans = n <= env_.config.limits.max_lines ? n * sizeof(visibility::LinePlan) : 0;
  return UnaryCall::start(
      env_, context, "LineOfSight", *request, held_bytes(*request), plans, planning_lines(n),
      [request, response](CallScope& scope) { return run_line_of_sight(scope, *request, *response); });
}

grpc::ServerUnaryReactor* VisibilityService::CullBoxes(grpc::CallbackServerContext* context,
                                                       const v1::CullBoxesRequest* request,
                                                       v1::CullBoxesResponse* response) {
  // The boxes as received, and the answer's, one per box; their conversion.
  const std::uint64_t n = static_cast<std::uint64_t>(request->boxes_size());
  const std::uint64_t messages = held_bytes(*request) + n * MemoryBudget::kResponseBytesPerBox;
  const std::uint64_t boxes = n <= env_.config.limits.max_boxes ? n * visibility::kCullBytesPerBox : 0;
  return UnaryCall::start(env_, context, "CullBoxes", *request, messages, boxes, converting_boxes(n),
                          [request, response](CallScope& scope) { return run_cull_boxes(scope, *request, *response); });
}

grpc::ServerUnaryReactor* VisibilityService::RegionVisibility(grpc::CallbackServerContext* context,
                                                              const v1::RegionVisibilityRequest* request,
                                                              v1::RegionVisibilityResponse* response) {
  // The request as received, and a verdict per box; their conversion.
  const std::uint64_t n = static_cast<std::uint64_t>(request->boxes_size());
  const std::uint64_t messages = held_bytes(*request) + n * sizeof(v1::RegionBoxVerdict);
  const std::uint64_t boxes = n <= env_.config.limits.max_boxes ? n * region::kBytesPerBox : 0;
  return UnaryCall::start(
      env_, context, "RegionVisibility", *request, messages, boxes, converting_boxes(n),
      [request, response](CallScope& scope) { return run_region_visibility(scope, *request, *response); });
}

}  // namespace horizon::server
