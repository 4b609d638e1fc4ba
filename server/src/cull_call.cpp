// CullBoxes: one viewpoint, many object boxes, against the OHF of the window
// they need (the culling logic itself is core's visibility/cull).
#include <algorithm>
#include <string>
#include <vector>

#include "call_scope.hpp"
#include "horizon/visibility/cull.hpp"
#include "horizon/visibility/plan.hpp"
#include "translate.hpp"
#include "visibility_service.hpp"
#include "worker_memory.hpp"

namespace horizon::server {

grpc::Status run_cull_boxes(CallScope& scope, const v1::CullBoxesRequest& request, v1::CullBoxesResponse& response) {
  auto dataset = scope.dataset(request.dataset());
  if (!dataset.ok()) return scope.status_of(dataset.error());
  const Dataset& d = **dataset;
  const ServerEnv& env = scope.env();
  const int n = request.boxes_size();
  scope.record().boxes = static_cast<std::uint64_t>(n);
  if (n > 0 && static_cast<std::uint64_t>(n) > env.config.limits.max_boxes)
    return scope.status_of(make_error(ErrorCode::kResourceExhausted,
                                      "boxes: " + std::to_string(n) + " boxes, more than limits.max_boxes = " +
                                          std::to_string(env.config.limits.max_boxes),
                                      "boxes"));
  if (!request.has_observer())
    return scope.status_of(make_error(ErrorCode::kInvalidArgument, "observer: required", "observer"));
  auto spec = to_point_spec(request.observer(), "observer");
  if (!spec.ok()) return scope.status_of(spec.error());

  auto options = to_cull_options(request, env.config.engine_threads);
  if (!options.ok()) return scope.status_of(options.error());
  scope.record().algorithm = std::string(visibility::algorithm_name(
      options->conservative ? visibility::Algorithm::kConservative : options->viewshed.algorithm));
  // The boxes' conversion and plan hold kCullBytesPerBox a box: reserved
  // with the messages at admission (VisibilityService::CullBoxes), before
  // they are made, as the rest of the plan's cost is below.
  // The worker's kept buffers serve this run; its own are kept when it is done (worker_memory.hpp).
  WorkspaceLease lease(scope);
  auto boxes = to_boxes(request);
  if (!boxes.ok()) return scope.status_of(boxes.error());

  // The plan: observer and boxes placed on the dataset's header, the reach, cells and cost known.
  auto plan = visibility::plan_cull_boxes(*d.source, {*spec, std::move(*boxes), *options});
  if (!plan.ok()) return scope.status_of(rename_field(plan.error(), ""));
  const std::uint64_t cells = plan->cost.cells;
  if (cells > env.config.limits.max_cells)
    return scope.status_of(
        make_error(ErrorCode::kResourceExhausted,
                   "boxes: the farthest box needs a window of " + std::to_string(cells) +
                       " cells, more than limits.max_cells = " + std::to_string(env.config.limits.max_cells),
                   "boxes"));
  // The messages were reserved at admission (VisibilityService::CullBoxes).
  const std::string what = planned_work("this culling request", plan->cost, plan->viewshed.radial.ray_spacing);
  // The boxes' share is the call's own; the rest is buffers the workspace serves.
  const std::uint64_t boxes_bytes =
      std::min<std::uint64_t>(plan->cost.bytes, static_cast<std::uint64_t>(n) * visibility::kCullBytesPerBox);
  if (auto s = lease.reserve(plan->cost.bytes - boxes_bytes, boxes_bytes, what); !s.ok())
    return scope.status_of(s.error());

  // The daemon's GPU contexts are lent to the OHF (backend auto: a hardware GPU for large windows).
  auto run = visibility::run_cull_boxes(*plan, *d.source, &env.cache, scope.control(), env.gpu, env.backend,
                                        lease.workspace());
  if (!run.ok()) return scope.status_of(rename_field(run.error(), ""));
  const visibility::CullResult* const result = &run->result;
  const visibility::WorkStats& stats = result->stats;
  scope.ohf_computed(stats);

  response.mutable_boxes()->Reserve(n);
  for (int i = 0; i < n; ++i) {
    const visibility::BoxVisibility& b = result->boxes[static_cast<std::size_t>(i)];
    v1::BoxVisibility* out = response.add_boxes();
    out->set_visible(visibility::may_be_seen(b.state));
    out->set_ohf_min(b.ohf_min);
    out->set_state(to_proto_box_state(b.state));
    out->set_id(request.boxes(i).id());
  }
  response.set_visible_count(static_cast<std::uint32_t>(result->visible_count));
  response.set_out_of_range_count(static_cast<std::uint32_t>(result->out_of_range_count));
  fill_window(result->window, *response.mutable_window());
  fill_stats(stats, *response.mutable_stats());
  response.set_pyramid_cells_read(result->pyramid_cells_read);
  response.set_algorithm(std::string(visibility::algorithm_name(result->algorithm)));
  fill_point(run->observer, d.header().georef, *response.mutable_observer());
  return grpc::Status::OK;
}

}  // namespace horizon::server
