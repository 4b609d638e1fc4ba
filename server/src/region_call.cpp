// RegionVisibility: one box of viewpoints, object boxes or every cell within
// reach classified always visible / always hidden / undetermined (the
// classification itself is core's region/).
#include <string>

#include "call_scope.hpp"
#include "horizon/region/region_plan.hpp"
#include "translate.hpp"
#include "visibility_service.hpp"

namespace horizon::server {
namespace {

// One message holds the raster answer: 1 byte a cell, under gRPC's 4 MiB
// default receive limit with room for the rest.
constexpr std::uint64_t kMaxRasterCells = 4'000'000;

}  // namespace

grpc::Status run_region_visibility(CallScope& scope, const v1::RegionVisibilityRequest& request,
                                   v1::RegionVisibilityResponse& response) {
  auto dataset = scope.dataset(request.dataset());
  if (!dataset.ok()) return scope.status_of(dataset.error());
  const Dataset& d = **dataset;
  const ServerEnv& env = scope.env();
  const int n = request.boxes_size();
  scope.record().boxes = static_cast<std::uint64_t>(n);
  if (static_cast<std::uint64_t>(n) > env.config.limits.max_boxes)
    return scope.status_of(make_error(ErrorCode::kResourceExhausted,
                                      "boxes: " + std::to_string(n) + " boxes, more than limits.max_boxes = " +
                                          std::to_string(env.config.limits.max_boxes),
                                      "boxes"));
  // The boxes' conversion and plan hold kBytesPerBox a box: reserved with
  // the messages at admission (VisibilityService::RegionVisibility), before
  // they are made, as the rest of the plan's holding is below.
  auto query = to_region_query(request, env.config.engine_threads);
  if (!query.ok()) return scope.status_of(query.error());

  // The window bounding the region and its items, sized from the header.
  auto plan = region::plan_region(*d.source, std::move(*query));
  if (!plan.ok()) return scope.status_of(rename_field(plan.error(), ""));
  const std::string cause = plan->query.cells ? "max_distance" : "boxes";
  const std::uint64_t limit =
      plan->query.cells ? std::min(env.config.limits.max_cells, kMaxRasterCells) : env.config.limits.max_cells;
  if (plan->cells > limit)
    return scope.status_of(
        make_error(ErrorCode::kResourceExhausted,
                   cause + ": the region and its items span a window of " + std::to_string(plan->cells) +
                       " cells, more than the limit of " + std::to_string(limit) +
                       (plan->query.cells ? " (limits.max_cells, and one message's 4 000 000)" : " (limits.max_cells)"),
                   cause));
  scope.record().cells = plan->cells;
  // The run's own holding, and the raster's copy in the answer.
  const std::uint64_t held = plan->bytes + (plan->query.cells ? plan->cells : 0);
  if (auto s = scope.reserve(held, "this region request (" + std::to_string(plan->cells) + " cells)"); !s.ok())
    return scope.status_of(s.error());

  auto run = region::run_region(*plan, *d.source, &env.cache, scope.control());
  if (!run.ok()) return scope.status_of(rename_field(run.error(), ""));

  if (plan->query.cells) {
    const terrain::Grid<std::uint8_t>& codes = run->codes;
    std::string* bytes = response.mutable_codes();
    bytes->resize(static_cast<std::size_t>(codes.width()) * static_cast<std::size_t>(codes.height()));
    for (int r = 0; r < codes.height(); ++r)
      for (int c = 0; c < codes.width(); ++c)
        (*bytes)[static_cast<std::size_t>(r) * static_cast<std::size_t>(codes.width()) + static_cast<std::size_t>(c)] =
            static_cast<char>(codes.at(c, r));
    fill_window(run->window, *response.mutable_window());
    const terrain::GeoTransform& t = d.header().georef.transform;
    fill_transform(t.shifted(run->window.col0, run->window.row0), *response.mutable_transform());
  } else {
    response.mutable_boxes()->Reserve(n);
    for (int i = 0; i < n; ++i) {
      v1::RegionBoxVerdict* out = response.add_boxes();
      out->set_verdict(to_proto_verdict(run->verdicts[static_cast<std::size_t>(i)]));
      out->set_id(request.boxes(i).id());
    }
    fill_window(run->window, *response.mutable_window());
  }
  fill_region_stats(run->stats, *response.mutable_stats());
  return grpc::Status::OK;
}

}  // namespace horizon::server
