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

#include <cstdint>
#include <optional>
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

// The engine and the daemon name a site "observers[3]"; the user knows it
// by its flag or file line. When `where` (an error's field, or a daemon's
// message) names observers[i], returns "observer i+1 (NAME): " + message;
// otherwise message unchanged.
std::string in_user_words(const std::string& where, const std::string& message,
                          const std::vector<NamedObserver>& observers);

// One line of the --summary table: an observer as resolved and what it saw.
struct ObserverLine {
  std::string name;
  double x = 0, y = 0;                 // the DEM's CRS
  std::optional<double> lon, lat;      // WGS84, when the CRS converts
  double ground = 0, eye = 0;          // metres
  std::optional<double> max_distance;  // ground metres; none: unbounded
  std::uint64_t cells_answered = 0, cells_visible = 0;
  double visible_km2 = 0, seconds = 0;
};

// The --summary CSV, one line an observer in order (observer,name,x,y,lon,
// lat,ground_m,eye_m,max_distance_m,cells_answered,cells_visible,
// visible_km2,visible_percent,seconds), written whole to a temporary and
// renamed; `geographic` prints x,y as degrees.
Status write_observer_summary(const std::string& path, const std::vector<ObserverLine>& lines, bool geographic);

}  // namespace horizon::cli
