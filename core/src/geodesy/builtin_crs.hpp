// builtin_crs.hpp — the common CRSs described and converted without PROJ.
//
// Most DEMs are in one of a few CRSs: WGS 84 longitude/latitude (EPSG:4326,
// every SRTM and Copernicus tile), a WGS 84 / UTM zone (EPSG:32601-32660
// north, 32701-32760 south), web Mercator (EPSG:3857, web map tiles), or
// longitude/latitude, a UTM zone or New Zealand's transverse Mercator on a
// national datum of the GRS 1980 ellipsoid (below). PROJ describes those
// through its SQLite database: loading libproj and its libraries, then
// opening proj.db and searching it, costs a process 5-55 ms (the most where
// page faults are dear, as in some VMs), as much as the whole viewshed of a
// million-cell DEM. Crs (crs.cpp) therefore describes these CRSs from the
// facts here and builds PROJ's objects for them only when a caller needs
// one (a WKT, an equivalence test, a position outside the range below).
//
// The facts are PROJ's own for these codes (names, units, method, the
// ellipsoid); tests/geodesy/test_crs_builtin.cpp compares them, and every
// conversion here, with PROJ's for every code.
//
// Datums. WGS 84 itself, and three datums on GRS 1980 (inverse flattening
// 298.257222101 against WGS 84's 298.257223563) to which EPSG gives exactly
// one transformation from WGS 84, a null one good to 1 m: SIRGAS 2000 (the
// Americas; "SIRGAS 2000 to WGS 84 (1)", EPSG:15894), ETRS89 (Europe;
// EPSG:1149) and NZGD2000 (New Zealand; EPSG:1565). PROJ applies those as
// the identity on longitude and latitude, so a WGS 84 position has the same
// numbers on these datums, and only the projection's ellipsoid differs.
// NAD83 (North America, GRS 1980) is described here but not converted: EPSG
// has dozens of transformations from it to WGS 84 and PROJ picks among them
// by place, so its positions go to and from WGS 84 through PROJ, built when
// a position is first converted. A viewshed given its observer in the
// DEM's own coordinates needs none: the facts and the ground scale (the
// projection's alone, which no datum shift changes) are enough.
//
// Conversions: GeographicLib's transverse Mercator (Krüger's series to
// order 6, scale 0.9996 on the central meridian for UTM and NZTM alike),
// accurate to 5 nm within 3 900 km of the central meridian. Positions
// further than kMaxTmLongitudeSpan degrees of longitude from it are left to
// PROJ (nullopt here), so answers far outside a zone are PROJ's exactly as
// before.
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

enum class BuiltinDatum { kWgs84, kSirgas2000, kEtrs89, kNzgd2000, kNad83 };

// Whether a WGS 84 longitude/latitude has the same numbers on the datum
// (PROJ's transformation is the identity): all but NAD83.
inline bool identity_to_wgs84(BuiltinDatum datum) {
  return datum != BuiltinDatum::kNad83;
}

enum class BuiltinKind { kGeographic, kTransverseMercator, kWebMercator };

struct BuiltinCrs {
  int epsg = 0;
  BuiltinDatum datum = BuiltinDatum::kWgs84;
  BuiltinKind kind = BuiltinKind::kGeographic;
  // Transverse Mercator: the UTM zone (1..60, 0 for New Zealand's own
  // projection), its central meridian (degrees) and false origin (metres).
  int zone = 0;
  bool south = false;
  double lon0 = 0.0, false_easting = 0.0, false_northing = 0.0;

  bool geographic() const { return kind == BuiltinKind::kGeographic; }
};

// The CRS of a definition spelled exactly "EPSG:<code>" with one of the
// codes above; nullopt for anything else, which PROJ reads.
std::optional<BuiltinCrs> builtin_crs(const std::string& definition);

// PROJ's name for it: "WGS 84", "SIRGAS 2000 / UTM zone 25S", "NZGD2000 /
// New Zealand Transverse Mercator 2000", "WGS 84 / Pseudo-Mercator".
std::string builtin_crs_name(const BuiltinCrs& crs);

// The datum's ellipsoid: semi-major axis (metres) and inverse flattening.
struct EllipsoidFacts {
  double a = 0.0, inverse_flattening = 0.0;
};
EllipsoidFacts ellipsoid_of(BuiltinDatum datum);

// Beyond this many degrees of longitude from the central meridian, PROJ converts.
inline constexpr double kMaxTmLongitudeSpan = 30.0;

// A transverse Mercator position's longitude/latitude and point scale k, or
// nullopt where the longitude is beyond the span above, the easting more
// than 3 900 km from the false easting, or the input not finite.
struct TmReverse {
  LonLat lonlat;
  double k = 1.0;
};
std::optional<TmReverse> tm_to_lonlat(const BuiltinCrs& crs, XY p);
// Transverse Mercator coordinates of a position, or nullopt beyond the span above.
std::optional<XY> tm_from_lonlat(const BuiltinCrs& crs, LonLat p);

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
