// `horizon info DEM`: what a DEM holds and where it lies.
#include <algorithm>
#include <cmath>
#include <iostream>

#include "commands/command.hpp"
#include "inputs.hpp"
#include "output.hpp"
#include "remote/remote.hpp"

namespace horizon::cli {
namespace {

constexpr FlagSpec kFlags[] = {
    {"--band", "", "N", "Band to read, 1-based (required when the file has several)"},
    {"--json", "", "", "Print a JSON document instead of text"},
    remote::kServerFlag,
    remote::kDeadlineFlag,
    remote::kCaFlag,
    remote::kClientCertFlag,
    remote::kTokenFileFlag,
};

struct Extent {
  double x_min, x_max, y_min, y_max;
};

Extent extent_of(const terrain::Dem& dem) {
  const auto& t = dem.georef.transform;
  const double x0 = t.origin_x, x1 = t.origin_x + dem.width() * t.pixel_width;
  const double y0 = t.origin_y, y1 = t.origin_y + dem.height() * t.pixel_height;
  return {std::min(x0, x1), std::max(x0, x1), std::min(y0, y1), std::max(y0, y1)};
}

int run_info(const Args& args) {
  const std::string& path = single_operand(args, "DEM");
  const bool json = args.has("--json");
  // Checked before reading so a malformed --band is a usage error, not a read.
  (void)args.positive_integer("--band");
  if (args.has("--server")) return remote::run_info(args, path, json);  // DEM is a dataset name

  auto dem = load_dem(path, args, /*allow_missing_crs=*/true);
  if (!dem.ok()) return report_error(dem.error());

  const auto& t = dem->georef.transform;
  const Extent extent = extent_of(*dem);
  const terrain::ElevationStats stats = terrain::elevation_stats(dem->elevation);
  const std::uint64_t cells = dem->elevation.size();

  std::optional<geodesy::Crs> crs;
  if (dem->georef.has_crs()) {
    auto c = geodesy::Crs::of(dem->georef);
    if (!c.ok()) return report_error(c.error());
    crs = *c;
  }
  // A CRS the file names but Horizon cannot use: said, not hidden as "none".
  const std::string& unusable = dem->georef.crs_problem;
  geodesy::GroundScale scale;  // metres per CRS unit at the centre; 1 without a CRS
  std::optional<geodesy::LonLatBounds> bounds;
  if (crs) {
    scale = crs->ground_scale({(extent.x_min + extent.x_max) / 2, (extent.y_min + extent.y_max) / 2});
    bounds = geodesy::lonlat_bounds(*crs, extent.x_min, extent.y_min, extent.x_max, extent.y_max);
  }
  const double cell_x_m = std::abs(t.pixel_width) * scale.metres_per_x;
  const double cell_y_m = std::abs(t.pixel_height) * scale.metres_per_y;
  const bool geographic = crs && crs->is_geographic();

  if (json) {
    Json j;
    j["path"] = path;
    j["format"] = dem->format;
    j["width"] = dem->width();
    j["height"] = dem->height();
    j["cells"] = cells;
    j["crs"] = crs ? to_json(*crs) : Json(nullptr);
    j["crs_unusable"] = unusable.empty() ? Json(nullptr) : Json(unusable);
    j["geotransform"] = to_json(t);
    j["cell_size_m"] = {{"x", cell_x_m}, {"y", cell_y_m}};
    j["extent"] = {{"x_min", extent.x_min}, {"y_min", extent.y_min}, {"x_max", extent.x_max}, {"y_max", extent.y_max}};
    j["extent_lonlat"] =
        bounds
            ? Json{{"west", bounds->west}, {"south", bounds->south}, {"east", bounds->east}, {"north", bounds->north}}
            : Json(nullptr);
    j["nodata"] = dem->nodata ? finite_or_null(*dem->nodata) : Json(nullptr);
    j["elevation"] = stats.valid_cells ? Json{{"min", stats.min}, {"max", stats.max}} : Json(nullptr);
    j["valid_cells"] = stats.valid_cells;
    j["void_cells"] = stats.nodata_cells;
    print_json(j);
    return kExitOk;
  }

  std::cout << "File:        " << path << '\n'
            << "Format:      " << dem->format << '\n'
            << "Size:        " << dem->width() << " x " << dem->height() << " cells (" << with_separators(cells)
            << ")\n";
  if (crs) {
    std::cout << "CRS:         " << crs_label(*crs) << '\n';
    if (crs->is_compound())
      std::cout << "Heights:     " << heights_label(*crs) << " (the vertical part of " << crs->name() << ")\n";
  } else if (!unusable.empty()) {
    std::cout << "CRS:         cannot be used: " << unusable << "; read as a plain grid (grid coordinates only)\n";
  } else {
    std::cout << "CRS:         none (grid coordinates only)\n";
  }
  std::cout << "Origin:      " << coordinate(t.origin_x, geographic) << ", " << coordinate(t.origin_y, geographic)
            << "  (outer corner of the first cell)\n"
            << "Pixel size:  " << fixed(t.pixel_width, geographic ? 10 : 4) << ", "
            << fixed(t.pixel_height, geographic ? 10 : 4) << '\n'
            << "Cell size:   " << fixed(cell_x_m, 2) << " m east-west x " << fixed(cell_y_m, 2)
            << " m north-south (at the centre)\n"
            << "Extent:      x " << coordinate(extent.x_min, geographic) << " .. "
            << coordinate(extent.x_max, geographic) << ", y " << coordinate(extent.y_min, geographic) << " .. "
            << coordinate(extent.y_max, geographic) << '\n';
  if (bounds)
    std::cout << "Lon/lat:     lon " << fixed(bounds->west, 6) << " .. " << fixed(bounds->east, 6) << ", lat "
              << fixed(bounds->south, 6) << " .. " << fixed(bounds->north, 6) << '\n';
  std::cout << "Nodata:      " << (dem->nodata ? fixed(*dem->nodata, 6) : std::string("none")) << '\n';
  if (stats.valid_cells)
    std::cout << "Elevation:   " << fixed(stats.min, 2) << " .. " << fixed(stats.max, 2) << " m\n";
  else
    std::cout << "Elevation:   no valid cells\n";
  std::cout << "Voids:       " << with_separators(stats.nodata_cells) << " cells ("
            << fixed(cells ? 100.0 * static_cast<double>(stats.nodata_cells) / static_cast<double>(cells) : 0.0, 2)
            << " %)\n";
  return kExitOk;
}

}  // namespace

const Command& info_command() {
  static const Command command{
      "info",
      "Describe a DEM: size, CRS, georeferencing, cell size, extent, nodata, elevations",
      "horizon info DEM [--band N] [--json]",
      "Reads DEM (GeoTIFF, SRTM .hgt or terrain-RGB PNG) and prints its size, coordinate\n"
      "reference system (EPSG code or name, projection, units, heights; for a CRS it\n"
      "cannot use, what that CRS is and what is not supported), geotransform, true cell\n"
      "size in metres at its centre, extent in its CRS and in WGS84 longitude/latitude,\n"
      "nodata value, elevation range and number of void cells.",
      kFlags,
      "  horizon info data/dem/rainier_summit_srtm3_400x400.tif\n"
      "  horizon info data/dem/ecuador_andes_utm17s_10m_383x415.tif --json\n",
      run_info,
  };
  return command;
}

}  // namespace horizon::cli
