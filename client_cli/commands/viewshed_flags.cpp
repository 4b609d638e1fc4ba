// The shared viewshed flags (viewshed_flags.hpp).
#include "commands/viewshed_flags.hpp"

#include <cmath>
#include <limits>

#include "inputs.hpp"

namespace horizon::cli {
namespace {

constexpr std::string_view kGrounds[] = {"bilinear", "cell"};

// --max-distance: metres, or 0 / "none" for no limit.
double max_distance(const Args& args) {
  const auto text = args.text("--max-distance");
  if (!text) return std::numeric_limits<double>::infinity();
  if (*text == "none") return std::numeric_limits<double>::infinity();
  const auto v = parse_finite(*text);
  if (!v || *v < 0)
    throw UsageError(args.typed("--max-distance") + ": expected metres >= 0, or 0 or 'none' for no limit, got '" +
                     *text + "'");
  return *v == 0.0 ? std::numeric_limits<double>::infinity() : *v;
}

}  // namespace

visibility::ViewshedOptions shared_viewshed_options(const Args& args) {
  visibility::ViewshedOptions o;
  o.target_height = args.non_negative("--target-height").value_or(0.0);
  o.max_distance = max_distance(args);
  if (args.has("--curvature") && args.has("--refraction"))
    throw UsageError(args.typed("--curvature") +
                     " and --refraction both set the bending of sight lines; give one (curvature = 1 - refraction)");
  o.curvature_coefficient = args.non_negative("--curvature").value_or(o.curvature_coefficient);
  if (auto k = args.number("--refraction")) {
    if (*k < -1 || *k > 1)
      throw UsageError(
          "--refraction: expected GRASS's refraction coefficient in [-1, 1] (0.14286 for visible "
          "light, 1 for a flat earth), got '" +
          *args.text("--refraction") + "'");
    o.curvature_coefficient = visibility::curvature_from_refraction(*k);
  }
  if (auto policy = args.text("--nodata")) o.nodata = parse_nodata(*policy, o.nodata_fill_height);
  if (auto spacing = args.non_negative("--ray-spacing")) o.radial.ray_spacing = *spacing;
  o.threads = args.non_negative_integer("--threads").value_or(0);
  visibility::FieldOfView& view = o.field_of_view;
  if (auto azimuth = args.pair("--azimuth")) {
    view.azimuth_start = azimuth->first;
    view.azimuth_end = azimuth->second;
  }
  view.min_distance = args.non_negative("--min-distance").value_or(0.0);
  if (view.min_distance > 0 && !(view.min_distance < o.max_distance))
    throw UsageError(args.typed("--min-distance") + ": must be below " + args.typed("--max-distance") + " (" +
                     *args.text("--max-distance") + " m), got '" + *args.text("--min-distance") + "'");
  if (auto pitch = args.pair("--pitch")) {
    if (pitch->first > pitch->second)
      throw UsageError(args.typed("--pitch") + ": expected MIN,MAX with MIN <= MAX, got '" + *args.text("--pitch") +
                       "'");
    view.pitch_min = pitch->first;
    view.pitch_max = pitch->second;
  }
  // The ranges (azimuths in [0, 360], pitches in [-90, 90]) are the engine's: validate_options.
  return o;
}

geodesy::GroundSample observer_ground(const Args& args) {
  return args.choice("--observer-ground", kGrounds).value_or("bilinear") == "cell" ? geodesy::GroundSample::kCell
                                                                                   : geodesy::GroundSample::kBilinear;
}

GeoTiffFlags geotiff_flags(const Args& args) {
  GeoTiffFlags g;
  terrain::TiffFormat format = terrain::TiffFormat::kGTiff;
  if (auto name = args.text("--format")) {
    const auto parsed = terrain::parse_tiff_format(*name);
    if (!parsed) throw UsageError(args.typed("--format") + ": expected GTiff or COG, got '" + *name + "'");
    format = *parsed;
  }
  g.creation_options = args.all("--co");
  auto options = terrain::parse_creation_options(format, g.creation_options);
  if (!options.ok()) {
    // A codec missing from this libtiff is a failure of the build, not of the command line; both name -co.
    if (options.error().code != ErrorCode::kInvalidArgument) throw UsageError(options.error().message);
    throw UsageError(args.typed("--co") + " " + options.error().message);
  }
  g.options = *options;
  return g;
}

geodesy::PointSpec observer_point(const Args& args) {
  const bool has_x = args.has("--observer-x"), has_y = args.has("--observer-y");
  if (!has_x && !has_y) return point_from_flags(args, {"--observer", "--lat", "--lon"});
  if (has_x != has_y)
    throw UsageError(args.typed(has_x ? "--observer-y" : "--observer-x") + ": required with " +
                     args.typed(has_x ? "--observer-x" : "--observer-y"));
  for (std::string_view other : {"--observer", "--lat", "--lon"})
    if (args.has(other))
      throw UsageError(args.typed("--observer-x") + "/" + args.typed("--observer-y") + " and " + args.typed(other) +
                       " both place the observer; give one of them");
  geodesy::PointSpec spec;
  spec.frame = geodesy::PointFrame::kDatasetCrs;
  spec.x = *args.number("--observer-x");
  spec.y = *args.number("--observer-y");
  return spec;
}

}  // namespace horizon::cli
