// output.hpp — how results look: JSON documents (nlohmann, keys in the order
// written) and the number formats of the human-readable summaries.
//
// JSON conventions: lengths in metres, times in seconds, coordinates in the
// DEM's CRS plus "lon"/"lat" in WGS84 degrees where the CRS allows; a value
// that is not a finite number (no data, "no limit", "nothing blocks") is null.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "horizon/geodesy/crs.hpp"
#include "horizon/geodesy/observer.hpp"
#include "horizon/terrain/georef.hpp"
#include "horizon/terrain/grid.hpp"
#include "horizon/visibility/line_of_sight.hpp"
#include "horizon/visibility/options.hpp"
#include "horizon/visibility/viewshed_outputs.hpp"
#include "horizon/visibility/work_stats.hpp"

namespace horizon::cli {

using Json = nlohmann::ordered_json;

// Pretty-printed document plus newline on stdout.
void print_json(const Json& document);

// The number, or null when it is NaN or infinite.
Json finite_or_null(double value);

Json to_json(const terrain::GeoTransform& transform);  // GDAL order [x0, dx, 0, y0, 0, dy]
Json to_json(const terrain::Window& window);
// Includes "backend" ("cpu"/"gpu") and "gpu_fallback" (why the GPU asked for did not answer; null when it did).
Json to_json(const visibility::WorkStats& stats);
// A uint8 raster's codes: {"visible", "hidden", "out_of_range", "nodata"}.
Json to_json(const visibility::ValueCodes& codes);
Json to_json(const visibility::ProfileSample& sample);
// A resolved point: CRS x/y, lon/lat (when known), grid col/row, ground and point elevation.
Json to_json(const geodesy::GridPoint& point, const std::optional<geodesy::LonLat>& lonlat);
// A viewshed request's options as `horizon viewshed --json` echoes them
// (`nodata` as given on the command line).
Json viewshed_options_json(const geodesy::PointSpec& observer, const visibility::ViewshedOptions& options,
                           const std::string& nodata);

// A CRS in one phrase: "EPSG:32633 (WGS 84 / UTM zone 33N)", or for one
// without a code its name and "(user-defined)" ("user-defined" alone when
// it has no name).
std::string crs_name(const geodesy::Crs& crs);
// The summaries' CRS line: crs_name, then "geographic" or "projected
// (METHOD)", then the units: "..., projected (Transverse Mercator), units: metre".
std::string crs_label(const geodesy::Crs& crs);
// The vertical part of a compound CRS, "EPSG:5701 (ODN height)"; empty without one.
std::string heights_label(const geodesy::Crs& crs);
// `info --json`'s "crs": epsg (of the horizontal part; null without a code),
// name, geographic, units, unit_size (metres or degrees per unit),
// projection (null for geographic), vertical ({epsg, name}; null without
// one), compound_epsg (only when the whole compound CRS has a code), wkt.
Json to_json(const geodesy::Crs& crs);

// "1234567" -> "1,234,567".
std::string with_separators(std::uint64_t count);
// Fixed-point with `decimals` digits; "n/a" for NaN, "inf"/"-inf" for infinities.
std::string fixed(double value, int decimals);
// Coordinates: 7 decimals for degrees, 2 for metres.
std::string coordinate(double value, bool geographic);

}  // namespace horizon::cli
