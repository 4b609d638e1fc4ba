// wgs84_crs.cpp — WGS 84 and its UTM zones without PROJ (see wgs84_crs.hpp).
//
// Reference: GeographicLib's TransverseMercator (C. F. F. Karney, "Transverse
// Mercator with an accuracy of a few nanometers", J. Geodesy 85, 2011) and
// its UTM() instance (WGS 84, k0 = 0.9996); UTM's false origins from the
// EPSG dataset (EPSG:16001-16060 north, 16101-16160 south).
#include "wgs84_crs.hpp"

#include <GeographicLib/Ellipsoid.hpp>
#include <GeographicLib/Math.hpp>
#include <GeographicLib/TransverseMercator.hpp>

#include <cmath>
#include <cstdio>
#include <numbers>

namespace horizon::geodesy::detail {
namespace {

constexpr double kFalseEasting = 500000.0;
constexpr double kFalseNorthingSouth = 10000000.0;
// The series' accurate range, metres east or west of the central meridian.
constexpr double kMaxUtmEastingSpan = 3900000.0;

constexpr double kA = 6378137.0;  // WGS 84's semi-major axis, metres
constexpr double kDegree = std::numbers::pi / 180.0;
// Web Mercator's square: |x| <= pi a, and the latitude where y = pi a.
constexpr double kMercatorMaxLatitude = 85.0511287798;

double false_northing(const Wgs84Crs& crs) {
  return crs.south ? kFalseNorthingSouth : 0.0;
}

}  // namespace

std::optional<Wgs84Crs> wgs84_crs(const std::string& definition) {
  if (definition == "EPSG:4326") return Wgs84Crs{.epsg = 4326, .geographic = true};
  if (definition == "EPSG:3857") return Wgs84Crs{.epsg = 3857, .web_mercator = true};
  // "EPSG:" and five digits: 326zz or 327zz.
  if (definition.size() != 10 || definition.compare(0, 5, "EPSG:") != 0) return std::nullopt;
  int code = 0;
  for (std::size_t i = 5; i < definition.size(); ++i) {
    if (definition[i] < '0' || definition[i] > '9') return std::nullopt;
    code = code * 10 + (definition[i] - '0');
  }
  const int zone = code % 100;
  if (zone < 1 || zone > 60) return std::nullopt;
  if (code / 100 == 326) return Wgs84Crs{.epsg = code, .zone = zone};
  if (code / 100 == 327) return Wgs84Crs{.epsg = code, .zone = zone, .south = true};
  return std::nullopt;
}

std::string wgs84_crs_name(const Wgs84Crs& crs) {
  if (crs.geographic) return "WGS 84";
  if (crs.web_mercator) return "WGS 84 / Pseudo-Mercator";
  char buf[32];
  std::snprintf(buf, sizeof buf, "WGS 84 / UTM zone %d%c", crs.zone, crs.south ? 'S' : 'N');
  return buf;
}

double utm_central_meridian(const Wgs84Crs& crs) {
  return 6.0 * crs.zone - 183.0;
}

std::optional<UtmReverse> utm_to_lonlat(const Wgs84Crs& crs, XY p) {
  if (!std::isfinite(p.x) || !std::isfinite(p.y)) return std::nullopt;
  if (std::abs(p.x - kFalseEasting) > kMaxUtmEastingSpan) return std::nullopt;
  const double lon0 = utm_central_meridian(crs);
  double lat = 0, lon = 0, gamma = 0, k = 0;
  GeographicLib::TransverseMercator::UTM().Reverse(lon0, p.x - kFalseEasting, p.y - false_northing(crs), lat, lon,
                                                   gamma, k);
  if (!std::isfinite(lat) || !std::isfinite(lon) || !(k > 0)) return std::nullopt;
  if (std::abs(GeographicLib::Math::AngDiff(lon0, lon)) > kMaxUtmLongitudeSpan) return std::nullopt;
  return UtmReverse{LonLat{GeographicLib::Math::AngNormalize(lon), lat}, k};
}

std::optional<XY> utm_from_lonlat(const Wgs84Crs& crs, LonLat p) {
  if (!std::isfinite(p.lon) || !std::isfinite(p.lat) || std::abs(p.lat) > 90.0) return std::nullopt;
  const double lon0 = utm_central_meridian(crs);
  if (std::abs(GeographicLib::Math::AngDiff(lon0, p.lon)) > kMaxUtmLongitudeSpan) return std::nullopt;
  double x = 0, y = 0, gamma = 0, k = 0;
  GeographicLib::TransverseMercator::UTM().Forward(lon0, p.lat, p.lon, x, y, gamma, k);
  if (!std::isfinite(x) || !std::isfinite(y)) return std::nullopt;
  return XY{x + kFalseEasting, y + false_northing(crs)};
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
