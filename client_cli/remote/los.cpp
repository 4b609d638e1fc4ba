// `horizon los DATASET --server HOST:PORT ...`: one sight line through the
// batched LineOfSight call, reported as embedded mode does.
#include <cmath>
#include <iostream>

#include "commands/command.hpp"
#include "output.hpp"
#include "remote/client.hpp"
#include "remote/module_abi.hpp"

namespace horizon::cli::remote {
namespace {

visibility::ProfileSample to_sample(const v1::ProfileSample& s) {
  return {s.distance(), s.col(), s.row(), s.x(), s.y(), s.terrain(), s.sight_line()};
}

}  // namespace

int impl::run_los(const Args& args, const std::string& dataset, const geodesy::PointSpec& from_spec,
                  const geodesy::PointSpec& to_spec, const visibility::LosOptions& options, bool json) {
  Client client(args);
  v1::Dataset d;
  if (auto s = client.get_dataset(dataset, d); !s.ok()) return report_status(s, client.address());

  v1::LineOfSightRequest request;
  request.set_dataset(dataset);
  request.set_curvature(options.curvature_coefficient);
  request.set_include_profile(true);  // one line: cheap, and the report counts the crossings
  v1::SightLine* line = request.add_lines();
  *line->mutable_from() = to_proto_point(from_spec);
  *line->mutable_to() = to_proto_point(to_spec);
  v1::LineOfSightResponse response;
  if (auto s = client.visibility().LineOfSight(client.context().get(), request, &response); !s.ok())
    return report_status(s, client.address());
  if (response.results_size() != 1)
    return report_error(make_error(ErrorCode::kDataError,
                                   "the daemon answered " + std::to_string(response.results_size()) + " lines, not 1"));
  const v1::LineOfSightResult& r = response.results(0);
  const geodesy::GridPoint eye = to_grid_point(r.from()), target = to_grid_point(r.to());
  std::optional<visibility::ProfileSample> block;
  if (r.has_first_block()) block = to_sample(r.first_block());

  if (json) {
    Json j;
    j["dem"] = dataset;
    j["visible"] = r.visible();
    j["distance"] = r.distance();
    j["clearance"] = finite_or_null(r.clearance());
    j["curvature"] = options.curvature_coefficient;
    j["from"] = to_json(eye, to_lonlat(r.from()));
    j["to"] = to_json(target, to_lonlat(r.to()));
    j["first_block"] = block ? to_json(*block) : Json(nullptr);
    Json profile = Json::array();
    for (const v1::ProfileSample& s : r.profile()) profile.push_back(to_json(to_sample(s)));
    j["profile"] = std::move(profile);
    print_json(j);
    return kExitOk;
  }

  const bool geographic = d.geographic();
  std::cout << "Line of sight over " << dataset << " on " << client.address() << '\n'
            << "  from:       x " << coordinate(eye.x, geographic) << ", y " << coordinate(eye.y, geographic)
            << ", eye " << fixed(eye.elevation, 1) << " m\n"
            << "  to:         x " << coordinate(target.x, geographic) << ", y " << coordinate(target.y, geographic)
            << ", target " << fixed(target.elevation, 1) << " m\n"
            << "  visible:    " << (r.visible() ? "yes" : "no") << '\n'
            << "  distance:   " << fixed(r.distance(), 1) << " m\n"
            << "  clearance:  "
            << (std::isfinite(r.clearance())
                    ? fixed(r.clearance(), 2) + " m (lowest gap between sight line and terrain)"
                    : std::string("n/a (no terrain between the points)"))
            << '\n';
  if (block)
    std::cout << "  blocked at: x " << coordinate(block->x, geographic) << ", y " << coordinate(block->y, geographic)
              << ", " << fixed(block->distance, 1) << " m from the eye: terrain " << fixed(block->terrain, 1)
              << " m, sight line " << fixed(block->sight_line, 1) << " m\n";
  std::cout << "  profile:    " << r.profile_size() << " grid crossings (--json prints them)\n";
  return kExitOk;
}

}  // namespace horizon::cli::remote
