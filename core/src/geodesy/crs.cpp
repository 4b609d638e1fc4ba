// crs.cpp — the EPSG coordinate systems Horizon understands, on GeographicLib.
//
// References:
//   * EPSG Geodetic Parameter Dataset (epsg.org): the codes listed in crs.hpp
//     and their parameters (UTM: lon0 = 6*zone - 183, k0 = 0.9996,
//     FE = 500 000 m, FN = 0 / 10 000 000 m; NZTM2000 (EPSG:2193): lon0 = 173,
//     k0 = 0.9996, FE = 1 600 000 m, FN = 10 000 000 m).
//   * C. F. F. Karney, "Transverse Mercator with an accuracy of a few
//     nanometers", J. Geodesy 85 (2011) 475-485 — GeographicLib's
//     TransverseMercator (the same Krueger series UTMUPS uses), accurate to
//     5 nm within 3900 km of the central meridian.
//   * EPSG Guidance Note 7-2, section 1.3.3.2 "Popular Visualisation
//     Pseudo-Mercator" (EPSG:3857): spherical formulas on R = 6 378 137 m.
//
// Every datum is treated as WGS84 (crs.hpp explains why that is acceptable).
// UTM and NZTM share one transverse Mercator (WGS84, k0 = 0.9996) and differ
// only in central meridian and false origin, so both go through the same code
// path; GeographicLib::UTMUPS would add its own hemisphere/zone-width checks,
// which reject points a DEM in a neighbouring zone legitimately needs.
#include "horizon/geodesy/crs.hpp"

#include <GeographicLib/Ellipsoid.hpp>
#include <GeographicLib/Math.hpp>
#include <GeographicLib/TransverseMercator.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>

namespace horizon::geodesy {
namespace {

// Beyond this distance from the central meridian GeographicLib's series loses
// its nanometre accuracy (Karney 2011); we call such points out of range.
constexpr double kMaxTmDistanceMetres = 3'900'000.0;
// Web Mercator's square world ends at +-85.0511287798 degrees latitude.
constexpr double kWebMercatorMaxLat = 85.0511287798066;
constexpr double kDegToRad = std::numbers::pi / 180.0;

const GeographicLib::TransverseMercator& utm_projection() {
  // The WGS84 ellipsoid with k0 = 0.9996: the UTM projection, also NZTM's.
  return GeographicLib::TransverseMercator::UTM();
}

Error out_of_range(const std::string& crs_name, const std::string& what) {
  return make_error(ErrorCode::kOutOfRange, crs_name + ": " + what);
}

std::string format_lonlat(LonLat p) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "lon %.9g, lat %.9g", p.lon, p.lat);
  return buf;
}

std::string format_xy(XY p) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "x %.10g, y %.10g", p.x, p.y);
  return buf;
}

}  // namespace

Result<Crs> Crs::from_epsg(int epsg) {
  Crs crs;
  crs.epsg_ = epsg;
  auto utm = [&crs](const char* datum, int zone, bool north) {
    crs.kind_ = Kind::kUtm;
    crs.zone_ = zone;
    crs.north_ = north;
    crs.lon0_ = 6.0 * zone - 183.0;
    crs.k0_ = 0.9996;
    crs.false_easting_ = 500000.0;
    crs.false_northing_ = north ? 0.0 : 10000000.0;
    crs.name_ = std::string(datum) + " / UTM zone " + std::to_string(zone) + (north ? "N" : "S");
  };
  switch (epsg) {
    case 4326:
      crs.name_ = "WGS 84";
      return crs;
    case 4269:
      crs.name_ = "NAD83";
      return crs;
    case 4258:
      crs.name_ = "ETRS89";
      return crs;
    case 4283:
      crs.name_ = "GDA94";
      return crs;
    case 4167:
      crs.name_ = "NZGD2000";
      return crs;
    case 4674:
      crs.name_ = "SIRGAS 2000";
      return crs;
    case 2193:
      crs.kind_ = Kind::kTransverseMercator;
      crs.lon0_ = 173.0;
      crs.k0_ = 0.9996;
      crs.false_easting_ = 1600000.0;
      crs.false_northing_ = 10000000.0;
      crs.name_ = "NZGD2000 / New Zealand Transverse Mercator 2000";
      return crs;
    case 3857:
      crs.kind_ = Kind::kWebMercator;
      crs.name_ = "WGS 84 / Pseudo-Mercator";
      return crs;
    default:
      break;
  }
  if (epsg >= 32601 && epsg <= 32660) {
    utm("WGS 84", epsg - 32600, true);
    return crs;
  }
  if (epsg >= 32701 && epsg <= 32760) {
    utm("WGS 84", epsg - 32700, false);
    return crs;
  }
  if (epsg >= 26901 && epsg <= 26923) {
    utm("NAD83", epsg - 26900, true);
    return crs;
  }
  if (epsg >= 25828 && epsg <= 25838) {
    utm("ETRS89", epsg - 25800, true);
    return crs;
  }
  // SIRGAS 2000: 31965..31976 are zones 11N..22N, 31977..31985 zones 17S..25S.
  if (epsg >= 31965 && epsg <= 31976) {
    utm("SIRGAS 2000", epsg - 31954, true);
    return crs;
  }
  if (epsg >= 31977 && epsg <= 31985) {
    utm("SIRGAS 2000", epsg - 31960, false);
    return crs;
  }
  return make_error(ErrorCode::kUnsupported,
                    "EPSG:" + std::to_string(epsg) +
                        " is not a supported CRS (supported: WGS84-compatible geographic, UTM, NZTM2000, "
                        "web Mercator; see horizon/geodesy/crs.hpp)",
                    "epsg");
}

Result<XY> Crs::from_lonlat(LonLat p) const {
  if (!std::isfinite(p.lon) || !std::isfinite(p.lat) || std::abs(p.lat) > 90.0)
    return out_of_range(name_, "position (" + format_lonlat(p) + ") is not a valid longitude/latitude");
  switch (kind_) {
    case Kind::kGeographic:
      return XY{p.lon, p.lat};
    case Kind::kUtm:
    case Kind::kTransverseMercator: {
      double x = 0, y = 0, gamma = 0, k = 0;
      utm_projection().Forward(lon0_, p.lat, p.lon, x, y, gamma, k);
      if (!std::isfinite(x) || !std::isfinite(y) || std::abs(x) > kMaxTmDistanceMetres)
        return out_of_range(name_,
                            "position (" + format_lonlat(p) + ") is too far from the projection's central meridian");
      return XY{x + false_easting_, y + false_northing_};
    }
    case Kind::kWebMercator: {
      if (std::abs(p.lat) > kWebMercatorMaxLat)
        return out_of_range(
            name_, "position (" + format_lonlat(p) + ") is beyond web Mercator's latitude limit of 85.0511 degrees");
      const double lon = GeographicLib::Math::AngNormalize(p.lon);
      const double x = kEarthRadiusMetres * lon * kDegToRad;
      const double y = kEarthRadiusMetres * std::log(std::tan(std::numbers::pi / 4.0 + p.lat * kDegToRad / 2.0));
      return XY{x, y};
    }
  }
  return make_error(ErrorCode::kInternal, name_ + ": unknown projection kind");
}

Result<LonLat> Crs::to_lonlat(XY p) const {
  if (!std::isfinite(p.x) || !std::isfinite(p.y))
    return out_of_range(name_, "position (" + format_xy(p) + ") is not finite");
  switch (kind_) {
    case Kind::kGeographic:
      if (std::abs(p.y) > 90.0)
        return out_of_range(name_, "position (" + format_xy(p) + ") has a latitude beyond 90 degrees");
      return LonLat{p.x, p.y};
    case Kind::kUtm:
    case Kind::kTransverseMercator: {
      const double x = p.x - false_easting_;
      const double y = p.y - false_northing_;
      if (std::abs(x) > kMaxTmDistanceMetres)
        return out_of_range(name_, "position (" + format_xy(p) + ") is too far from the projection's central meridian");
      double lat = 0, lon = 0, gamma = 0, k = 0;
      utm_projection().Reverse(lon0_, x, y, lat, lon, gamma, k);
      if (!std::isfinite(lat) || !std::isfinite(lon))
        return out_of_range(name_, "position (" + format_xy(p) + ") has no geographic equivalent");
      return LonLat{GeographicLib::Math::AngNormalize(lon), lat};
    }
    case Kind::kWebMercator: {
      const double lon = p.x / kEarthRadiusMetres / kDegToRad;
      const double lat = std::atan(std::sinh(p.y / kEarthRadiusMetres)) / kDegToRad;
      return LonLat{GeographicLib::Math::AngNormalize(lon), lat};
    }
  }
  return make_error(ErrorCode::kInternal, name_ + ": unknown projection kind");
}

GroundScale Crs::ground_scale(XY p) const {
  switch (kind_) {
    case Kind::kGeographic: {
      // Length of one degree along a parallel (radius N cos(lat)) and along a
      // meridian (radius of curvature M) at this latitude.
      const double lat = std::isfinite(p.y) ? std::clamp(p.y, -90.0, 90.0) : 0.0;
      const GeographicLib::Ellipsoid& wgs84 = GeographicLib::Ellipsoid::WGS84();
      return GroundScale{wgs84.CircleRadius(lat) * kDegToRad, wgs84.MeridionalCurvatureRadius(lat) * kDegToRad};
    }
    case Kind::kUtm:
    case Kind::kTransverseMercator: {
      // A conformal projection stretches ground distances by k in every
      // direction, so one projected metre is 1/k metres on the ground.
      double k = k0_;
      const double x = p.x - false_easting_;
      if (std::isfinite(p.x) && std::isfinite(p.y) && std::abs(x) <= kMaxTmDistanceMetres) {
        double lat = 0, lon = 0, gamma = 0, kp = 0;
        utm_projection().Reverse(lon0_, x, p.y - false_northing_, lat, lon, gamma, kp);
        if (std::isfinite(kp) && kp > 0) k = kp;
      }
      return GroundScale{1.0 / k, 1.0 / k};
    }
    case Kind::kWebMercator: {
      // Spherical Mercator's scale is sec(lat): one CRS metre is cos(lat) ground metres.
      const double lat = std::isfinite(p.y) ? std::atan(std::sinh(p.y / kEarthRadiusMetres)) : 0.0;
      const double c = std::cos(lat);
      return GroundScale{c, c};
    }
  }
  return GroundScale{};
}

std::optional<LonLatBounds> lonlat_bounds(const Crs& crs, double x_min, double y_min, double x_max, double y_max) {
  const double xm = (x_min + x_max) / 2, ym = (y_min + y_max) / 2;
  const XY points[] = {{x_min, y_min}, {x_max, y_min}, {x_min, y_max}, {x_max, y_max},
                       {xm, y_min},    {xm, y_max},    {x_min, ym},    {x_max, ym}};
  std::optional<LonLatBounds> b;
  for (const XY& p : points) {
    auto ll = crs.to_lonlat(p);
    if (!ll.ok()) return std::nullopt;
    if (!b) b = LonLatBounds{ll->lon, ll->lat, ll->lon, ll->lat};
    b->west = std::min(b->west, ll->lon);
    b->east = std::max(b->east, ll->lon);
    b->south = std::min(b->south, ll->lat);
    b->north = std::max(b->north, ll->lat);
  }
  return b;
}

}  // namespace horizon::geodesy
