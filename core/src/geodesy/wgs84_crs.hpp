// wgs84_crs.hpp — WGS 84, its UTM zones and web Mercator described without
// PROJ's database.
//
// Most DEMs are in one of 122 CRSs: WGS 84 longitude/latitude (EPSG:4326,
// every SRTM and Copernicus tile), a WGS 84 / UTM zone (EPSG:32601-32660
// north, 32701-32760 south) or web Mercator (EPSG:3857, web map tiles). PROJ describes those through its SQLite
// database, whose first use in a process costs 5-20 ms (opening proj.db and
// parsing its schema, then searching for operations) — as much as the whole
// viewshed of a million-cell DEM. Crs (crs.cpp) therefore describes these
// CRSs from the facts here and builds PROJ's objects for them only when a
// caller needs one (a WKT, an equivalence test, a position outside the
// range below).
//
// The facts are PROJ's own for these codes (names, units, method, the WGS 84
// ellipsoid); tests/geodesy/test_crs_builtin.cpp compares them, and every
// conversion here, with PROJ's for all 122 codes.
//
// Conversions: GeographicLib's transverse Mercator (Krüger's series to
// order 6, with UTM's scale 0.9996, false easting 500 km and, south, false
// northing 10 000 km), accurate to 5 nm within 3 900 km of the central
// meridian. Positions further than kMaxUtmLongitudeSpan degrees of longitude
// from the zone's meridian are left to PROJ (nullopt here), so answers far
// outside a zone are PROJ's exactly as before.
//
// Web Mercator (EPSG:1024, "Popular Visualisation Pseudo Mercator"): the
// spherical Mercator formulas on WGS 84's semi-major axis a, applied to WGS
// 84 latitudes: x = a lambda, y = a ln tan(pi/4 + phi/2). Its ground scale is
// the ellipsoid's: one unit of x is N cos(phi) / a metres, one of y
// M cos(phi) / a (N, M the radii of curvature), as PROJ's derivatives give.
// Positions beyond the map's square (|x| > pi a, |latitude| > 85.06) are
// left to PROJ.
#pragma once

#include <optional>
#include <string>

#include "horizon/geodesy/crs.hpp"

namespace horizon::geodesy::detail {

struct Wgs84Crs {
  int epsg = 0;
  bool geographic = false;    // EPSG:4326
  bool web_mercator = false;  // EPSG:3857
  int zone = 0;               // UTM: 1..60
  bool south = false;
};

// The CRS of a definition spelled exactly "EPSG:4326", "EPSG:3857",
// "EPSG:326zz" or "EPSG:327zz" (zz = 01..60); nullopt for anything else,
// which PROJ reads.
std::optional<Wgs84Crs> wgs84_crs(const std::string& definition);

// PROJ's name for it: "WGS 84", "WGS 84 / UTM zone 45N", "WGS 84 / Pseudo-Mercator".
std::string wgs84_crs_name(const Wgs84Crs& crs);

// A UTM zone's central meridian, degrees.
double utm_central_meridian(const Wgs84Crs& crs);

// Beyond this many degrees of longitude from a zone's meridian, PROJ converts.
inline constexpr double kMaxUtmLongitudeSpan = 30.0;

// A UTM position's longitude/latitude and point scale k, or nullopt where
// the longitude is beyond the span above, the easting more than 3 900 km
// from the false easting, or the input not finite.
struct UtmReverse {
  LonLat lonlat;
  double k = 1.0;
};
std::optional<UtmReverse> utm_to_lonlat(const Wgs84Crs& crs, XY p);
// UTM coordinates of a position, or nullopt beyond the span above.
std::optional<XY> utm_from_lonlat(const Wgs84Crs& crs, LonLat p);

// Web Mercator: a position's longitude/latitude and its ground scale, or
// nullopt outside the map's square (or not finite).
struct MercatorReverse {
  LonLat lonlat;
  GroundScale scale;
};
std::optional<MercatorReverse> web_mercator_to_lonlat(XY p);
// Web Mercator coordinates of a position, or nullopt outside the square.
std::optional<XY> web_mercator_from_lonlat(LonLat p);

}  // namespace horizon::geodesy::detail
