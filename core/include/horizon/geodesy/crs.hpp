// horizon/geodesy/crs.hpp — the horizontal coordinate systems Horizon handles.
//
// Supported EPSG codes (everything GeographicLib can express without a datum
// shift; datums are all treated as WGS84, an error well under 2 m for the
// ones listed):
//   geographic degrees, lon/lat order:  4326 (WGS 84), 4269 (NAD83),
//       4258 (ETRS89), 4283 (GDA94), 4167 (NZGD2000), 4674 (SIRGAS 2000)
//   UTM (GeographicLib::UTMUPS):        32601-32660, 32701-32760 (WGS 84),
//       26901-26923 (NAD83), 25828-25838 (ETRS89), 31965-31985 (SIRGAS 2000)
//   transverse Mercator:                2193 (NZGD2000 / NZTM2000)
//   spherical ("web") Mercator:         3857
// Anything else is ErrorCode::kUnsupported with the code in the message.
#pragma once

#include <optional>
#include <string>

#include "horizon/common/error.hpp"

namespace horizon::geodesy {

struct LonLat {
  double lon = 0.0;  // degrees east, [-180, 180)
  double lat = 0.0;  // degrees north
};

struct XY {
  double x = 0.0, y = 0.0;  // CRS units (metres or degrees)
};

// Ground metres per CRS unit along the CRS's x and y axes at one place. For
// projected CRSs both equal 1/k (k = the projection's point scale, ~0.9996 in
// UTM, 1/cos(lat) in web Mercator); for geographic CRSs they are the lengths
// of a degree of longitude and latitude on the WGS84 ellipsoid.
struct GroundScale {
  double metres_per_x = 1.0;
  double metres_per_y = 1.0;
};

class Crs {
 public:
  static Result<Crs> from_epsg(int epsg);

  int epsg() const { return epsg_; }
  bool is_geographic() const { return kind_ == Kind::kGeographic; }
  const std::string& name() const { return name_; }  // e.g. "WGS 84 / UTM zone 45N"

  // WGS84 longitude/latitude (degrees) -> CRS coordinates. Fails (kOutOfRange)
  // for latitudes beyond +-90, or outside the projection's valid area.
  Result<XY> from_lonlat(LonLat p) const;
  // CRS coordinates -> WGS84 longitude/latitude.
  Result<LonLat> to_lonlat(XY p) const;
  // Metric size of CRS units at a CRS point.
  GroundScale ground_scale(XY p) const;

 private:
  enum class Kind { kGeographic, kUtm, kTransverseMercator, kWebMercator };
  Kind kind_ = Kind::kGeographic;
  int epsg_ = 0;
  int zone_ = 0;            // UTM zone
  bool north_ = true;       // UTM hemisphere
  double lon0_ = 0.0, k0_ = 1.0, false_easting_ = 0.0, false_northing_ = 0.0;  // transverse Mercator
  std::string name_;
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
