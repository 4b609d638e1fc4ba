// `horizon region DEM --from-box ...`: what is always visible, always hidden
// or undetermined from anywhere in a box of viewpoints.
#include <chrono>
#include <cmath>
#include <iostream>

#include "commands/command.hpp"
#include "horizon/evaluation/region_check.hpp"
#include "horizon/imageio/imageio.hpp"
#include "horizon/region/region.hpp"
#include "horizon/terrain/geotiff_writer.hpp"
#include "horizon/terrain/height_view.hpp"
#include "horizon/terrain/preview.hpp"
#include "horizon/terrain/qgis_style.hpp"
#include "horizon/visibility/viewshed_preview.hpp"
#include "inputs.hpp"
#include "interrupt.hpp"
#include "output.hpp"

namespace horizon::cli {
namespace {

constexpr FlagSpec kFlags[] = {
    {"--from-box", "", "XMIN,YMIN,XMAX,YMAX", "The region of viewpoints: a rectangle in the DEM's CRS"},
    {"--from-path", "", "X0,Y0,X1,Y1",
     "Or the rectangle a box sweeps moving from (X0,Y0) to (X1,Y1) (with --half-size)"},
    {"--half-size", "", "M", "Half the side of the box swept along --from-path, CRS units (default 0)"},
    {"--lonlat", "", "", "The region's (and the boxes') x/y are WGS84 longitude/latitude"},
    {"--heights", "", "ZMIN,ZMAX", "Viewpoint heights above the ground, metres (default 2,2)"},
    {"--altitudes", "", "ZMIN,ZMAX", "Viewpoint altitudes, absolute metres (instead of --heights)"},
    {"--out", "-o", "OUT.tif",
     "Write the three-valued raster: 0 always hidden, 1 always visible, 2 undetermined, 255 none"},
    {"--png", "", "PREVIEW.png",
     "Also write a PNG preview: blue always visible, vermillion always hidden, yellow undetermined over a hillshade, "
     "the region's box, a legend, scale bar and north arrow"},
    {"--boxes", "", "FILE.csv",
     "Classify object boxes instead: x_min,y_min,x_max,y_max,z_min,z_max a line (absolute metres)"},
    {"--max-distance", "", "M", "Answer only cells within M ground metres of the region (default: the whole DEM)"},
    {"--target-height", "", "M", "Target height above each cell, metres (default 0)"},
    {"--curvature", "", "C", "Curvature/refraction coefficient as GDAL's (default 0.85714; 0 disables)"},
    {"--face-resolution", "", "N", "Fuzzy-array columns per cube face (default 1024)"},
    {"--visible-budget", "", "N", "Pyramid cells one always-visible test may read (default 4096)"},
    {"--splits", "", "N", "Answer the footprint as N x N pieces and intersect their verdicts (default 2)"},
    {"--check", "", "N",
     "Also check the verdicts with exact R3 from the corners, edge midpoints, 8 points a face and N interior "
     "points of the region (up to 4000 cells)"},
    {"--threads", "", "N", "Worker threads (default 0 = all cores)"},
    {"--band", "", "N", "DEM band to read, 1-based (required when the file has several)"},
    {"--json", "", "", "Print a JSON document"},
};

std::vector<double> numbers(const Args& args, std::string_view flag, std::size_t count) {
  const auto text = args.text(flag);
  if (!text) return {};
  const CsvNumbers n = parse_csv_numbers(*text);
  if (n.blank || !n.numeric || n.values.size() != count)
    throw UsageError(std::string(flag) + ": expected " + std::to_string(count) + " comma-separated numbers, got '" +
                     *text + "'");
  return n.values;
}

region::RegionSpec region_from_flags(const Args& args) {
  if (args.has("--from-box") == args.has("--from-path"))
    throw UsageError("give the region as one of --from-box XMIN,YMIN,XMAX,YMAX or --from-path X0,Y0,X1,Y1");
  if (args.has("--heights") && args.has("--altitudes"))
    throw UsageError("--heights and --altitudes both set the viewpoints' heights; give one of them");
  std::vector<double> z = numbers(args, args.has("--altitudes") ? "--altitudes" : "--heights", 2);
  if (z.empty()) z = {2.0, 2.0};
  if (z[1] < z[0]) throw UsageError("--heights/--altitudes: ZMAX is below ZMIN");
  const auto mode = args.has("--altitudes") ? geodesy::HeightMode::kAbsolute : geodesy::HeightMode::kAboveGround;
  region::RegionSpec s;
  if (args.has("--from-box")) {
    const std::vector<double> b = numbers(args, "--from-box", 4);
    if (b[2] < b[0] || b[3] < b[1]) throw UsageError("--from-box: XMAX or YMAX is below XMIN or YMIN");
    s = {.x_min = b[0], .y_min = b[1], .x_max = b[2], .y_max = b[3], .z_min = z[0], .z_max = z[1], .height_mode = mode};
  } else {
    const std::vector<double> p = numbers(args, "--from-path", 4);
    const double half = args.non_negative("--half-size").value_or(0.0);
    s = region::swept_region(p[0], p[1], p[2], p[3], half, half, z[0], z[1], mode);
  }
  if (args.has("--half-size") && !args.has("--from-path")) throw UsageError("--half-size goes with --from-path");
  s.frame = args.has("--lonlat") ? geodesy::PointFrame::kWgs84 : geodesy::PointFrame::kDatasetCrs;
  return s;
}

Json stats_json(const region::RegionStats& s) {
  return {{"items", s.items},
          {"always_hidden", s.always_hidden},
          {"always_visible", s.always_visible},
          {"undetermined", s.undetermined},
          {"walls_swept", s.walls_swept},
          {"wall_nodes_read", s.wall_nodes_read},
          {"pyramid_cells_read", s.pyramid_cells_read},
          {"seconds", s.seconds}};
}

Json check_json(const evaluation::RegionCheck& c) {
  return {{"viewpoints", c.viewpoints},
          {"items_checked", c.items_checked},
          {"hidden_checked", c.hidden_checked},
          {"visible_checked", c.visible_checked},
          {"wrong_hidden", c.wrong_hidden},
          {"wrong_visible", c.wrong_visible},
          {"sampled_hidden", c.sampled_hidden},
          {"sampled_visible", c.sampled_visible},
          {"seconds", c.seconds}};
}

void print_check(const Json& c) {
  std::cout << "  R3 check:       " << c["items_checked"].get<std::uint64_t>() << " items x "
            << c["viewpoints"].get<std::uint64_t>() << " viewpoints: " << c["wrong_hidden"].get<std::uint64_t>()
            << " wrong hidden, " << c["wrong_visible"].get<std::uint64_t>() << " wrong visible; decided "
            << c["hidden_checked"].get<std::uint64_t>() << " of " << c["sampled_hidden"].get<std::uint64_t>()
            << " hidden from every sample, " << c["visible_checked"].get<std::uint64_t>() << " of "
            << c["sampled_visible"].get<std::uint64_t>() << " visible from every sample\n";
}

std::string share(std::uint64_t n, std::uint64_t of) {
  return with_separators(n) + " (" + fixed(of ? 100.0 * n / of : 0.0, 1) + " %)";
}

void print_summary(const std::string& dem, const region::RegionFrame& f, const region::RegionStats& s,
                   const std::string& what) {
  std::cout << "From-region visibility over " << dem << '\n'
            << "  region:         grid columns " << fixed(f.col_min, 1) << ".." << fixed(f.col_max, 1) << ", rows "
            << fixed(f.row_min, 1) << ".." << fixed(f.row_max, 1) << ", " << fixed(f.z_min, 1) << ".."
            << fixed(f.z_max, 1) << " m\n"
            << "  " << what << with_separators(s.items) << '\n'
            << "  always visible: " << share(s.always_visible, s.items) << '\n'
            << "  always hidden:  " << share(s.always_hidden, s.items) << '\n'
            << "  undetermined:   " << share(s.undetermined, s.items) << '\n'
            << "  work:           " << with_separators(s.walls_swept) << " walls swept ("
            << with_separators(s.wall_nodes_read) << " nodes), " << with_separators(s.pyramid_cells_read)
            << " pyramid cells read\n"
            << "  compute:        " << fixed(s.seconds, 3) << " s\n";
}

int run_region(const Args& args) {
  const std::string& path = single_operand(args, "DEM");
  const bool json = args.has("--json");
  const region::RegionSpec spec = region_from_flags(args);
  region::RegionOptions o;
  if (auto m = args.number("--max-distance")) o.max_distance = *m;
  o.target_height = args.non_negative("--target-height").value_or(0.0);
  o.curvature_coefficient = args.non_negative("--curvature").value_or(0.85714);
  if (auto n = args.positive_integer("--face-resolution")) o.face_resolution = *n;
  if (auto n = args.positive_integer("--visible-budget")) o.visible_test_budget = *n;
  if (auto n = args.positive_integer("--splits")) o.footprint_splits = *n;
  const auto check_points = args.non_negative_integer("--check");
  o.threads = args.non_negative_integer("--threads").value_or(0);
  (void)args.positive_integer("--band");
  throw_if_invalid_option(region::validate_region_options(o));
  const auto boxes_path = args.text("--boxes");
  const auto out = args.text("--out");
  const auto png = args.text("--png");
  if (boxes_path && (out || png)) throw UsageError("--boxes classifies boxes; -o and --png are for the raster answer");
  if (!boxes_path && !out) throw UsageError("missing -o OUT.tif (or --boxes FILE.csv)");
  if (out) {
    if (auto s = check_output_path(*out, "-o", path, {".tif", ".tiff"}); !s.ok()) return report_error(s.error());
  }
  if (png) {
    if (out && same_file(*png, *out)) throw UsageError("--png: '" + *png + "' is also the -o output");
    if (auto s = check_output_path(*png, "--png", path, {".png"}); !s.ok()) return report_error(s.error());
    if (auto plugin = imageio::plugin_path(); !plugin.ok()) return report_error(plugin.error());
  }
  std::vector<visibility::BoxSpec> boxes;
  if (boxes_path) boxes = read_boxes_file(*boxes_path, args.has("--lonlat"));

  auto dem = load_dem(path, args);
  if (!dem.ok()) return report_error(dem.error());
  InterruptScope interrupt;
  RunControl control;
  control.cancel = &interrupt.token();

  if (boxes_path) {
    auto res = region::classify_boxes(*dem, spec, boxes, o, &control);
    if (!res.ok()) return report_error(res.error());
    Json checked;
    if (check_points) {
      const auto viewpoints =
          evaluation::sample_region(*dem, spec, res->frame, {8, static_cast<int>(*check_points), 1});
      checked = check_json(evaluation::check_boxes(*dem, *res, boxes, o, viewpoints, o.threads));
    }
    if (json) {
      Json list = Json::array();
      for (region::Verdict v : res->verdicts) list.push_back(std::string(region::verdict_name(v)));
      Json j{{"dem", path}, {"boxes_file", *boxes_path}, {"stats", stats_json(res->stats)}, {"boxes", list}};
      if (check_points) j["check"] = checked;
      print_json(j);
      return kExitOk;
    }
    print_summary(path, res->frame, res->stats, "boxes:          ");
    if (check_points) print_check(checked);
    for (std::size_t i = 0; i < res->verdicts.size(); ++i)
      std::cout << "  " << i << "  " << region::verdict_name(res->verdicts[i]) << '\n';
    return kExitOk;
  }

  auto res = region::classify_cells(*dem, spec, o, &control);
  if (!res.ok()) return report_error(res.error());
  const terrain::Window& w = res->window;
  terrain::Georeference georef = dem->georef;
  georef.transform = georef.transform.shifted(w.col0, w.row0);
  const auto write_codes = [&] {
    return terrain::write_geotiff(*out, res->codes, georef, double{region::kNoAnswer}, visibility::code_colour_table());
  };
  if (auto s = terrain::write_with_style(*out, visibility::region_style(), write_codes); !s.ok())
    return report_error(s.error());
  double preview_seconds = 0.0;
  if (png) {
    const auto drawing = std::chrono::steady_clock::now();
    const terrain::Grid<float> elevation = terrain::copy_cells(terrain::HeightView(dem->elevation).sub(w));
    const region::RegionFrame& f = res->frame;
    terrain::PreviewOptions p;
    p.metres_per_col = f.metres_per_col;
    p.metres_per_row = f.metres_per_row;
    p.region = terrain::PreviewRect{f.col_min - w.col0, f.row_min - w.row0, f.col_max - w.col0, f.row_max - w.row0};
    p.classes = {.visible = "always visible (from the whole region)",
                 .hidden = "always hidden",
                 .undetermined = "undetermined",
                 .beyond = "beyond reach: not computed"};
    const bool above = spec.height_mode == geodesy::HeightMode::kAboveGround;
    p.title = {"From-region visibility over " + visibility::dem_label(path),
               "Viewpoints anywhere in the box " +
                   (spec.frame == geodesy::PointFrame::kWgs84
                        ? "lon " + fixed(spec.x_min, 5) + " to " + fixed(spec.x_max, 5) + ", lat " +
                              fixed(spec.y_min, 5) + " to " + fixed(spec.y_max, 5)
                        : "x " + fixed(spec.x_min, 1) + " to " + fixed(spec.x_max, 1) + ", y " + fixed(spec.y_min, 1) +
                              " to " + fixed(spec.y_max, 1)) +
                   "; " + fixed(spec.z_min, 1) + " to " + fixed(spec.z_max, 1) +
                   (above ? " m above the ground" : " m altitude") + "; targets " + fixed(o.target_height, 1) +
                   " m above the ground; reach " +
                   (std::isfinite(o.max_distance) ? fixed(o.max_distance / 1000.0, 2) + " km" : "the whole DEM")};
    if (auto s = terrain::write_viewshed_preview(*png, elevation, res->codes, p); !s.ok())
      return report_error(s.error());
    preview_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - drawing).count();
  }
  Json checked;
  if (check_points) {
    const auto viewpoints = evaluation::sample_region(*dem, spec, res->frame, {8, static_cast<int>(*check_points), 1});
    checked = check_json(evaluation::check_cells(*dem, *res, o, viewpoints, 4000, o.threads));
  }
  if (json) {
    Json j{{"dem", path},
           {"output", *out},
           {"style", terrain::qml_path_for(*out)},
           {"window", to_json(w)},
           {"stats", stats_json(res->stats)}};
    j["preview_seconds"] = png ? Json(preview_seconds) : Json(nullptr);
    if (check_points) j["check"] = checked;
    print_json(j);
    return kExitOk;
  }
  print_summary(path, res->frame, res->stats, "cells answered: ");
  if (check_points) print_check(checked);
  std::cout << "  wrote:          " << *out << ", its QGIS style " << terrain::qml_path_for(*out) << '\n';
  if (png) std::cout << "  preview:        " << *png << " (" << fixed(preview_seconds, 3) << " s)\n";
  return kExitOk;
}

}  // namespace

const Command& region_command() {
  static const Command command{
      "region",
      "From-region visibility: what is always visible, always hidden or undetermined from a box of viewpoints",
      "horizon region DEM (--from-box XMIN,YMIN,XMAX,YMAX | --from-path X0,Y0,X1,Y1 --half-size M) "
      "(-o OUT.tif | --boxes FILE.csv) [options]",
      "Classifies every DEM cell's target (or each object box) against every viewpoint\n"
      "of the region at once: always visible (seen from all of it), always hidden (from\n"
      "none of it), or undetermined. Both verdicts are sound against the exact R3 line\n"
      "of sight: a viewpoint anywhere in the region never contradicts them. Only the\n"
      "undetermined items need per-viewpoint work. --from-path takes the box a moving\n"
      "viewer of half-size M sweeps (its bounding rectangle).",
      kFlags,
      "  horizon region data/dem/ecuador_andes_utm17s_10m_383x415.tif \\\n"
      "      --from-box 713800,9558900,713950,9559000 --heights 2,30 -o region.tif --png region.png\n"
      "  horizon region data/dem/ecuador_andes_utm17s_10m_383x415.tif --from-path 713700,9558800,714100,9559100 \\\n"
      "      --half-size 20 --boxes examples/ecuador_boxes.csv --json\n",
      run_region,
  };
  return command;
}

}  // namespace horizon::cli
