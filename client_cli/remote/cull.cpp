// `horizon cull DATASET --server HOST:PORT ...`: one CullBoxes call, reported
// as embedded mode reports its own culling.
#include <chrono>

#include "commands/command.hpp"
#include "commands/cull.hpp"
#include "remote/client.hpp"
#include "remote/module_abi.hpp"

namespace horizon::cli::remote {
namespace {

// The box's state as the server answered it; a server older than the state
// field leaves it unspecified, and then `visible` says visible or hidden.
visibility::Visibility box_state(const v1::BoxVisibility& b) {
  switch (b.state()) {
    case v1::BOX_STATE_VISIBLE:
      return visibility::Visibility::kSeen;
    case v1::BOX_STATE_HIDDEN:
      return visibility::Visibility::kOccluded;
    case v1::BOX_STATE_UNDETERMINED:
      return visibility::Visibility::kUndetermined;
    case v1::BOX_STATE_OUT_OF_RANGE:
      return visibility::Visibility::kOutOfRange;
    default:
      return b.visible() ? visibility::Visibility::kSeen : visibility::Visibility::kOccluded;
  }
}

}  // namespace

int impl::run_cull(const Args& args, const std::string& dataset, const geodesy::PointSpec& observer,
                   const std::vector<visibility::BoxSpec>& boxes, const std::vector<std::uint64_t>& ids,
                   const visibility::CullOptions& options, bool json) {
  Client client(args);
  const auto started = std::chrono::steady_clock::now();
  v1::Dataset d;
  if (auto s = client.get_dataset(dataset, d); !s.ok()) return report_status(s, client.address());

  v1::CullBoxesRequest request;
  request.set_dataset(dataset);
  *request.mutable_observer() = to_proto_point(observer);
  request.set_conservative(options.conservative);
  request.set_algorithm(to_proto_algorithm(options.viewshed.algorithm));
  request.set_curvature(options.viewshed.curvature_coefficient);
  if (options.viewshed.nodata == visibility::NodataPolicy::kFill) {
    request.set_nodata(v1::NODATA_POLICY_FILL);
    request.set_nodata_fill_height(options.viewshed.nodata_fill_height);
  }
  request.mutable_boxes()->Reserve(static_cast<int>(boxes.size()));
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    v1::Box& box = *request.add_boxes() = to_proto_box(boxes[i]);
    if (!ids.empty()) box.set_id(ids[i]);
  }
  v1::CullBoxesResponse response;
  if (auto s = client.visibility().CullBoxes(client.context().get(), request, &response); !s.ok())
    return report_status(s, client.address());

  CullReport report;
  report.dem = dataset;
  report.boxes_path = args.text("--boxes").value_or("");
  report.where = "on " + client.address();
  report.observer = to_grid_point(response.observer());
  report.observer_lonlat = to_lonlat(response.observer());
  report.geographic = d.geographic();
  report.conservative = options.conservative;
  visibility::CullResult& r = report.result;
  r.algorithm = visibility::parse_algorithm(response.algorithm()).value_or(visibility::Algorithm::kRadial);
  r.window = {response.window().col0(), response.window().row0(), response.window().col1(), response.window().row1()};
  r.stats = to_stats(response.stats());
  r.pyramid_cells_read = response.pyramid_cells_read();
  r.visible_count = response.visible_count();
  r.out_of_range_count = response.out_of_range_count();
  r.boxes.reserve(boxes.size());
  for (const v1::BoxVisibility& b : response.boxes()) {
    r.boxes.push_back({box_state(b), static_cast<float>(b.ohf_min())});
    if (!ids.empty()) report.ids.push_back(b.id());  // the server's echo
  }
  report.total_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  print_cull(report, boxes, json);
  return kExitOk;
}

}  // namespace horizon::cli::remote
