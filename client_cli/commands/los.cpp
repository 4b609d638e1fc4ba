// `horizon los DEM --from ... --to ...`: one sight line, explained.
#include <cmath>
#include <iostream>

#include "commands/command.hpp"
#include "horizon/terrain/source.hpp"
#include "horizon/visibility/line_of_sight.hpp"
#include "horizon/visibility/options.hpp"
#include "horizon/visibility/plan.hpp"
#include "inputs.hpp"
#include "output.hpp"
#include "remote/remote.hpp"

namespace horizon::cli {
namespace {

constexpr FlagSpec kFlags[] = {
    {"--from", "", "X,Y", "Eye position in the DEM's CRS"},
    {"--from-lat", "", "LAT", "Eye latitude, WGS84 degrees (with --from-lon)"},
    {"--from-lon", "", "LON", "Eye longitude, WGS84 degrees (with --from-lat)"},
    {"--to", "", "X,Y", "Target position in the DEM's CRS"},
    {"--to-lat", "", "LAT", "Target latitude, WGS84 degrees (with --to-lon)"},
    {"--to-lon", "", "LON", "Target longitude, WGS84 degrees (with --to-lat)"},
    {"--from-height", "", "M", "Eye height above the ground, metres (default 2)"},
    {"--to-height", "", "M", "Target height above the ground, metres (default 0)"},
    {"--curvature", "", "C", "Curvature/refraction coefficient as GDAL's (default 0.85714; 0 disables)"},
    {"--band", "", "N", "DEM band to read, 1-based (required when the file has several)"},
    kValidRangeFlag,
    {"--json", "", "", "Print a JSON document, with the full terrain profile"},
    remote::kServerFlag,
    remote::kDeadlineFlag,
    remote::kCaFlag,
    remote::kClientCertFlag,
    remote::kTokenFileFlag,
};

int run_los(const Args& args) {
  const std::string& path = single_operand(args, "DEM");
  const bool json = args.has("--json");
  geodesy::PointSpec from = point_from_flags(args, {"--from", "--from-lat", "--from-lon"});
  geodesy::PointSpec to = point_from_flags(args, {"--to", "--to-lat", "--to-lon"});
  from.height = args.non_negative("--from-height").value_or(2.0);
  to.height = args.non_negative("--to-height").value_or(0.0);
  visibility::LosOptions options;
  options.curvature_coefficient = args.non_negative("--curvature").value_or(options.curvature_coefficient);
  {
    // The engine owns the coefficient's range; ask it before reading the DEM.
    visibility::ViewshedOptions check;
    check.curvature_coefficient = options.curvature_coefficient;
    throw_if_invalid_option(visibility::validate_options(check));
  }
  (void)source_options(args);  // a malformed --band or --valid-range is a usage error before any reading
  if (args.has("--server")) return remote::run_los(args, path, from, to, options, json);  // DEM is a dataset name

  // Planned on the header, run on the cells between the two points only.
  auto source = terrain::ElevationSource::open(path, source_options(args));
  if (!source.ok()) return report_error(source.error());
  auto plan = visibility::plan_line(**source, {from, to, options});
  if (!plan.ok()) return report_error(plan.error());
  auto run = visibility::run_line(*plan, **source, nullptr);
  if (!run.ok()) return report_error(run.error());
  const terrain::Georeference& georef = (*source)->header().georef;
  const geodesy::GridPoint* const eye = &run->from;
  const geodesy::GridPoint* const target = &run->to;
  const visibility::LosResult* const los = &run->result;

  if (json) {
    Json j;
    j["dem"] = path;
    j["visible"] = los->visible;
    j["distance"] = los->distance;
    j["clearance"] = finite_or_null(los->clearance);
    j["curvature"] = options.curvature_coefficient;
    j["from"] = to_json(*eye, lonlat_of(georef, eye->x, eye->y));
    j["to"] = to_json(*target, lonlat_of(georef, target->x, target->y));
    j["first_block"] = los->first_block ? to_json(*los->first_block) : Json(nullptr);
    Json profile = Json::array();
    for (const visibility::ProfileSample& s : los->profile) profile.push_back(to_json(s));
    j["profile"] = std::move(profile);
    print_json(j);
    return kExitOk;
  }

  const bool geographic = is_geographic(georef);
  std::cout << "Line of sight over " << path << '\n'
            << "  from:       x " << coordinate(eye->x, geographic) << ", y " << coordinate(eye->y, geographic)
            << ", eye " << fixed(eye->elevation, 1) << " m\n"
            << "  to:         x " << coordinate(target->x, geographic) << ", y " << coordinate(target->y, geographic)
            << ", target " << fixed(target->elevation, 1) << " m\n"
            << "  visible:    " << (los->visible ? "yes" : "no") << '\n'
            << "  distance:   " << fixed(los->distance, 1) << " m\n"
            << "  clearance:  "
            << (std::isfinite(los->clearance)
                    ? fixed(los->clearance, 2) + " m (lowest gap between sight line and terrain)"
                    : std::string("n/a (no terrain between the points)"))
            << '\n';
  if (const auto& b = los->first_block)
    std::cout << "  blocked at: x " << coordinate(b->x, geographic) << ", y " << coordinate(b->y, geographic) << ", "
              << fixed(b->distance, 1) << " m from the eye: terrain " << fixed(b->terrain, 1) << " m, sight line "
              << fixed(b->sight_line, 1) << " m\n";
  std::cout << "  profile:    " << los->profile.size() << " grid crossings (--json prints them)\n";
  return kExitOk;
}

}  // namespace

const Command& los_command() {
  static const Command command{
      "los",
      "Test one line of sight and explain it: first blocking point, clearance, terrain profile",
      "horizon los DEM (--from X,Y | --from-lat LAT --from-lon LON) (--to X,Y | --to-lat LAT --to-lon LON) [options]",
      "Tests whether a target is visible from an eye by the exact R3 rule: the sight\n"
      "line is checked against the terrain at every grid row and column it crosses.\n"
      "Prints whether it is visible, the distance, the clearance (smallest height of\n"
      "the sight line above the terrain) and the first point where terrain blocks it.\n"
      "Profile heights are lowered for curvature as seen from the eye.",
      kFlags,
      "  horizon los data/dem/rainier_summit_srtm3_400x400.tif --from-lat 46.8529 --from-lon -121.7604 \\\n"
      "      --to-lat 46.80 --to-lon -121.70 --to-height 10\n"
      "  horizon los data/dem/ecuador_andes_utm17s_10m_383x415.tif --from 713900,9558950 --to 714500,9559500 --json\n",
      run_los,
  };
  return command;
}

}  // namespace horizon::cli
