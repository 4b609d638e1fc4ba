// viewshed_flags.hpp — the flags of `horizon viewshed` that one observer and
// many share, read into engine terms: what is seen (target height, reach,
// curvature or refraction, voids, algorithm, field of view), how the eyes
// stand on the ground, and how the GeoTIFF is laid out. The flag table
// (viewshed.cpp) gives gdal_viewshed's spellings as aliases, so every
// message names the flag as the user typed it.
#pragma once

#include <string>
#include <vector>

#include "args.hpp"
#include "horizon/geodesy/observer.hpp"
#include "horizon/terrain/geotiff_options.hpp"
#include "horizon/visibility/options.hpp"

namespace horizon::cli {

// --target-height, --max-distance (0 or "none": no limit, as GDAL's -md 0),
// --curvature or --refraction (GRASS's coefficient: curvature = 1 - it),
// --nodata, --ray-spacing, --threads, --azimuth START,END, --min-distance,
// --pitch MIN,MAX. Throws UsageError. The algorithm is the caller's.
visibility::ViewshedOptions shared_viewshed_options(const Args& args);

// --observer-ground: how an eye's height above the ground stands on it.
geodesy::GroundSample observer_ground(const Args& args);

// --format (GTiff or COG) and every --co NAME=VALUE, as the writer takes
// them; the items as typed go to a daemon with --server.
struct GeoTiffFlags {
  terrain::GeoTiffOptions options;
  std::vector<std::string> creation_options;
};
GeoTiffFlags geotiff_flags(const Args& args);

// One observer's place from --observer X,Y, --lat/--lon, or gdal_viewshed's
// -ox X -oy Y (--observer-x, --observer-y).
geodesy::PointSpec observer_point(const Args& args);

}  // namespace horizon::cli
