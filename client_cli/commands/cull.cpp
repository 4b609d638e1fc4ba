// `horizon cull DEM --boxes FILE ...`: which object boxes an observer can see.
#include "commands/cull.hpp"

#include <chrono>
#include <cmath>
#include <fstream>
#include <iostream>
#include <sstream>

#include "commands/command.hpp"
#include "horizon/visibility/cull.hpp"
#include "inputs.hpp"
#include "interrupt.hpp"
#include "output.hpp"
#include "remote/remote.hpp"

namespace horizon::cli {
namespace {

constexpr FlagSpec kFlags[] = {
    {"--observer", "", "X,Y", "Viewpoint in the DEM's CRS"},
    {"--lat", "", "LAT", "Viewpoint latitude, WGS84 degrees (with --lon)"},
    {"--lon", "", "LON", "Viewpoint longitude, WGS84 degrees (with --lat)"},
    {"--height", "", "M", "Eye height above the ground, metres (default 2)"},
    {"--altitude", "", "M", "Eye altitude, absolute metres (instead of --height)"},
    {"--boxes", "", "FILE.csv",
     "Boxes, one per line: [id,]x_min,y_min,x_max,y_max,z_min,z_max (DEM CRS; absolute metres); '#' comments"},
    {"--lonlat", "", "", "The boxes' x/y are WGS84 longitude/latitude"},
    {"--conservative", "", "", "Never report hidden a box R3 sees (the conservative OHF)"},
    {"--algorithm", "", "ALG", "OHF algorithm without --conservative: 'fast' (default), 'exact', 'conservative', 'r3'"},
    {"--nodata", "", "POLICY",
     "Voids: 'transparent' (default: never block; a hidden box meeting one is undetermined) or 'fill:H' "
     "(terrain at H metres)"},
    {"--curvature", "", "C", "Curvature/refraction coefficient as GDAL's (default 0.85714; 0 disables)"},
    {"--threads", "", "N", "Worker threads (default 0 = all cores)"},
    {"--band", "", "N", "DEM band to read, 1-based (required when the file has several)"},
    {"--json", "", "", "Print a JSON document with every box"},
    remote::kServerFlag,
    remote::kDeadlineFlag,
    remote::kCaFlag,
    remote::kClientCertFlag,
    remote::kTokenFileFlag,
};

constexpr std::string_view kAlgorithms[] = {"fast", "exact", "conservative", "r3"};

int run_cull(const Args& args) {
  const std::string& path = single_operand(args, "DEM");
  const bool json = args.has("--json");
  geodesy::PointSpec observer = point_from_flags(args, {"--observer", "--lat", "--lon"});
  if (args.has("--height") && args.has("--altitude"))
    throw UsageError("--height and --altitude both set the eye; give one of them");
  if (auto altitude = args.number("--altitude")) {
    observer.height = *altitude;
    observer.height_mode = geodesy::HeightMode::kAbsolute;
  } else {
    observer.height = args.non_negative("--height").value_or(2.0);
  }
  visibility::CullOptions options;
  options.conservative = args.has("--conservative");
  if (auto a = args.choice("--algorithm", kAlgorithms)) options.viewshed.algorithm = *visibility::parse_algorithm(*a);
  options.viewshed.curvature_coefficient = args.non_negative("--curvature").value_or(0.85714);
  options.viewshed.threads = args.non_negative_integer("--threads").value_or(0);
  if (auto policy = args.text("--nodata"))
    options.viewshed.nodata = parse_nodata(*policy, options.viewshed.nodata_fill_height);
  throw_if_invalid_option(visibility::validate_options(options.viewshed));
  (void)args.positive_integer("--band");
  const auto boxes_path = args.text("--boxes");
  if (!boxes_path) throw UsageError("missing --boxes FILE.csv");
  std::vector<std::uint64_t> ids;
  const std::vector<visibility::BoxSpec> boxes = read_boxes_file(*boxes_path, args.has("--lonlat"), &ids);

  if (args.has("--server")) return remote::run_cull(args, path, observer, boxes, ids, options, json);

  const auto started = std::chrono::steady_clock::now();
  auto dem = load_dem(path, args);
  if (!dem.ok()) return report_error(dem.error());
  auto eye = geodesy::resolve_point(*dem, observer, "observer");
  if (!eye.ok()) return report_error(eye.error());
  InterruptScope interrupt;
  RunControl control;
  control.cancel = &interrupt.token();
  auto result = visibility::cull_boxes(*dem, *eye, boxes, options, &control);
  if (!result.ok()) return report_error(result.error());

  CullReport report;
  report.dem = path;
  report.boxes_path = *boxes_path;
  report.observer = *eye;
  report.observer_lonlat = lonlat_of(*dem, eye->x, eye->y);
  report.geographic = is_geographic(*dem);
  report.conservative = options.conservative;
  report.result = std::move(*result);
  report.ids = std::move(ids);
  report.total_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  print_cull(report, boxes, json);
  return kExitOk;
}

}  // namespace

void print_cull(const CullReport& report, const std::vector<visibility::BoxSpec>& boxes, bool json) {
  const visibility::CullResult& r = report.result;
  std::size_t counts[4] = {};  // by visibility::Visibility
  for (const visibility::BoxVisibility& b : r.boxes) ++counts[static_cast<int>(b.state)];
  const auto count = [&](visibility::Visibility v) { return counts[static_cast<int>(v)]; };
  if (json) {
    Json j;
    j["dem"] = report.dem;
    j["boxes_file"] = report.boxes_path;
    j["observer"] = to_json(report.observer, report.observer_lonlat);
    j["algorithm"] = std::string(visibility::algorithm_name(r.algorithm));
    j["conservative"] = report.conservative;
    j["box_count"] = r.boxes.size();
    j["visible_count"] = r.visible_count;
    j["hidden_count"] = count(visibility::Visibility::kOccluded);
    j["undetermined_count"] = count(visibility::Visibility::kUndetermined);
    j["out_of_range_count"] = count(visibility::Visibility::kOutOfRange);
    j["window"] = to_json(r.window);
    j["stats"] = to_json(r.stats);
    j["pyramid_cells_read"] = r.pyramid_cells_read;
    Json list = Json::array();
    for (std::size_t i = 0; i < r.boxes.size(); ++i) {
      const visibility::BoxVisibility& b = r.boxes[i];
      Json box = {{"visible", visibility::may_be_seen(b.state)},
                  {"state", std::string(visibility::visibility_name(b.state))},
                  {"ohf_min", finite_or_null(b.ohf_min)}};
      if (!report.ids.empty()) box["id"] = report.ids[i];
      list.push_back(std::move(box));
    }
    j["boxes"] = std::move(list);
    j["total_seconds"] = report.total_seconds;
    print_json(j);
    return;
  }
  std::cout << "Culling over " << report.dem << (report.where.empty() ? "" : " " + report.where) << '\n'
            << "  observer:   x " << coordinate(report.observer.x, report.geographic) << ", y "
            << coordinate(report.observer.y, report.geographic) << ", eye " << fixed(report.observer.elevation, 1)
            << " m\n"
            << "  boxes:      " << with_separators(r.boxes.size()) << " from " << report.boxes_path << ": "
            << with_separators(count(visibility::Visibility::kSeen)) << " visible, "
            << with_separators(count(visibility::Visibility::kOccluded)) << " hidden, "
            << with_separators(count(visibility::Visibility::kUndetermined)) << " undetermined (over voids), "
            << with_separators(count(visibility::Visibility::kOutOfRange)) << " off the map\n"
            << "  algorithm:  " << visibility::algorithm_name(r.algorithm)
            << (report.conservative ? " (conservative: no visible box reported hidden)" : "") << '\n'
            << "  window:     " << r.window.width() << "x" << r.window.height() << " cells of "
            << with_separators(r.stats.dem_cells) << " (out to the farthest box)\n"
            << "  pyramid:    " << with_separators(r.pyramid_cells_read) << " cells read for all boxes\n"
            << "  compute:    " << fixed(r.stats.seconds, 3) << " s (" << fixed(report.total_seconds, 3)
            << " s in all)\n";
  for (std::size_t i = 0; i < r.boxes.size(); ++i) {
    const visibility::BoxVisibility& b = r.boxes[i];
    std::string state(visibility::visibility_name(b.state));
    state.resize(12, ' ');
    std::cout << "  " << (report.ids.empty() ? i : report.ids[i]) << "  " << state;
    if (b.state == visibility::Visibility::kOutOfRange) {
      std::cout << "  (footprint not wholly on the dataset)\n";
      continue;
    }
    std::cout << "  ohf_min " << (std::isfinite(b.ohf_min) ? fixed(b.ohf_min, 2) + " m" : std::string("none"));
    if (b.state == visibility::Visibility::kOccluded)
      std::cout << "  (" << fixed(b.ohf_min - boxes[i].z_max, 2) << " m short)";
    if (b.state == visibility::Visibility::kUndetermined)
      std::cout << (std::isfinite(b.ohf_min) ? "  (hidden where known; meets a void)" : "  (over voids only)");
    std::cout << '\n';
  }
}

const Command& cull_command() {
  static const Command command{
      "cull",
      "Cull object boxes: which of them an observer can see (any point at or above the OHF)",
      "horizon cull DEM (--observer X,Y | --lat LAT --lon LON) --boxes FILE.csv [options]",
      "Computes the occlusion height field (OHF) out to the farthest box and tests every\n"
      "box against it: a box is visible when some point of it is at or above the OHF\n"
      "over its footprint. Prints each box's state and the OHF's minimum over its\n"
      "footprint (so a hidden box shows by how much). --conservative guarantees no box\n"
      "the exact R3 rule sees is reported hidden.\n"
      "States: visible, hidden, undetermined (hidden where the OHF is known, but the\n"
      "footprint meets a transparent void: draw it), out_of_range (footprint not\n"
      "wholly on the dataset; the other boxes are still answered).",
      kFlags,
      "  horizon cull data/dem/rainier_summit_srtm3_400x400.tif --lat 46.85 --lon -121.76 \\\n"
      "      --boxes examples/rainier_boxes.csv --lonlat --conservative\n"
      "  horizon cull data/dem/ecuador_andes_utm17s_10m_383x415.tif --observer 713900,9558950 \\\n"
      "      --boxes examples/ecuador_boxes.csv\n"
      "  horizon cull rainier --server localhost:50051 --lat 46.75 --lon -121.6767 --boxes examples/rainier_boxes.csv "
      "\\\n"
      "      --lonlat --json\n",
      run_cull,
  };
  return command;
}

}  // namespace horizon::cli
