// builtin_crs.cpp — the common CRSs without PROJ (see builtin_crs.hpp).
//
// Reference: GeographicLib's TransverseMercator (C. F. F. Karney, "Transverse
// Mercator with an accuracy of a few nanometers", J. Geodesy 85, 2011); the
// codes, names, zones and false origins are the EPSG dataset's as PROJ's
// proj.db holds them (UTM: conversions EPSG:16001-16060 north, 16101-16160
// south; NZTM 2000: EPSG:19971, central meridian 173 E, false origin 1 600
// km east, 10 000 km north).
#include "builtin_crs.hpp"

#include <GeographicLib/Ellipsoid.hpp>
#include <GeographicLib/Math.hpp>
#include <GeographicLib/TransverseMercator.hpp>

#include <cmath>
#include <cstdio>
#include <numbers>

namespace horizon::geodesy::detail {
namespace {

constexpr double kUtmFalseEasting = 500000.0;
constexpr double kUtmFalseNorthingSouth = 10000000.0;
constexpr double kScaleOnMeridian = 0.9996;  // UTM and NZTM
// The series' accurate range, metres east or west of the central meridian.
constexpr double kMaxEastingSpan = 3900000.0;

constexpr double kA = 6378137.0;  // WGS 84's and GRS 1980's semi-major axis, metres
constexpr double kWgs84InverseFlattening = 298.257223563;
constexpr double kGrs80InverseFlattening = 298.257222101;
constexpr double kDegree = std::numbers::pi / 180.0;
// Web Mercator's square: |x| <= pi a, and the latitude where y = pi a.
constexpr double kMercatorMaxLatitude = 85.0511287798;

constexpr int kNztmCode = 2193;

BuiltinCrs utm(int epsg, BuiltinDatum datum, int zone, bool south) {
  return BuiltinCrs{.epsg = epsg,
                    .datum = datum,
                    .kind = BuiltinKind::kTransverseMercator,
                    .zone = zone,
                    .south = south,
                    .lon0 = 6.0 * zone - 183.0,
                    .false_easting = kUtmFalseEasting,
                    .false_northing = south ? kUtmFalseNorthingSouth : 0.0};
}

// Runs of consecutive codes: geographic (zone 0) or UTM zones from first_zone on.
struct CodeRun {
  int first_code, count;
  BuiltinDatum datum;
  int first_zone;
  bool south;
};
constexpr CodeRun kCodeRuns[] = {
    {4326, 1, BuiltinDatum::kWgs84, 0, false},         {32601, 60, BuiltinDatum::kWgs84, 1, false},
    {32701, 60, BuiltinDatum::kWgs84, 1, true},        {4674, 1, BuiltinDatum::kSirgas2000, 0, false},
    {31965, 12, BuiltinDatum::kSirgas2000, 11, false}, {6210, 2, BuiltinDatum::kSirgas2000, 23, false},
    {31977, 9, BuiltinDatum::kSirgas2000, 17, true},   {5396, 1, BuiltinDatum::kSirgas2000, 26, true},
    {4258, 1, BuiltinDatum::kEtrs89, 0, false},        {25828, 10, BuiltinDatum::kEtrs89, 28, false},
    {4167, 1, BuiltinDatum::kNzgd2000, 0, false},      {2133, 3, BuiltinDatum::kNzgd2000, 58, true},
    {5700, 1, BuiltinDatum::kNzgd2000, 1, true},       {4269, 1, BuiltinDatum::kNad83, 0, false},
    {26901, 23, BuiltinDatum::kNad83, 1, false},       {9712, 1, BuiltinDatum::kNad83, 24, false},
    {3372, 2, BuiltinDatum::kNad83, 59, false},
};

std::optional<BuiltinCrs> builtin_code(int code) {
  if (code == 3857) return BuiltinCrs{.epsg = code, .kind = BuiltinKind::kWebMercator};
  if (code == kNztmCode)
    return BuiltinCrs{.epsg = code,
                      .datum = BuiltinDatum::kNzgd2000,
                      .kind = BuiltinKind::kTransverseMercator,
                      .lon0 = 173.0,
                      .false_easting = 1600000.0,
                      .false_northing = 10000000.0};
  for (const CodeRun& run : kCodeRuns) {
    if (code < run.first_code || code >= run.first_code + run.count) continue;
    if (run.first_zone == 0) return BuiltinCrs{.epsg = code, .datum = run.datum};
    return utm(code, run.datum, run.first_zone + (code - run.first_code), run.south);
  }
  return std::nullopt;
}

const char* datum_name(BuiltinDatum datum) {
  switch (datum) {
    case BuiltinDatum::kSirgas2000:
      return "SIRGAS 2000";
    case BuiltinDatum::kEtrs89:
      return "ETRS89";
    case BuiltinDatum::kNzgd2000:
      return "NZGD2000";
    case BuiltinDatum::kNad83:
      return "NAD83";
    case BuiltinDatum::kWgs84:
      break;
  }
  return "WGS 84";
}

// The datum's transverse Mercator with UTM's scale on the central meridian.
const GeographicLib::TransverseMercator& projection_of(BuiltinDatum datum) {
  if (datum == BuiltinDatum::kWgs84) return GeographicLib::TransverseMercator::UTM();
  static const GeographicLib::TransverseMercator grs80(kA, 1.0 / kGrs80InverseFlattening, kScaleOnMeridian);
  return grs80;
}

}  // namespace

std::optional<BuiltinCrs> builtin_crs(const std::string& definition) {
  // "EPSG:" and four or five digits.
  if (definition.size() < 9 || definition.size() > 10 || definition.compare(0, 5, "EPSG:") != 0) return std::nullopt;
  int code = 0;
  for (std::size_t i = 5; i < definition.size(); ++i) {
    if (definition[i] < '0' || definition[i] > '9') return std::nullopt;
    code = code * 10 + (definition[i] - '0');
  }
  if (definition[5] == '0') return std::nullopt;  // "EPSG:04326" is PROJ's to read
  return builtin_code(code);
}

std::string builtin_crs_name(const BuiltinCrs& crs) {
  const std::string datum = datum_name(crs.datum);
  switch (crs.kind) {
    case BuiltinKind::kGeographic:
      return datum;
    case BuiltinKind::kWebMercator:
      return datum + " / Pseudo-Mercator";
    case BuiltinKind::kTransverseMercator:
      break;
  }
  if (crs.zone == 0) return datum + " / New Zealand Transverse Mercator 2000";
  char buf[32];
  std::snprintf(buf, sizeof buf, " / UTM zone %d%c", crs.zone, crs.south ? 'S' : 'N');
  return datum + buf;
}

EllipsoidFacts ellipsoid_of(BuiltinDatum datum) {
  return {kA, datum == BuiltinDatum::kWgs84 ? kWgs84InverseFlattening : kGrs80InverseFlattening};
}

std::optional<TmReverse> tm_to_lonlat(const BuiltinCrs& crs, XY p) {
  if (!std::isfinite(p.x) || !std::isfinite(p.y)) return std::nullopt;
  if (std::abs(p.x - crs.false_easting) > kMaxEastingSpan) return std::nullopt;
  double lat = 0, lon = 0, gamma = 0, k = 0;
  projection_of(crs.datum).Reverse(crs.lon0, p.x - crs.false_easting, p.y - crs.false_northing, lat, lon, gamma, k);
  if (!std::isfinite(lat) || !std::isfinite(lon) || !(k > 0)) return std::nullopt;
  if (std::abs(GeographicLib::Math::AngDiff(crs.lon0, lon)) > kMaxTmLongitudeSpan) return std::nullopt;
  return TmReverse{LonLat{GeographicLib::Math::AngNormalize(lon), lat}, k};
}

std::optional<XY> tm_from_lonlat(const BuiltinCrs& crs, LonLat p) {
  if (!std::isfinite(p.lon) || !std::isfinite(p.lat) || std::abs(p.lat) > 90.0) return std::nullopt;
  if (std::abs(GeographicLib::Math::AngDiff(crs.lon0, p.lon)) > kMaxTmLongitudeSpan) return std::nullopt;
  double x = 0, y = 0, gamma = 0, k = 0;
  projection_of(crs.datum).Forward(crs.lon0, p.lat, p.lon, x, y, gamma, k);
  if (!std::isfinite(x) || !std::isfinite(y)) return std::nullopt;
  return XY{x + crs.false_easting, y + crs.false_northing};
}

std::optional<MercatorReverse> web_mercator_to_lonlat(XY p) {
  if (!std::isfinite(p.x) || !std::isfinite(p.y)) return std::nullopt;
  if (std::abs(p.x) > std::numbers::pi * kA || std::abs(p.y) > std::numbers::pi * kA) return std::nullopt;
  const double phi = std::atan(std::sinh(p.y / kA));
  const double lat = phi / kDegree, lon = p.x / kA / kDegree;
  const GeographicLib::Ellipsoid& wgs84 = GeographicLib::Ellipsoid::WGS84();
  // Per unit: dlambda = dx / a, dphi = cos(phi) dy / a.
  const GroundScale scale{wgs84.CircleRadius(lat) / kA, wgs84.MeridionalCurvatureRadius(lat) * std::cos(phi) / kA};
  return MercatorReverse{LonLat{GeographicLib::Math::AngNormalize(lon), lat}, scale};
}

std::optional<XY> web_mercator_from_lonlat(LonLat p) {
  if (!std::isfinite(p.lon) || !std::isfinite(p.lat) || std::abs(p.lat) > kMercatorMaxLatitude) return std::nullopt;
  if (std::abs(p.lon) > 180.0) return std::nullopt;
  const double phi = p.lat * kDegree;
  return XY{kA * p.lon * kDegree, kA * std::asinh(std::tan(phi))};
}

}  // namespace horizon::geodesy::detail
