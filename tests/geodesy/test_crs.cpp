// Tests for geodesy/crs.cpp. Reference coordinates were computed with
// gdaltransform (GDAL 3.6 on PROJ 9.1), geographic scales from the WGS84
// radii of curvature by hand, projected ones against geodesic distances
// (GeographicLib::Geodesic, independent of PROJ). tests/terrain/test_geotiff_crs.cpp
// checks real GeoTIFFs in many CRSs against gdalinfo and gdaltransform live.
#include <gtest/gtest.h>

#include <GeographicLib/Geodesic.hpp>

#include <atomic>
#include <cmath>
#include <numbers>
#include <string>
#include <thread>
#include <vector>

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

TEST(Crs, AcceptsAnyEpsgCrsProjKnows) {
  // National grids, LAEA, Lambert conformal, polar stereographic, oblique
  // Mercator, feet: all from PROJ's database.
  struct Case {
    int epsg;
    const char* name;
    const char* projection;
    const char* unit;
  };
  for (const Case& c :
       {Case{27700, "OSGB36 / British National Grid", "Transverse Mercator", "metre"},
        Case{3035, "ETRS89-extended / LAEA Europe", "Lambert Azimuthal Equal Area", "metre"},
        Case{2154, "RGF93 v1 / Lambert-93", "Lambert Conic Conformal (2SP)", "metre"},
        Case{3413, "WGS 84 / NSIDC Sea Ice Polar Stereographic North", "Polar Stereographic (variant B)", "metre"},
        Case{2056, "CH1903+ / LV95", "Hotine Oblique Mercator (variant B)", "metre"},
        Case{2227, "NAD83 / California zone 3 (ftUS)", "Lambert Conic Conformal (2SP)", "US survey foot"}}) {
    const Crs k = crs(c.epsg);
    EXPECT_EQ(k.name(), c.name);
    EXPECT_EQ(k.epsg(), c.epsg);
    EXPECT_EQ(k.horizontal_epsg(), c.epsg);
    EXPECT_FALSE(k.is_geographic());
    EXPECT_FALSE(k.is_compound());
    EXPECT_EQ(k.projection(), c.projection);
    EXPECT_EQ(k.unit_name(), c.unit);
  }
  EXPECT_NEAR(crs(2227).unit_size(), 1200.0 / 3937.0, 1e-15);
  EXPECT_EQ(crs(4807).unit_name(), "grad");  // NTF (Paris): grads from the Paris meridian
  EXPECT_NEAR(crs(4807).unit_size(), 0.9, 1e-15);
}

TEST(Crs, CompoundCrsUsesItsHorizontalPart) {
  for (const std::string& definition : {std::string("EPSG:7405"), std::string("EPSG:27700+5701")}) {
    auto c = Crs::from_definition(definition);
    ASSERT_TRUE(c.ok()) << c.error().message;
    EXPECT_EQ(c->name(), "OSGB36 / British National Grid + ODN height");
    EXPECT_EQ(c->horizontal_epsg(), 27700);
    EXPECT_EQ(c->horizontal_name(), "OSGB36 / British National Grid");
    EXPECT_EQ(c->vertical_epsg(), 5701);
    EXPECT_EQ(c->vertical_name(), "ODN height");
    EXPECT_TRUE(c->is_compound());
    // The same positions as the horizontal CRS alone.
    const XY a = c->from_lonlat({-3.1883, 55.9533}).value(), b = crs(27700).from_lonlat({-3.1883, 55.9533}).value();
    EXPECT_EQ(a.x, b.x);
    EXPECT_EQ(a.y, b.y);
  }
  EXPECT_EQ(Crs::from_definition("EPSG:7405")->epsg(), 7405);
  EXPECT_EQ(Crs::from_definition("EPSG:27700+5701")->epsg(), 0);  // no single code names the pair
  // A 3D geographic CRS works as its 2D self.
  EXPECT_TRUE(crs(4979).is_geographic());
  EXPECT_EQ(crs(4979).horizontal_epsg(), 4326);
}

TEST(Crs, UserDefinedDefinitions) {
  // A PROJ string and WKT; the WKT of an EPSG CRS is equivalent to its code.
  auto aeqd = Crs::from_definition(
      "+proj=aeqd +lat_0=46.85 +lon_0=-121.76 +x_0=1000 +y_0=2000 +datum=WGS84 +units=m +type=crs");
  ASSERT_TRUE(aeqd.ok()) << aeqd.error().message;
  EXPECT_EQ(aeqd->epsg(), 0);
  EXPECT_FALSE(aeqd->is_geographic());
  EXPECT_NE(aeqd->wkt().find("PROJCRS"), std::string::npos);
  const XY centre = aeqd->from_lonlat({-121.76, 46.85}).value();
  EXPECT_NEAR(centre.x, 1000.0, 1e-6);
  EXPECT_NEAR(centre.y, 2000.0, 1e-6);
  auto from_wkt = Crs::from_definition(crs(27700).wkt());
  ASSERT_TRUE(from_wkt.ok()) << from_wkt.error().message;
  EXPECT_TRUE(from_wkt->equivalent_to(crs(27700)));
  EXPECT_FALSE(from_wkt->equivalent_to(crs(3035)));
  EXPECT_TRUE(aeqd->equivalent_to(*aeqd));
}

TEST(Crs, RejectsWhatItCannotUseSayingWhat) {
  struct Case {
    std::string definition;
    const char* says;
  };
  for (const Case& c : {
           Case{"EPSG:0", "EPSG:0"},
           Case{"EPSG:99999", "EPSG:99999"},
           Case{"EPSG:5714", "vertical"},             // MSL height alone
           Case{"EPSG:4978", "geocentric"},           // WGS 84 X/Y/Z
           Case{"EPSG:2227+6360", "US survey foot"},  // heights in feet
           Case{"+proj=ob_tran +o_proj=longlat +o_lon_p=0 +o_lat_p=30 +lon_0=0 +datum=WGS84 +type=crs", "rotated-pole"},
           Case{R"(ENGCRS["Site grid",EDATUM["Site"],CS[Cartesian,2],AXIS["x",east,LENGTHUNIT["metre",1]],)"
                R"(AXIS["y",north,LENGTHUNIT["metre",1]]])",
                "engineering"},
           Case{"IAU_2015:49900", "WGS 84"},  // Mars: no way to the Earth
           Case{"not a crs", "not a crs"},
       }) {
    auto k = c.definition == "EPSG:0" ? Crs::from_epsg(0) : Crs::from_definition(c.definition);
    ASSERT_FALSE(k.ok()) << c.definition;
    EXPECT_EQ(k.error().code, ErrorCode::kUnsupported) << c.definition;
    EXPECT_NE(k.error().message.find(c.says), std::string::npos) << k.error().message;
  }
  EXPECT_EQ(Crs::from_epsg(-1).error().code, ErrorCode::kUnsupported);
  EXPECT_EQ(Crs::from_definition("").error().code, ErrorCode::kInvalidArgument);
  terrain::Georeference none;
  EXPECT_EQ(Crs::of(none).error().code, ErrorCode::kInvalidArgument);
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
           // gdaltransform -s_srs EPSG:4326 -t_srs EPSG:n (OSGB36 and CH1903+ through their Helmert shifts).
           Known{27700, -3.1883, 55.9533, 325897.218139444, 674001.201609759},    // Edinburgh
           Known{3035, -9.1393, 38.7223, 2665519.21431248, 1946764.04481795},     // Lisbon
           Known{2154, 2.2945, 48.85826, 648237.162462836, 6862256.11484876},     // Eiffel Tower
           Known{3413, -51.7216, 64.1835, -332761.317290066, -2823475.61828632},  // Nuuk
           Known{3031, 166.6683, -77.8419, 305710.558991267, -1290058.15860091},  // McMurdo
           Known{2056, 7.6586, 45.9763, 2617047.96070803, 1091660.42370227},      // Matterhorn
           Known{2227, -122.4783, 37.8199, 5990283.75382575, 2127045.51823977},   // Golden Gate (US feet)
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
  EXPECT_EQ(crs(32633).from_lonlat({std::nan(""), 0.0}).error().code, ErrorCode::kOutOfRange);
  // LAEA Europe has no image of its centre's antipode, Lambert-93 none of the south pole.
  EXPECT_EQ(crs(3035).from_lonlat({-170.0, -52.0}).error().code, ErrorCode::kOutOfRange);
  EXPECT_EQ(crs(2154).from_lonlat({2.0, -90.0}).error().code, ErrorCode::kOutOfRange);
  // 89 degrees from the central meridian, off the equator, transverse Mercator has no answer.
  EXPECT_EQ(crs(32633).from_lonlat({15.0 + 89.0, 10.0}).error().code, ErrorCode::kOutOfRange);
  EXPECT_EQ(crs(32633).to_lonlat({5.0e7, 0.0}).error().code, ErrorCode::kOutOfRange);
  const std::string laea = crs(3035).from_lonlat({-170.0, -52.0}).error().message;
  EXPECT_NE(laea.find("ETRS89-extended / LAEA Europe"), std::string::npos) << laea;
  EXPECT_NE(laea.find("lon -170, lat -52"), std::string::npos) << laea;
  EXPECT_NE(crs(32633).from_lonlat({104.0, 10.0}).error().message.find("lon 104, lat 10"), std::string::npos);
}

TEST(Crs, PositionsWherePROJPicksAnotherTransformationBackStillConvert) {
  // East of Shetland, at the edge of the OSGB36 -> WGS 84 Helmert
  // transformation's area: WGS 84 -> OSGB36 takes the Helmert shift and the
  // way back PROJ's datum-less fallback, ~150 m apart. The position is fine;
  // gdaltransform -s_srs EPSG:4326 -t_srs EPSG:27700 gives the same answer.
  auto xy = crs(27700).from_lonlat({2.0, 60.0});
  ASSERT_TRUE(xy.ok()) << xy.error().message;
  EXPECT_NEAR(xy->x, 622998.296546202, 1e-3);
  EXPECT_NEAR(xy->y, 1130592.52486683, 1e-3);
  // And back as gdaltransform -s_srs EPSG:27700 -t_srs EPSG:4326 does.
  auto ll = crs(27700).to_lonlat(*xy);
  ASSERT_TRUE(ll.ok()) << ll.error().message;
  EXPECT_NEAR(ll->lon, 1.99763733916393, 1e-9);
  EXPECT_NEAR(ll->lat, 59.9995437854552, 1e-9);
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

TEST(Crs, WebMercatorGroundScaleOnTheEllipsoid) {
  // EPSG:3857 puts WGS 84 latitudes into spherical formulas on a = 6378137:
  // x = a lon, y = a ln tan(pi/4 + lat/2). On the ellipsoid one metre of x
  // is N cos(lat) / a ground metres and one of y M cos(lat) / a (not the
  // sphere's cos(lat) for both: 0.18 % apart at 46.85 N).
  const Crs c = crs(3857);
  const double e2 = 0.00669437999014;
  for (double lat : {0.0, 30.0, 46.85, 60.0, 80.0}) {
    const double phi = lat * std::numbers::pi / 180.0, w = 1.0 - e2 * std::sin(phi) * std::sin(phi);
    const XY p = c.from_lonlat({7.0, lat}).value();
    const GroundScale s = c.ground_scale(p);
    EXPECT_NEAR(s.metres_per_x, std::cos(phi) / std::sqrt(w), 1e-9) << lat;
    EXPECT_NEAR(s.metres_per_y, std::cos(phi) * (1.0 - e2) / (w * std::sqrt(w)), 1e-9) << lat;
  }
}

// Geodesic length (WGS 84) of `units` CRS units along x or y from p.
double geodesic_metres(const Crs& c, XY p, double dx, double dy) {
  const LonLat a = c.to_lonlat({p.x - dx / 2, p.y - dy / 2}).value(),
               b = c.to_lonlat({p.x + dx / 2, p.y + dy / 2}).value();
  double s12 = 0;
  GeographicLib::Geodesic::WGS84().Inverse(a.lat, a.lon, b.lat, b.lon, s12);
  return s12;
}

TEST(Crs, ProjectedGroundScaleIsTheGeodesicLengthOfTheGridAxes) {
  // Where a projection is far from conformal, or its grid far from the
  // meridians, each axis still gets its own true length: LAEA Europe at
  // Lisbon and at Moscow, polar stereographic at Nuuk, Lambert-93, the
  // British grid, web Mercator, feet, SWEREF 99 TM (its axes northing
  // first, as EPSG defines them).
  //
  // The scale is that of the CRS's own ellipsoid; the geodesics here are on
  // WGS 84, reached through the datum transformation. For datums that match
  // WGS 84 to a metre (ETRS89, RGF93, NAD83) the two agree to 1e-8; OSGB36's
  // Helmert transformation to WGS 84 carries a scale of -20.5 ppm, and
  // Airy's surface lies ~50 m from WGS 84's there: 29 ppm in all, within
  // 4e-5 (the own-ellipsoid test below is exact for such CRSs).
  struct Case {
    int epsg;
    double lon, lat;
    double tolerance;
  };
  for (const Case& k : {Case{3035, -9.14, 38.72, 1e-7}, Case{3035, 37.6, 55.75, 1e-7}, Case{3413, -51.72, 64.18, 1e-7},
                        Case{3031, 166.67, -77.84, 1e-7}, Case{2154, 2.29, 48.86, 1e-7}, Case{3857, 7.0, 46.85, 1e-7},
                        Case{2227, -122.48, 37.82, 1e-7}, Case{3006, 18.07, 59.33, 1e-7},
                        Case{27700, -3.19, 55.95, 4e-5}, Case{2056, 7.66, 45.98, 4e-5}}) {
    const Crs c = crs(k.epsg);
    const XY p = c.from_lonlat({k.lon, k.lat}).value();
    const GroundScale s = c.ground_scale(p);
    const double d = 30.0 / c.unit_size();  // a 30 m cell, in CRS units
    EXPECT_NEAR(s.metres_per_x * d / geodesic_metres(c, p, d, 0), 1.0, k.tolerance) << k.epsg;
    EXPECT_NEAR(s.metres_per_y * d / geodesic_metres(c, p, 0, d), 1.0, k.tolerance) << k.epsg;
  }
  // LAEA is far from conformal there: x and y lengths differ by percents.
  const Crs laea = crs(3035);
  const GroundScale moscow = laea.ground_scale(laea.from_lonlat({37.6, 55.75}).value());
  EXPECT_GT(std::abs(moscow.metres_per_x - moscow.metres_per_y), 0.005);
}

TEST(Crs, ProjectedGroundScaleOnTheCrsOwnEllipsoid) {
  // A CRS on a datum PROJ knows no transformation for reaches WGS 84 by its
  // "ballpark" (latitude and longitude kept as they are), so to_lonlat gives
  // the CRS's own geodetic coordinates: geodesics on its own ellipsoid then
  // check the scale exactly. The British grid's projection on Airy, in
  // metres and in international feet; Lambert zone II on Clarke 1880 (IGN)
  // from the Paris meridian (PROJ's operation is then a pipeline).
  struct Case {
    const char* definition;
    double lon, lat;
    double a, b;
  };
  const char* bng = "+proj=tmerc +lat_0=49 +lon_0=-2 +k=0.9996012717 +x_0=400000 +y_0=-100000 +ellps=airy";
  for (const Case& k :
       {Case{"+units=m", -3.19, 55.95, 6377563.396, 6356256.909},
        Case{"+units=ft", -3.19, 55.95, 6377563.396, 6356256.909}, Case{nullptr, 2.5, 47.0, 6378249.2, 6356515.0}}) {
    const std::string definition =
        k.definition ? std::string(bng) + " " + k.definition + " +type=crs"
                     : "+proj=lcc +lat_1=46.8 +lat_0=46.8 +lon_0=0 +k_0=0.99987742 +x_0=600000 +y_0=2200000 "
                       "+a=6378249.2 +b=6356515 +pm=paris +units=m +type=crs";
    auto c = Crs::from_definition(definition);
    ASSERT_TRUE(c.ok()) << c.error().message;
    const GeographicLib::Geodesic own(k.a, (k.a - k.b) / k.a);
    const XY p = c->from_lonlat({k.lon, k.lat}).value();
    const GroundScale s = c->ground_scale(p);
    const double d = 30.0 / c->unit_size();
    const auto metres = [&](double dx, double dy) {
      const LonLat a = c->to_lonlat({p.x - dx / 2, p.y - dy / 2}).value();
      const LonLat b = c->to_lonlat({p.x + dx / 2, p.y + dy / 2}).value();
      double s12 = 0;
      own.Inverse(a.lat, a.lon, b.lat, b.lon, s12);
      return s12;
    };
    EXPECT_NEAR(s.metres_per_x * d / metres(d, 0), 1.0, 1e-8) << definition;
    EXPECT_NEAR(s.metres_per_y * d / metres(0, d), 1.0, 1e-8) << definition;
  }
}

TEST(Crs, ConcurrentUseGivesTheSameAnswers) {
  // Daemon workers share Crs handles: every thread converts through its own
  // PROJ context; the answers equal one thread's, bit for bit.
  const std::vector<int> codes = {27700, 3035, 2154, 3413, 32633, 4326};
  std::vector<XY> expected;
  for (int code : codes) expected.push_back(crs(code).from_lonlat({2.0, 60.0}).value());
  std::atomic<int> mismatches{0};
  std::vector<std::thread> threads;
  for (int t = 0; t < 8; ++t)
    threads.emplace_back([&, t] {
      for (int i = 0; i < 200; ++i) {
        const std::size_t k = static_cast<std::size_t>(t + i) % codes.size();
        auto c = Crs::from_epsg(codes[k]);
        if (!c.ok()) {
          ++mismatches;
          continue;
        }
        auto xy = c->from_lonlat({2.0, 60.0});
        if (!xy.ok() || xy->x != expected[k].x || xy->y != expected[k].y) ++mismatches;
        (void)c->ground_scale(expected[k]);
        (void)c->to_lonlat(expected[k]);
      }
    });
  for (std::thread& t : threads) t.join();
  EXPECT_EQ(mismatches.load(), 0);
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
