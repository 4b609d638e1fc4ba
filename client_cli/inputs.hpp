// inputs.hpp — command-line values shared by several commands, translated
// into engine terms: the DEM (with --band), points given as "X,Y" in the DEM's
// CRS or as WGS84 --lat/--lon, and output paths checked before any work.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "args.hpp"
#include "horizon/common/error.hpp"
#include "horizon/geodesy/crs.hpp"
#include "horizon/geodesy/observer.hpp"
#include "horizon/terrain/dem.hpp"
#include "horizon/visibility/cull.hpp"

namespace horizon::cli {

// Reads `path` with the band from --band (absent: the file's only band).
Result<terrain::Dem> load_dem(const std::string& path, const Args& args, bool allow_missing_crs = false);

// The flags that place one point: `xy` ("--observer", "X,Y" in the DEM's CRS)
// or both `lat` and `lon` (WGS84 degrees). Throws UsageError when neither or
// both forms are given, or only one of lat/lon.
struct PointFlags {
  std::string_view xy, lat, lon;
};
geodesy::PointSpec point_from_flags(const Args& args, const PointFlags& flags);

// Checks an output path before any computation: `flag` names it in messages.
// Usage errors (thrown): empty, a directory, the input DEM itself, a wrong
// extension (one of `extensions`, lower case, with the dot). Failures
// (returned, exit 1): the parent directory is missing or not writable.
Status check_output_path(const std::string& path, std::string_view flag, const std::string& dem_path,
                         std::initializer_list<std::string_view> extensions);

// True when a and b name the same file (existing or not).
bool same_file(const std::string& a, const std::string& b);

// The flag that sets an engine option field ("max_distance" -> "--max-distance").
// Used to turn validate_options() errors into usage errors.
std::string flag_for_field(std::string_view field);
// Throws UsageError for an invalid-argument Status from option validation,
// naming the flag (as the user typed it, when `args` is given: "-md" for
// --max-distance); does nothing for an ok Status.
void throw_if_invalid_option(const Status& status, const Args* args = nullptr);

// True when the DEM's CRS is geographic (coordinates in degrees).
bool is_geographic(const terrain::Dem& dem);
bool is_geographic(const terrain::Georeference& georef);

// WGS84 position of a CRS point, when the CRS supports it.
std::optional<geodesy::LonLat> lonlat_of(const terrain::Dem& dem, double x, double y);
std::optional<geodesy::LonLat> lonlat_of(const terrain::Georeference& georef, double x, double y);

// One line of a CSV file of numbers: blank (nothing but a '#' comment or
// spaces), or its comma-separated fields as finite numbers (numeric false
// and no values when one is not: a header, or a mistake).
struct CsvNumbers {
  bool blank = true;
  bool numeric = true;
  std::vector<double> values;
};
CsvNumbers parse_csv_numbers(std::string line);

// A boxes file for --boxes: one box a line, x_min,y_min,x_max,y_max,z_min,z_max
// (the DEM's CRS, or WGS84 degrees when `lonlat`; absolute metres). Blank
// lines, '#' comments and a first line that is not numbers (a header) are
// skipped. Throws UsageError naming the file and line.
// With `ids`, a line may hold seven numbers, an id first (a whole number
// from 0 to 2^53, the client's name for the box, echoed in answers), and
// *ids receives them; every box has one, or none does.
std::vector<visibility::BoxSpec> read_boxes_file(const std::string& path, bool lonlat,
                                                 std::vector<std::uint64_t>* ids = nullptr);

// --nodata: "transparent" (voids never block) or "fill:H" (terrain at H
// metres, stored in fill_height). Throws UsageError otherwise.
visibility::NodataPolicy parse_nodata(const std::string& text, double& fill_height);

}  // namespace horizon::cli
