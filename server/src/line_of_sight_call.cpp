// LineOfSight: many sight lines on one dataset, each by the exact R3 rule.
#include <algorithm>
#include <string>
#include <vector>

#include "call_scope.hpp"
#include "horizon/visibility/line_of_sight.hpp"
#include "horizon/visibility/plan.hpp"
#include "translate.hpp"
#include "visibility_service.hpp"

namespace horizon::server {

grpc::Status run_line_of_sight(CallScope& scope, const v1::LineOfSightRequest& request,
                               v1::LineOfSightResponse& response) {
  auto dataset = scope.dataset(request.dataset());
  if (!dataset.ok()) return scope.status_of(dataset.error());
  const Dataset& d = **dataset;
  const auto& limits = scope.env().config.limits;
  const int n = request.lines_size();
  scope.record().lines = static_cast<std::uint64_t>(n);
  scope.record().algorithm = "r3";
  if (n == 0)
    return scope.status_of(make_error(ErrorCode::kInvalidArgument, "lines: at least one line is needed", "lines"));
  if (static_cast<std::uint64_t>(n) > limits.max_lines)
    return scope.status_of(make_error(ErrorCode::kResourceExhausted,
                                      "lines: " + std::to_string(n) + " sight lines, more than limits.max_lines = " +
                                          std::to_string(limits.max_lines),
                                      "lines"));
  auto curvature = to_curvature(request.has_curvature(), request.curvature());
  if (!curvature.ok()) return scope.status_of(curvature.error());
  visibility::LosOptions options;
  options.curvature_coefficient = *curvature;

  // Every line planned first (points checked and placed, cells known), so the
  // memory is reserved before any line runs: the plans (held until the last
  // line runs; their fixed part reserved at admission, before they are made:
  // VisibilityService::LineOfSight; their lists of blocks once known), then
  // with them the largest line's cells (lines run one after another) and
  // every result message.
  std::uint64_t plan_bytes = static_cast<std::uint64_t>(n) * sizeof(visibility::LinePlan);
  std::vector<visibility::LinePlan> plans;
  plans.reserve(static_cast<std::size_t>(n));
  std::uint64_t largest = 0, messages = 0;
  for (int i = 0; i < n; ++i) {
    if (i % 64 == 0)
      if (auto s = check_control(scope.control()); !s.ok()) return scope.status_of(s.error());
    const std::string prefix = "lines[" + std::to_string(i) + "].";
    auto ends = to_line_ends(request.lines(i), prefix);
    if (!ends.ok()) return scope.status_of(ends.error());
    auto plan = visibility::plan_line(*d.source, {ends->first, ends->second, options});
    if (!plan.ok()) return scope.status_of(rename_field(plan.error(), "", prefix));
    largest = std::max(largest, plan->cost.bytes);
    plan_bytes += plan->read.blocks.capacity() * sizeof(std::uint64_t);
    const terrain::Window& w = plan->read.read;
    messages += MemoryBudget::kMessageBytesPerLine +
                (request.include_profile()
                     ? static_cast<std::uint64_t>(w.width() + w.height()) * MemoryBudget::kMessageBytesPerSample
                     : 0);
    plans.push_back(std::move(*plan));
  }
  if (auto s = scope.reserve(plan_bytes + largest + messages, "these sight lines"); !s.ok())
    return scope.status_of(s.error());

  const terrain::Georeference& georef = d.header().georef;
  for (int i = 0; i < n; ++i) {
    const std::string prefix = "lines[" + std::to_string(i) + "].";
    auto run = visibility::run_line(plans[static_cast<std::size_t>(i)], *d.source, &scope.env().cache, scope.control());
    if (!run.ok()) return scope.status_of(rename_field(run.error(), "", prefix));
    const visibility::LosResult& los = run->result;
    v1::LineOfSightResult& out = *response.add_results();
    out.set_visible(los.visible);
    out.set_distance(los.distance);
    out.set_clearance(los.clearance);
    fill_point(run->from, georef, *out.mutable_from());
    fill_point(run->to, georef, *out.mutable_to());
    if (los.first_block) fill_sample(*los.first_block, *out.mutable_first_block());
    if (request.include_profile())
      for (const visibility::ProfileSample& s : los.profile) fill_sample(s, *out.add_profile());
  }
  return grpc::Status::OK;
}

}  // namespace horizon::server
