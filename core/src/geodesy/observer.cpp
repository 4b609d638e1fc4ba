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

#include <cmath>
#include <cstdio>
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

}  // namespace

Result<GridPoint> resolve_point(const terrain::Dem& dem, const PointSpec& spec, const char* what) {
  const std::string name = what ? what : "point";
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
    if (dem.georef.epsg == 0)
      return make_error(ErrorCode::kInvalidArgument,
                        name + " is given as WGS84 lon/lat but " + dem_name(dem) +
                            " has no CRS; give it in the dataset's own coordinates",
                        name);
    if (std::abs(spec.y) > 90.0)
      return make_error(ErrorCode::kInvalidArgument,
                        y_field + fmt(" = %.9g is not a latitude (lon %.9g)", spec.y, spec.x), y_field);
    auto crs = Crs::from_epsg(dem.georef.epsg);
    if (!crs.ok()) return crs.error();
    auto xy = crs->from_lonlat(LonLat{spec.x, spec.y});
    if (!xy.ok())
      return make_error(ErrorCode::kOutOfRange,
                        name + fmt(" at lon %.9g, lat %.9g", spec.x, spec.y) + " cannot be placed in " + dem_name(dem) +
                            ": " + xy.error().message,
                        name);
    point.x = xy->x;
    point.y = xy->y;
  }

  // 3. Inside the raster's outer extent.
  const terrain::GeoTransform& t = dem.georef.transform;
  // Coordinates typed or computed for a cell centre come back a few ulps off
  // an integer; snap those so the point sits exactly on the centre (and a
  // void next to it does not leak into the bilinear ground height).
  auto snap = [](double v) {
    const double r = std::round(v);
    return std::abs(v - r) < 1e-7 ? r : v;
  };
  point.col = snap(t.col_at(point.x));
  point.row = snap(t.row_at(point.y));
  const double max_col = dem.width() - 0.5;
  const double max_row = dem.height() - 0.5;
  if (!(point.col >= -0.5 && point.col <= max_col && point.row >= -0.5 && point.row <= max_row)) {
    const double x0 = t.origin_x, x1 = t.origin_x + dem.width() * t.pixel_width;
    const double y0 = t.origin_y, y1 = t.origin_y + dem.height() * t.pixel_height;
    std::string where =
        wgs84 ? fmt(" at lon %.9g, lat %.9g", spec.x, spec.y) + fmt(" (x %.10g, y %.10g)", point.x, point.y)
              : fmt(" at x %.10g, y %.10g", point.x, point.y);
    return make_error(ErrorCode::kOutOfRange,
                      name + where + fmt(" [col %.2f, row %.2f]", point.col, point.row) + " is outside " +
                          dem_name(dem) + fmt(" (x %.10g .. %.10g", std::fmin(x0, x1), std::fmax(x0, x1)) +
                          fmt(", y %.10g .. %.10g)", std::fmin(y0, y1), std::fmax(y0, y1)),
                      name);
  }

  // 4. The ground under the point.
  point.ground = terrain::sample_bilinear(dem.elevation, point.col, point.row);
  if (spec.height_mode == HeightMode::kAboveGround) {
    if (std::isnan(point.ground))
      return make_error(ErrorCode::kDataError,
                        name + " is on a no-data cell" + fmt(" (col %.2f, row %.2f)", point.col, point.row) + " of " +
                            dem_name(dem) + "; give an absolute height or move it",
                        name);
    point.elevation = point.ground + spec.height;
  } else {
    point.elevation = spec.height;
  }
  return point;
}

}  // namespace horizon::geodesy
