// LineOfSight: many sight lines on one dataset, each by the exact R3 rule.
#include <string>

#include "call_scope.hpp"
#include "horizon/visibility/line_of_sight.hpp"
#include "translate.hpp"
#include "visibility_service.hpp"

namespace horizon::server {
namespace {

// Working memory per line: the result message and, with profiles, one sample
// per grid crossing (at most width + height of them).
std::uint64_t los_bytes(const Dataset& d, int lines, bool profile) {
  const std::uint64_t per_line = 512 + (profile ? static_cast<std::uint64_t>(d.dem.width() + d.dem.height()) * 128 : 0);
  return per_line * static_cast<std::uint64_t>(lines);
}

}  // namespace

grpc::Status run_line_of_sight(CallScope& scope, const v1::LineOfSightRequest& request,
                               v1::LineOfSightResponse& response) {
  auto dataset = scope.dataset(request.dataset());
  if (!dataset.ok()) return scope.status_of(dataset.error());
  const Dataset& d = **dataset;
  const auto& limits = scope.env().config.limits;
  const int n = request.lines_size();
  scope.record().lines = static_cast<std::uint64_t>(n);
  scope.record().algorithm = "r3";
  if (n == 0) return scope.status_of(make_error(ErrorCode::kInvalidArgument, "lines: at least one line is needed", "lines"));
  if (static_cast<std::uint64_t>(n) > limits.max_lines)
    return scope.status_of(make_error(ErrorCode::kResourceExhausted,
                                      "lines: " + std::to_string(n) + " sight lines, more than limits.max_lines = " +
                                          std::to_string(limits.max_lines),
                                      "lines"));
  auto curvature = to_curvature(request.has_curvature(), request.curvature());
  if (!curvature.ok()) return scope.status_of(curvature.error());
  if (auto s = scope.reserve(los_bytes(d, n, request.include_profile()), "these sight lines"); !s.ok())
    return scope.status_of(s.error());

  visibility::LosOptions options;
  options.curvature_coefficient = *curvature;
  for (int i = 0; i < n; ++i) {
    if (i % 64 == 0)
      if (auto s = check_control(scope.control()); !s.ok()) return scope.status_of(s.error());
    const v1::SightLine& line = request.lines(i);
    const std::string prefix = "lines[" + std::to_string(i) + "].";
    if (!line.has_from() || !line.has_to())
      return scope.status_of(make_error(ErrorCode::kInvalidArgument, prefix + (line.has_from() ? "to" : "from") + ": required",
                                        prefix + (line.has_from() ? "to" : "from")));
    auto from_spec = to_point_spec(line.from(), prefix + "from");
    if (!from_spec.ok()) return scope.status_of(from_spec.error());
    auto to_spec = to_point_spec(line.to(), prefix + "to");
    if (!to_spec.ok()) return scope.status_of(to_spec.error());
    auto from = geodesy::resolve_point(d.dem, *from_spec, "from");
    if (!from.ok()) return scope.status_of(rename_field(from.error(), "", prefix));
    auto to = geodesy::resolve_point(d.dem, *to_spec, "to");
    if (!to.ok()) return scope.status_of(rename_field(to.error(), "", prefix));
    auto los = visibility::line_of_sight(d.dem, *from, *to, options);
    if (!los.ok()) return scope.status_of(rename_field(los.error(), "", prefix));

    v1::LineOfSightResult& out = *response.add_results();
    out.set_visible(los->visible);
    out.set_distance(los->distance);
    out.set_clearance(los->clearance);
    fill_point(*from, d.dem, *out.mutable_from());
    fill_point(*to, d.dem, *out.mutable_to());
    if (los->first_block) fill_sample(*los->first_block, *out.mutable_first_block());
    if (request.include_profile())
      for (const visibility::ProfileSample& s : los->profile) fill_sample(s, *out.add_profile());
  }
  return grpc::Status::OK;
}

}  // namespace horizon::server
