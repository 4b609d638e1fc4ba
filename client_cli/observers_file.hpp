// observers_file.hpp — the --observers file of `horizon viewshed`: many
// observers, each with its own eye height and reach, as CSV or GeoJSON.
//
// CSV (any extension but .geojson/.json): one observer a line,
//   x,y[,height[,max_distance]]
// in the DEM's CRS, or longitude,latitude in WGS84 degrees when the header
// (an optional first line that is not numbers) starts with "lon" or
// "longitude". Blank lines and '#' comments are skipped. height is metres
// above the ground (absolute altitudes when the command says so: `mode`);
// max_distance ground metres, > 0.
//
// GeoJSON (.geojson, .json): a FeatureCollection of Point features,
// coordinates [longitude, latitude] in WGS84 (RFC 7946; a third coordinate
// is ignored), properties "height" and "max_distance" (numbers, optional)
// and "name" (or "id") naming the observer in the summary table.
//
// Absent values take the command's --height / --max-distance. Every
// mistake is a UsageError naming the file and the line or feature.
#pragma once

#include <string>
#include <vector>

#include "horizon/visibility/many_observers.hpp"

namespace horizon::cli {

struct NamedObserver {
  visibility::ObserverSite site;
  std::string name;  // from the file, or "line 12" / "feature 3"
};

// `height` / `mode` / `max_distance` (0: the shared reach) fill what a line
// or feature leaves out.
std::vector<NamedObserver> read_observers_file(const std::string& path, double height, geodesy::HeightMode mode,
                                               double max_distance);

}  // namespace horizon::cli
