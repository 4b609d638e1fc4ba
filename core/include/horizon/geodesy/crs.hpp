// horizon/geodesy/crs.hpp — the coordinate reference systems Horizon handles, through PROJ.
//
// Any CRS PROJ (9.1+) can turn into WGS 84 longitude/latitude: EPSG codes
// from its database (geographic, projected, compound "EPSG:27700+5701" or
// 7405), WKT 1 or 2, PROJJSON and PROJ strings ("+proj=aeqd ... +type=crs").
// A compound CRS (horizontal + vertical) is accepted and its horizontal part
// is what the engine computes with; its vertical part must be in metres
// (elevations are metres everywhere). Refused (kUnsupported, the message
// saying what): geocentric, engineering (local) and vertical-only CRSs,
// rotated-pole (derived geographic) CRSs, a CRS whose two horizontal axes
// have different units. One PROJ finds no way to WGS 84 for is refused by
// its first from_lonlat/to_lonlat (kUnsupported, saying so): the search for
// that transformation costs milliseconds, made only when a position is
// converted.
//
// Frames and units. Coordinates are in the CRS's own units (metres, feet,
// degrees, ...) in "GIS order": x east(ing) or longitude, y north(ing) or
// latitude, whatever order the CRS's definition declares (as GDAL and
// GeoTIFF files put them). WGS 84 means EPSG:4326: from_lonlat/to_lonlat go
// through the datum transformation PROJ picks for the place, the one
// gdaltransform picks on the same machine (e.g. OSGB36 <-> WGS 84 by a
// Helmert transformation, good to ~2 m; one that needs a grid file not
// installed is passed over, as there), so a point typed in WGS 84 lands
// where a GPS says it is. These transformations are 2D (the height a datum
// shift gives a point is dropped), so a position taken to WGS 84 and back
// returns within a millimetre, not bit for bit, where a datum shift applies.
// A position must convert back to itself (to ~0.1 m) by the transformation
// that carried it, else it is outside the projection's domain (kOutOfRange).
//
// Ground scale. Metres on the CRS's ellipsoid per CRS unit along the x and y
// axes at a point: from the projection's partial derivatives (proj_factors)
// there for projected CRSs, so a conformal, equal-area or azimuthal
// projection alike gets its true ground cell sizes, in whatever direction
// its grid lies to the meridian (LAEA far from its centre, polar
// stereographic); from the ellipsoid's radii of curvature for geographic
// CRSs. On a datum other than WGS 84's the lengths are that datum's: they
// differ from WGS 84 geodesics by its scale (29 ppm for OSGB36).
//
// Errors name the CRS ("CRS EPSG:4978 (WGS 84) is a geocentric CRS ...",
// "OSGB36 / British National Grid: position (lon 104, lat 10) is outside the
// projection's domain ...") and quote PROJ's reason with any file path cut
// to its name, so a daemon can pass them to its clients.
//
// Cost and threads. A Crs is a cheap handle (a shared pointer) to an
// immutable description; equal definitions share one description process-
// wide, so from_epsg / of() on a known CRS costs a map look-up. PROJ objects
// are bound to a PROJ context, which is not thread-safe: each description
// keeps a pool of per-context transformation sets, and a call borrows one
// for its duration (a thread that finds none free builds its own, once:
// milliseconds to tens of milliseconds, a PROJ database query). Every
// member function is therefore safe to call from any number of threads at
// once. Point conversions cost a few microseconds.
//
// The CRSs of most DEMs are described and converted without PROJ (loading
// it and opening its database costs a process 5-55 ms): longitude/latitude
// and the UTM zones of WGS 84, SIRGAS 2000, ETRS89 and NZGD2000, New
// Zealand's NZTM 2000 and web Mercator (EPSG:4326, 32601-32660, 32701-32760,
// 3857, 4674, 31965-31985, 6210, 6211, 5396, 4258, 25828-25837, 4167, 2193,
// 2133-2135, 5700; core/src/geodesy/builtin_crs.hpp says why those datums).
// NAD83's (4269, 26901-26923, 9712, 3372, 3373) are described without PROJ,
// and go to and from WGS 84 through it. PROJ's objects are built for them
// only for a WKT, an equivalence test, a position far outside the
// projection's usual range or (NAD83) a conversion to or from WGS 84.
#pragma once

#include <memory>
#include <optional>
#include <string>

#include "horizon/common/error.hpp"
#include "horizon/terrain/georef.hpp"

namespace horizon::geodesy {

struct LonLat {
  double lon = 0.0;  // degrees east, [-180, 180)
  double lat = 0.0;  // degrees north
};

struct XY {
  double x = 0.0, y = 0.0;  // CRS units (metres, feet or degrees)
};

// Ground metres per CRS unit along the CRS's x and y axes at one place. For
// a conformal projection both equal u/k (k = the projection's point scale,
// ~0.9996 in UTM; u = metres per CRS unit); for others the two differ (LAEA,
// web Mercator on the WGS 84 ellipsoid); for geographic CRSs they are the
// lengths of one unit (a degree) of longitude and latitude on the CRS's
// ellipsoid.
struct GroundScale {
  double metres_per_x = 1.0;
  double metres_per_y = 1.0;
};

namespace detail {
struct CrsData;
}

class Crs {
 public:
  // Any EPSG code of a geographic, projected or compound CRS. Not in PROJ's
  // database, or a kind refused above: kUnsupported naming "EPSG:<code>".
  static Result<Crs> from_epsg(int epsg);
  // "EPSG:n", "EPSG:h+v", WKT 1/2, PROJJSON or a PROJ string. Text PROJ
  // cannot read or a kind refused above: kUnsupported quoting the text.
  static Result<Crs> from_definition(const std::string& definition);
  // The CRS of a georeference: its `crs` definition when it has one, else
  // its EPSG code; kInvalidArgument when it has neither.
  static Result<Crs> of(const terrain::Georeference& georef);

  // The text it was made from: "EPSG:32633", "EPSG:27700+5701", or WKT.
  const std::string& definition() const;
  // EPSG code of the whole CRS (7405; 0 for "EPSG:27700+5701" or a
  // user-defined CRS), of its horizontal part (27700 for both), of its
  // vertical part (5701; 0 without one).
  int epsg() const;
  int horizontal_epsg() const;
  int vertical_epsg() const;
  // Names as PROJ gives them: "WGS 84 / UTM zone 45N", "OSGB36 / British
  // National Grid + ODN height"; the horizontal and vertical parts' names.
  const std::string& name() const;
  const std::string& horizontal_name() const;
  const std::string& vertical_name() const;  // empty without a vertical part
  bool is_geographic() const;
  bool is_compound() const { return vertical_epsg() != 0 || !vertical_name().empty(); }
  // The projection method of a projected CRS ("Transverse Mercator",
  // "Lambert Azimuthal Equal Area"); empty for a geographic one.
  const std::string& projection() const;
  // The unit of x and y ("metre", "US survey foot", "degree") and its size:
  // metres (projected) or degrees (geographic) per unit.
  const std::string& unit_name() const;
  double unit_size() const;
  // WKT2:2019 of the whole CRS.
  const std::string& wkt() const;

  // WGS 84 longitude/latitude (degrees) -> CRS coordinates. Fails
  // (kOutOfRange, naming the CRS and the position) for latitudes beyond
  // +-90, and where the CRS cannot express the place (PROJ refuses it, or
  // the result does not convert back to the same place).
  Result<XY> from_lonlat(LonLat p) const;
  // CRS coordinates -> WGS 84 longitude/latitude (longitude in [-180, 180]).
  Result<LonLat> to_lonlat(XY p) const;
  // Metric size of CRS units at a CRS point. Where a projection has no
  // derivative (the pole of an azimuthal projection, outside its domain):
  // its point scale there when PROJ gives one, else unit_size() metres per
  // unit.
  GroundScale ground_scale(XY p) const;

  // True when PROJ finds both the same CRS for coordinate work (its
  // "equivalent" criterion: names of CRSs, identifiers, units a parameter is
  // written in and a geographic CRS's axis order aside; datum names count).
  bool equivalent_to(const Crs& other) const;

 private:
  explicit Crs(std::shared_ptr<const detail::CrsData> data) : data_(std::move(data)) {}
  std::shared_ptr<const detail::CrsData> data_;
};

// WGS84 bounds of a rectangle in a CRS: the envelope of its corners and edge
// midpoints, which is exact for geographic CRSs and within a fraction of a
// cell for a DEM-sized UTM area. Empty when a point does not convert.
struct LonLatBounds {
  double west = 0.0, south = 0.0, east = 0.0, north = 0.0;  // degrees
};
std::optional<LonLatBounds> lonlat_bounds(const Crs& crs, double x_min, double y_min, double x_max, double y_max);

// WGS84 semi-major axis, metres; the Earth radius used for curvature.
inline constexpr double kEarthRadiusMetres = 6378137.0;

}  // namespace horizon::geodesy
