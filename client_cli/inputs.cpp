#include "inputs.hpp"

#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "horizon/terrain/dem_reader.hpp"

namespace horizon::cli {
namespace fs = std::filesystem;

Result<terrain::Dem> load_dem(const std::string& path, const Args& args, bool allow_missing_crs) {
  terrain::ReadOptions options;
  options.band = args.positive_integer("--band").value_or(0);
  options.allow_missing_crs = allow_missing_crs;
  return terrain::read_dem(path, options);
}

geodesy::PointSpec point_from_flags(const Args& args, const PointFlags& flags) {
  const bool has_xy = args.has(flags.xy);
  const bool has_lat = args.has(flags.lat);
  const bool has_lon = args.has(flags.lon);
  const std::string xy(flags.xy), lat(flags.lat), lon(flags.lon);
  if (has_xy && (has_lat || has_lon))
    throw UsageError(xy + " and " + lat + "/" + lon + " both place the point; give one of them");
  if (has_lat != has_lon) throw UsageError((has_lat ? lon : lat) + ": required with " + (has_lat ? lat : lon));
  if (!has_xy && !has_lat) throw UsageError("missing " + xy + " X,Y (or " + lat + " and " + lon + ")");

  geodesy::PointSpec spec;
  if (has_xy) {
    const auto [x, y] = *args.pair(flags.xy);
    spec.frame = geodesy::PointFrame::kDatasetCrs;
    spec.x = x;
    spec.y = y;
  } else {
    spec.frame = geodesy::PointFrame::kWgs84;
    spec.y = *args.number(flags.lat);
    spec.x = *args.number(flags.lon);
    if (std::abs(spec.y) > 90.0)
      throw UsageError(lat + ": expected a latitude in [-90, 90], got '" + *args.text(flags.lat) + "'");
  }
  return spec;
}

bool same_file(const std::string& a, const std::string& b) {
  std::error_code ec;
  if (fs::exists(a, ec) && fs::exists(b, ec)) return fs::equivalent(a, b, ec);
  return fs::weakly_canonical(fs::absolute(a, ec), ec) == fs::weakly_canonical(fs::absolute(b, ec), ec);
}

Status check_output_path(const std::string& path, std::string_view flag, const std::string& dem_path,
                         std::initializer_list<std::string_view> extensions) {
  const std::string name(flag);
  if (path.empty()) throw UsageError(name + ": expected a file name, got ''");
  std::error_code ec;
  if (fs::is_directory(path, ec)) throw UsageError(name + ": '" + path + "' is a directory; give a file name");
  if (same_file(path, dem_path)) throw UsageError(name + ": '" + path + "' is the input DEM; refusing to overwrite it");

  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (std::find(extensions.begin(), extensions.end(), ext) == extensions.end()) {
    std::string list;
    for (std::string_view e : extensions) {
      if (!list.empty()) list += " or ";
      list += e;
    }
    throw UsageError(name + ": expected a file name ending in " + list + ", got '" + path + "'");
  }

  fs::path dir = fs::path(path).parent_path();
  if (dir.empty()) dir = ".";
  if (!fs::is_directory(dir, ec))
    return make_error(ErrorCode::kNotFound, name + " '" + path + "': directory '" + dir.string() + "' does not exist",
                      name);
  if (::access(dir.c_str(), W_OK) != 0)
    return make_error(ErrorCode::kIoError, name + " '" + path + "': directory '" + dir.string() + "' is not writable",
                      name);
  return Status::Ok();
}

std::string flag_for_field(std::string_view field) {
  if (field == "curvature_coefficient") return "--curvature";
  if (field == "nodata_fill_height") return "--nodata";
  if (field == "visible_test_budget") return "--visible-budget";  // horizon region
  if (field == "footprint_splits") return "--splits";
  if (field == "azimuth_start" || field == "azimuth_end") return "--azimuth";  // horizon viewshed
  if (field == "pitch_min" || field == "pitch_max") return "--pitch";
  if (field == "visible_value") return "--visible-value";
  std::string flag = "--" + std::string(field);
  std::replace(flag.begin(), flag.end(), '_', '-');
  return flag;
}

void throw_if_invalid_option(const Status& status, const Args* args) {
  if (status.ok()) return;
  const Error& error = status.error();
  if (error.field.empty()) throw UsageError(error.message);
  std::string message = error.message;
  // Engine messages read "<field>: <what>"; say the flag instead.
  if (const std::string prefix = error.field + ": "; message.starts_with(prefix)) message.erase(0, prefix.size());
  const std::string flag = flag_for_field(error.field);
  throw UsageError((args ? args->typed(flag) : flag) + ": " + message);
}

bool is_geographic(const terrain::Dem& dem) {
  return is_geographic(dem.georef);
}

bool is_geographic(const terrain::Georeference& georef) {
  if (!georef.has_crs()) return false;
  auto crs = geodesy::Crs::of(georef);
  return crs.ok() && crs->is_geographic();
}

std::optional<geodesy::LonLat> lonlat_of(const terrain::Dem& dem, double x, double y) {
  return lonlat_of(dem.georef, x, y);
}

std::optional<geodesy::LonLat> lonlat_of(const terrain::Georeference& georef, double x, double y) {
  if (!georef.has_crs()) return std::nullopt;
  auto crs = geodesy::Crs::of(georef);
  if (!crs.ok()) return std::nullopt;
  auto ll = crs->to_lonlat({x, y});
  if (!ll.ok()) return std::nullopt;
  return *ll;
}

CsvNumbers parse_csv_numbers(std::string line) {
  CsvNumbers out;
  if (const auto hash = line.find('#'); hash != std::string::npos) line.resize(hash);
  if (line.find_first_not_of(" \t\r") == std::string::npos) return out;
  out.blank = false;
  std::stringstream fields(line);
  std::string field;
  while (std::getline(fields, field, ',')) {
    const auto first = field.find_first_not_of(" \t\r"), last = field.find_last_not_of(" \t\r");
    const auto value = first == std::string::npos ? std::nullopt : parse_finite(field.substr(first, last - first + 1));
    if (!value) {
      out.numeric = false;
      out.values.clear();
      return out;
    }
    out.values.push_back(*value);
  }
  return out;
}

std::vector<visibility::BoxSpec> read_boxes_file(const std::string& path, bool lonlat,
                                                 std::vector<std::uint64_t>* ids) {
  std::ifstream in(path);
  if (!in) throw UsageError("--boxes: cannot open '" + path + "'");
  std::vector<visibility::BoxSpec> boxes;
  std::string line;
  int number = 0;
  std::size_t columns = 0;  // 6, or 7 with ids; fixed by the first box
  while (std::getline(in, line)) {
    ++number;
    const CsvNumbers row = parse_csv_numbers(line);
    if (row.blank || (number == 1 && !row.numeric)) continue;  // a blank line, a comment, a header
    const std::string where = "--boxes: '" + path + "' line " + std::to_string(number);
    const std::size_t n = row.values.size();
    if (n != 6 && !(ids && n == 7))
      throw UsageError(where +
                       (ids ? ": expected six numbers x_min,y_min,x_max,y_max,z_min,z_max, or seven with an id first"
                            : ": expected six numbers x_min,y_min,x_max,y_max,z_min,z_max"));
    if (columns == 0) columns = n;
    if (n != columns)
      throw UsageError(where + ": " + std::to_string(n) + " numbers where the first box had " +
                       std::to_string(columns) + " (give every box an id, or none)");
    const double* v = row.values.data();
    if (n == 7) {
      if (!(v[0] >= 0 && v[0] <= 9007199254740992.0 && v[0] == std::floor(v[0])))
        throw UsageError(where + ": the id must be a whole number from 0 to 2^53, got " + std::to_string(v[0]));
      ids->push_back(static_cast<std::uint64_t>(v[0]));
      ++v;
    }
    boxes.push_back(
        {lonlat ? geodesy::PointFrame::kWgs84 : geodesy::PointFrame::kDatasetCrs, v[0], v[1], v[2], v[3], v[4], v[5]});
  }
  if (boxes.empty()) throw UsageError("--boxes: '" + path + "' holds no boxes");
  return boxes;
}

visibility::NodataPolicy parse_nodata(const std::string& text, double& fill_height) {
  if (text == "transparent") return visibility::NodataPolicy::kTransparent;
  if (text.starts_with("fill:")) {
    if (auto h = parse_finite(std::string_view(text).substr(5))) {
      fill_height = *h;
      return visibility::NodataPolicy::kFill;
    }
  }
  throw UsageError("--nodata: expected 'transparent' or 'fill:H' (H a finite number of metres), got '" + text + "'");
}

}  // namespace horizon::cli
