// observer.cpp — resolving a user's viewpoint (or target) against a DEM.
//
// The checks run in the order observer.hpp promises, and each error names the
// offending field ("observer.x", "target.lat", ...) so a CLI or server can
// point at the exact input:
//   1. finite numbers            -> kInvalidArgument
//   2. a CRS, for WGS84 input    -> kInvalidArgument (kUnsupported if the CRS is)
//   3. inside the outer extent   -> kOutOfRange, coordinates in the message
//   4. not on a void, for a height above ground -> kDataError
// "Inside" means within the cells' outer edges, [-0.5, W-0.5] x [-0.5, H-0.5]
// in grid coordinates (cell centres at integers), the same area over which
// terrain::sample_bilinear defines the surface.
#include "horizon/geodesy/observer.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>

#include "horizon/geodesy/crs.hpp"

namespace horizon::geodesy {
namespace {

std::string fmt(const char* format, double a, double b) {
  char buf[128];
  std::snprintf(buf, sizeof buf, format, a, b);
  return buf;
}

std::string dem_name(const terrain::Dem& dem) {
  return "dem '" + dem.source + "'";
}

// The value of the cell holding grid point (col, row): cell c spans
// [c - 0.5, c + 0.5), the outer edges belonging to the edge cells.
double cell_value(const terrain::Grid<float>& elevation, double col, double row) {
  const auto cell = [](double v, int n) { return std::clamp(static_cast<int>(std::floor(v + 0.5)), 0, n - 1); };
  return elevation.at(cell(col, elevation.width()), cell(row, elevation.height()));
}

}  // namespace

Result<GridPoint> resolve_point(const terrain::Dem& dem, const PointSpec& spec, const char* what) {
  auto located = locate_point(dem.georef, dem.width(), dem.height(), spec, what, dem.source);
  if (!located.ok()) return located.error();
  return place_on_ground(dem, *located, spec, what);
}

Result<GridPoint> locate_point(const terrain::Georeference& georef, int width, int height, const PointSpec& spec,
                               const char* what, const std::string& source) {
  const std::string name = what ? what : "point";
  const std::string dem_label = "dem '" + source + "'";
  const bool wgs84 = spec.frame == PointFrame::kWgs84;
  const std::string x_field = name + (wgs84 ? ".lon" : ".x");
  const std::string y_field = name + (wgs84 ? ".lat" : ".y");

  // 1. Finite inputs.
  if (!std::isfinite(spec.x))
    return make_error(ErrorCode::kInvalidArgument, x_field + " must be a finite number", x_field);
  if (!std::isfinite(spec.y))
    return make_error(ErrorCode::kInvalidArgument, y_field + " must be a finite number", y_field);
  if (!std::isfinite(spec.height))
    return make_error(ErrorCode::kInvalidArgument, name + ".height must be a finite number", name + ".height");

  // 2. Into the dataset's CRS.
  GridPoint point;
  point.x = spec.x;
  point.y = spec.y;
  if (wgs84) {
    if (!georef.has_crs())
      return make_error(ErrorCode::kInvalidArgument,
                        name + " is given as WGS84 lon/lat but " + dem_label +
                            " has no CRS; give it in the dataset's own coordinates",
                        name);
    if (std::abs(spec.y) > 90.0)
      return make_error(ErrorCode::kInvalidArgument,
                        y_field + fmt(" = %.9g is not a latitude (lon %.9g)", spec.y, spec.x), y_field);
    auto crs = Crs::of(georef);
    if (!crs.ok()) return crs.error();
    auto xy = crs->from_lonlat(LonLat{spec.x, spec.y});
    if (!xy.ok())
      return make_error(ErrorCode::kOutOfRange,
                        name + fmt(" at lon %.9g, lat %.9g", spec.x, spec.y) + " cannot be placed in " + dem_label +
                            ": " + xy.error().message,
                        name);
    point.x = xy->x;
    point.y = xy->y;
  }

  // 3. Inside the raster's outer extent.
  const terrain::GeoTransform& t = georef.transform;
  // Coordinates typed or computed for a cell centre come back a little off
  // an integer: a few ulps through the geotransform, up to a millimetre
  // through a datum shift (PROJ's 2D transformations drop the height the
  // shift gives a point, so WGS 84 -> CRS -> WGS 84 is not exact: 1 mm for
  // CH1903+ and OSGB36). Snap those, within a thousandth of a cell, so the
  // point sits exactly on the centre (and a void next to it does not leak
  // into the bilinear ground height).
  auto snap = [](double v) {
    const double r = std::round(v);
    return std::abs(v - r) < 1e-3 ? r : v;
  };
  point.col = snap(t.col_at(point.x));
  point.row = snap(t.row_at(point.y));
  const double max_col = width - 0.5;
  const double max_row = height - 0.5;
  auto inside = [&](double col, double row) { return col >= -0.5 && col <= max_col && row >= -0.5 && row <= max_row; };
  // Longitudes are circular: on a geographic DEM that crosses the
  // antimeridian (x beyond 180, or below -180) a point given as lon -179.95
  // is the same place as x = 180.05. Try the point one turn east and west.
  if (!inside(point.col, point.row) && georef.has_crs()) {
    auto crs = Crs::of(georef);
    if (crs.ok() && crs->is_geographic())
      for (double turn : {360.0 / crs->unit_size(), -360.0 / crs->unit_size()}) {
        const double col = snap(t.col_at(point.x + turn));
        if (inside(col, point.row)) {
          point.x += turn;
          point.col = col;
          break;
        }
      }
  }
  if (!(point.col >= -0.5 && point.col <= max_col && point.row >= -0.5 && point.row <= max_row)) {
    const double x0 = t.origin_x, x1 = t.origin_x + width * t.pixel_width;
    const double y0 = t.origin_y, y1 = t.origin_y + height * t.pixel_height;
    std::string where =
        wgs84 ? fmt(" at lon %.9g, lat %.9g", spec.x, spec.y) + fmt(" (x %.10g, y %.10g)", point.x, point.y)
              : fmt(" at x %.10g, y %.10g", point.x, point.y);
    return make_error(ErrorCode::kOutOfRange,
                      name + where + fmt(" [col %.2f, row %.2f]", point.col, point.row) + " is outside " + dem_label +
                          fmt(" (x %.10g .. %.10g", std::fmin(x0, x1), std::fmax(x0, x1)) +
                          fmt(", y %.10g .. %.10g)", std::fmin(y0, y1), std::fmax(y0, y1)),
                      name);
  }

  point.ground = std::numeric_limits<double>::quiet_NaN();
  point.elevation = std::numeric_limits<double>::quiet_NaN();
  return point;
}

Result<GridPoint> place_on_ground(const terrain::Dem& dem, GridPoint point, const PointSpec& spec, const char* what,
                                  int col_offset, int row_offset) {
  const std::string name = what ? what : "point";
  // 4. The ground under the point.
  point.ground = spec.ground == GroundSample::kCell ? cell_value(dem.elevation, point.col, point.row)
                                                    : terrain::sample_bilinear(dem.elevation, point.col, point.row);
  if (spec.height_mode == HeightMode::kAboveGround) {
    if (std::isnan(point.ground))
      return make_error(ErrorCode::kDataError,
                        name + " is on a no-data cell" +
                            fmt(" (col %.2f, row %.2f)", point.col + col_offset, point.row + row_offset) + " of " +
                            dem_name(dem) + "; give an absolute height or move it",
                        name);
    point.elevation = point.ground + spec.height;
  } else {
    point.elevation = spec.height;
  }
  return point;
}

terrain::Window cells_within(const terrain::Georeference& georef, int width, int height, const GridPoint& point,
                             double radius_metres, int margin) {
  if (!std::isfinite(radius_metres) || width <= 0 || height <= 0)
    return {0, 0, std::max(width, 0), std::max(height, 0)};
  GroundScale scale;  // metres per CRS unit; 1 without a CRS (as make_view_frame)
  if (georef.has_crs())
    if (auto crs = Crs::of(georef); crs.ok()) scale = crs->ground_scale({point.x, point.y});
  const double per_col = std::abs(georef.transform.pixel_width) * scale.metres_per_x;
  const double per_row = std::abs(georef.transform.pixel_height) * scale.metres_per_y;
  if (!(per_col > 0) || !(per_row > 0)) return {0, 0, width, height};
  const double reach_c = radius_metres / per_col + margin, reach_r = radius_metres / per_row + margin;
  auto clamp_to = [](double v, int n) { return static_cast<int>(std::clamp(v, 0.0, static_cast<double>(n))); };
  const int oc = std::clamp(static_cast<int>(std::lround(point.col)), 0, width - 1);
  const int orow = std::clamp(static_cast<int>(std::lround(point.row)), 0, height - 1);
  return {std::min(clamp_to(std::floor(point.col - reach_c), width), oc),
          std::min(clamp_to(std::floor(point.row - reach_r), height), orow),
          std::max(clamp_to(std::ceil(point.col + reach_c) + 1, width), oc + 1),
          std::max(clamp_to(std::ceil(point.row + reach_r) + 1, height), orow + 1)};
}

}  // namespace horizon::geodesy
