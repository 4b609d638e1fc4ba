// Tests for geodesy/crs.cpp. Reference coordinates were computed with PROJ
// (gdaltransform, GDAL 3.6) — an implementation independent of GeographicLib —
// and geographic scales from the WGS84 radii of curvature by hand.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>

#include "horizon/geodesy/crs.hpp"

namespace horizon::geodesy {
namespace {

Crs crs(int epsg) {
  auto c = Crs::from_epsg(epsg);
  EXPECT_TRUE(c.ok()) << epsg;
  return c.ok() ? c.value() : Crs::from_epsg(4326).value();
}

TEST(Crs, NamesAndKinds) {
  EXPECT_EQ(crs(4326).name(), "WGS 84");
  EXPECT_TRUE(crs(4326).is_geographic());
  EXPECT_TRUE(crs(4269).is_geographic());
  EXPECT_EQ(crs(32645).name(), "WGS 84 / UTM zone 45N");
  EXPECT_EQ(crs(32717).name(), "WGS 84 / UTM zone 17S");
  EXPECT_EQ(crs(26910).name(), "NAD83 / UTM zone 10N");
  EXPECT_EQ(crs(25832).name(), "ETRS89 / UTM zone 32N");
  EXPECT_EQ(crs(31965).name(), "SIRGAS 2000 / UTM zone 11N");
  EXPECT_EQ(crs(31976).name(), "SIRGAS 2000 / UTM zone 22N");
  EXPECT_EQ(crs(31977).name(), "SIRGAS 2000 / UTM zone 17S");
  EXPECT_EQ(crs(31985).name(), "SIRGAS 2000 / UTM zone 25S");
  EXPECT_FALSE(crs(2193).is_geographic());
  EXPECT_FALSE(crs(3857).is_geographic());
  EXPECT_EQ(crs(32601).epsg(), 32601);
  EXPECT_EQ(crs(32760).name(), "WGS 84 / UTM zone 60S");
}

TEST(Crs, RejectsUnsupportedCodes) {
  for (int epsg : {0, 3035, 32600, 32661, 32700, 32761, 26900, 26924, 25827, 25839, 31964, 31986, 27700, -1}) {
    auto c = Crs::from_epsg(epsg);
    ASSERT_FALSE(c.ok()) << epsg;
    EXPECT_EQ(c.error().code, ErrorCode::kUnsupported);
    EXPECT_NE(c.error().message.find("EPSG:" + std::to_string(epsg)), std::string::npos) << c.error().message;
  }
}

struct Known {
  int epsg;
  double lon, lat, x, y;
};

TEST(Crs, KnownProjectedCoordinates) {
  for (const Known& k : {
           Known{32631, 2.2945, 48.85826, 448251.857056711, 5411939.34735292},        // Eiffel Tower
           Known{32645, 86.925278, 27.988056, 492652.333326476, 3095881.52222629},    // Everest summit
           Known{32610, -121.760556, 46.852778, 594487.498381764, 5189549.77732758},  // Mt Rainier
           Known{31985, -34.85, -8.0, 296097.213640056, 9115243.88979289},            // Olinda coast
           Known{2193, 174.7767, -41.2784, 1748795.82814317, 5428814.89988414},       // Wellington, Beehive
           Known{3857, 138.7274, 35.3606, 15443063.5270748, 4212993.86452212},        // Mt Fuji
       }) {
    const Crs c = crs(k.epsg);
    auto xy = c.from_lonlat({k.lon, k.lat});
    ASSERT_TRUE(xy.ok()) << k.epsg << ": " << xy.error().message;
    // PROJ uses GRS80 for 2193/31985; it differs from WGS84 by < 1 mm here.
    EXPECT_NEAR(xy->x, k.x, 2e-3) << k.epsg;
    EXPECT_NEAR(xy->y, k.y, 2e-3) << k.epsg;
    auto ll = c.to_lonlat({k.x, k.y});
    ASSERT_TRUE(ll.ok()) << ll.error().message;
    EXPECT_NEAR(ll->lon, k.lon, 1e-7) << k.epsg;
    EXPECT_NEAR(ll->lat, k.lat, 1e-7) << k.epsg;
  }
}

TEST(Crs, UtmRoundTripsWithinMicrodegrees) {
  // Points across each zone (and a little beyond its edges), both hemispheres.
  for (int epsg : {32601, 32633, 32645, 32660, 32717, 32756, 26910, 25832, 31983}) {
    const Crs c = crs(epsg);
    const bool south = epsg > 32700 && epsg < 32800;
    const int zone = epsg >= 32601 && epsg <= 32660   ? epsg - 32600
                     : epsg >= 32701 && epsg <= 32760 ? epsg - 32700
                     : epsg >= 26901 && epsg <= 26923 ? epsg - 26900
                     : epsg >= 25828 && epsg <= 25838 ? epsg - 25800
                                                      : epsg - 31960;
    const double lon0 = 6.0 * zone - 183.0;
    for (double dlon : {-4.5, -3.0, 0.0, 1.7, 3.0, 4.5})
      for (double lat : {0.5, 12.0, 37.3, 60.0, 79.0}) {
        const LonLat p{lon0 + dlon, south ? -lat : lat};
        auto xy = c.from_lonlat(p);
        ASSERT_TRUE(xy.ok()) << xy.error().message;
        auto back = c.to_lonlat(xy.value());
        ASSERT_TRUE(back.ok()) << back.error().message;
        // Longitudes come back in [-180, 180]; compare modulo 360.
        EXPECT_NEAR(std::remainder(back->lon - p.lon, 360.0), 0.0, 1e-6) << epsg;
        EXPECT_NEAR(back->lat, p.lat, 1e-6) << epsg;
      }
  }
}

TEST(Crs, GeographicIsIdentity) {
  const Crs c = crs(4326);
  auto xy = c.from_lonlat({86.9, 27.9});
  ASSERT_TRUE(xy.ok());
  EXPECT_EQ(xy->x, 86.9);
  EXPECT_EQ(xy->y, 27.9);
  auto ll = c.to_lonlat({-122.5, 46.1});
  ASSERT_TRUE(ll.ok());
  EXPECT_EQ(ll->lon, -122.5);
  EXPECT_EQ(ll->lat, 46.1);
}

TEST(Crs, WebMercatorRoundTrip) {
  const Crs c = crs(3857);
  for (double lat : {-85.0, -45.0, 0.0, 35.3606, 85.0})
    for (double lon : {-179.9, -10.0, 0.0, 138.7274}) {
      auto xy = c.from_lonlat({lon, lat});
      ASSERT_TRUE(xy.ok());
      auto ll = c.to_lonlat(xy.value());
      ASSERT_TRUE(ll.ok());
      EXPECT_NEAR(ll->lon, lon, 1e-9);
      EXPECT_NEAR(ll->lat, lat, 1e-9);
    }
  // The square world: lon 180 at pi R.
  EXPECT_NEAR(c.from_lonlat({-180.0, 0.0})->x, -std::numbers::pi * kEarthRadiusMetres, 1e-6);
}

TEST(Crs, RejectsPositionsOutsideValidArea) {
  EXPECT_EQ(crs(4326).from_lonlat({0.0, 90.5}).error().code, ErrorCode::kOutOfRange);
  EXPECT_EQ(crs(4326).to_lonlat({0.0, -91.0}).error().code, ErrorCode::kOutOfRange);
  EXPECT_EQ(crs(3857).from_lonlat({0.0, 86.0}).error().code, ErrorCode::kOutOfRange);
  EXPECT_EQ(crs(32633).from_lonlat({15.0 + 60.0, 0.0}).error().code, ErrorCode::kOutOfRange);
  EXPECT_EQ(crs(32633).from_lonlat({std::nan(""), 0.0}).error().code, ErrorCode::kOutOfRange);
  EXPECT_EQ(crs(32633).to_lonlat({500000.0 + 5.0e6, 0.0}).error().code, ErrorCode::kOutOfRange);
  EXPECT_NE(crs(3857).from_lonlat({0.0, 86.0}).error().message.find("WGS 84 / Pseudo-Mercator"), std::string::npos);
}

TEST(Crs, GeographicGroundScaleAt45Degrees) {
  // WGS84: a = 6378137, e^2 = 0.00669437999014.
  // N(45) = a / sqrt(1 - e^2/2) = 6388838.29 m -> N cos(45) pi/180 = 78846.8 m per degree of longitude;
  // M(45) = a (1 - e^2) / (1 - e^2/2)^1.5 = 6367381.82 m -> 111131.75 m per degree of latitude.
  const GroundScale s = crs(4326).ground_scale({10.0, 45.0});
  EXPECT_NEAR(s.metres_per_x, 78846.8, 0.5);
  EXPECT_NEAR(s.metres_per_y, 111131.75, 0.5);
  // At the equator a degree of longitude is a * pi / 180.
  EXPECT_NEAR(crs(4326).ground_scale({0.0, 0.0}).metres_per_x, 111319.49, 0.01);
}

TEST(Crs, WebMercatorGroundScaleIsCosLat) {
  const Crs c = crs(3857);
  for (double lat : {0.0, 30.0, 46.85, 60.0, 80.0}) {
    const XY p = c.from_lonlat({7.0, lat}).value();
    const GroundScale s = c.ground_scale(p);
    EXPECT_NEAR(s.metres_per_x, std::cos(lat * std::numbers::pi / 180.0), 1e-12) << lat;
    EXPECT_DOUBLE_EQ(s.metres_per_x, s.metres_per_y);
  }
}

TEST(Crs, TransverseMercatorGroundScale) {
  // On the central meridian k = k0 = 0.9996; 180 km east k ~ k0 (1 + x^2 / 2R^2) ~ 1.0000.
  const Crs utm = crs(32633);
  EXPECT_NEAR(utm.ground_scale({500000.0, 5000000.0}).metres_per_x, 1.0 / 0.9996, 1e-9);
  EXPECT_NEAR(utm.ground_scale({680000.0, 5000000.0}).metres_per_x, 1.0, 1e-4);
  EXPECT_GT(utm.ground_scale({500000.0, 5000000.0}).metres_per_x, utm.ground_scale({800000.0, 5000000.0}).metres_per_x);
  const Crs nztm = crs(2193);
  EXPECT_NEAR(nztm.ground_scale({1600000.0, 5400000.0}).metres_per_y, 1.0 / 0.9996, 1e-9);
}

TEST(Crs, NorthZoneContinuesAcrossTheEquator) {
  // EPSG:32631 is a northern zone; a point at 1 S gets a negative northing
  // (no hemisphere jump), and comes back.
  const Crs c = crs(32631);
  auto xy = c.from_lonlat({3.0, -1.0});
  ASSERT_TRUE(xy.ok());
  EXPECT_NEAR(xy->y, -110538.0, 100.0);
  EXPECT_NEAR(c.to_lonlat(xy.value())->lat, -1.0, 1e-9);
}

}  // namespace
}  // namespace horizon::geodesy

namespace horizon::geodesy {
namespace {

TEST(LonLatBounds, GeographicRectangleIsItself) {
  auto wgs84 = Crs::from_epsg(4326);
  ASSERT_TRUE(wgs84.ok());
  auto b = lonlat_bounds(*wgs84, -122.0, 46.0, -121.0, 47.0);
  ASSERT_TRUE(b.has_value());
  EXPECT_DOUBLE_EQ(b->west, -122.0);
  EXPECT_DOUBLE_EQ(b->east, -121.0);
  EXPECT_DOUBLE_EQ(b->south, 46.0);
  EXPECT_DOUBLE_EQ(b->north, 47.0);
}

TEST(LonLatBounds, UtmRectangleEnvelopesItsCornersAndMidpoints) {
  // A 100 km square whose west edge is UTM 45N's central meridian (87 E), at
  // 27-28 N: the envelope holds every point of it, and its east edge lies just
  // past 88 E (a degree of longitude is ~98.6 km there).
  auto utm = Crs::from_epsg(32645);
  ASSERT_TRUE(utm.ok());
  auto b = lonlat_bounds(*utm, 500000.0, 3000000.0, 600000.0, 3100000.0);
  ASSERT_TRUE(b.has_value());
  for (XY p : {XY{500000.0, 3000000.0}, XY{600000.0, 3100000.0}, XY{550000.0, 3050000.0}}) {
    auto ll = utm->to_lonlat(p);
    ASSERT_TRUE(ll.ok());
    EXPECT_GE(ll->lon, b->west);
    EXPECT_LE(ll->lon, b->east);
    EXPECT_GE(ll->lat, b->south);
    EXPECT_LE(ll->lat, b->north);
  }
  EXPECT_NEAR(b->west, 87.0, 1e-9);  // x = 500000 is the central meridian
  EXPECT_GT(b->east, 88.0);
  EXPECT_LT(b->east, 88.1);
}

}  // namespace
}  // namespace horizon::geodesy
