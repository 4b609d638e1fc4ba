// Tests for visibility/viewshed_preview.cpp: the title names the observer in
// WGS 84 and in the DEM's own CRS, whatever that CRS is.
#include <gtest/gtest.h>

#include <string>

#include "horizon/geodesy/crs.hpp"
#include "horizon/visibility/viewshed_preview.hpp"

namespace horizon::visibility {
namespace {

std::string observer_line(const std::optional<geodesy::Crs>& crs, double x, double y) {
  ViewshedResult result;
  result.frame.eye = 1002.0;
  result.frame.max_distance = 1500.0;
  const PreviewCaption caption{.dem = "dem", .algorithm = "fast", .crs = crs, .x = x, .y = y, .ground = 1000.0};
  const auto title = viewshed_title(result, PreviewRaster::kVisibility, caption);
  EXPECT_EQ(title.size(), 2u);
  return title.size() == 2 ? title[1] : "";
}

geodesy::Crs crs(const std::string& definition) {
  auto c = geodesy::Crs::from_definition(definition);
  EXPECT_TRUE(c.ok()) << c.error().message;
  return c.ok() ? *c : *geodesy::Crs::from_epsg(4326);
}

TEST(ViewshedTitle, NamesTheObserverInAnyCrs) {
  // Edinburgh on the British grid: gdaltransform -s_srs EPSG:27700 -t_srs EPSG:4326 gives lon -3.1883, lat 55.9533.
  EXPECT_EQ(observer_line(crs("EPSG:27700"), 325897.218139444, 674001.201609759),
            "Observer 55.9533 N, 3.1883 W = x 325897, y 674001 (EPSG:27700); eye 2 m above the ground (1002 m); "
            "targets 0 m above the ground; reach 1.50 km; algorithm fast");
  // A compound CRS: its horizontal code.
  EXPECT_NE(observer_line(crs("EPSG:27700+5701"), 325897.218139444, 674001.201609759)
                .find("55.9533 N, 3.1883 W = x 325897, y 674001 (EPSG:27700)"),
            std::string::npos);
  // A CRS defined by its parameters: no code; "user-defined" when PROJ names it "unknown".
  EXPECT_NE(observer_line(crs("+proj=aeqd +lat_0=46.85 +lon_0=-121.76 +x_0=1000 +y_0=2000 +datum=WGS84 +type=crs"),
                          1000.0, 2000.0)
                .find("Observer 46.8500 N, 121.7600 W = x 1000, y 2000 (user-defined);"),
            std::string::npos);
  // Named, in ASCII (OpenImageIO draws no other glyphs).
  const std::string named =
      R"(PROJCRS["Gauß grid",BASEGEOGCRS["WGS 84",DATUM["World Geodetic System 1984",)"
      R"(ELLIPSOID["WGS 84",6378137,298.257223563]]],CONVERSION["tm",METHOD["Transverse Mercator"],)"
      R"(PARAMETER["Latitude of natural origin",0],PARAMETER["Longitude of natural origin",9],)"
      R"(PARAMETER["Scale factor at natural origin",1],PARAMETER["False easting",500000],)"
      R"(PARAMETER["False northing",0]],CS[Cartesian,2],AXIS["easting",east,LENGTHUNIT["metre",1]],)"
      R"(AXIS["northing",north,LENGTHUNIT["metre",1]]])";
  EXPECT_NE(observer_line(crs(named), 500000.0, 0.0).find("Observer 0.0000 N, 9.0000 E = x 500000, y 0 (Gau??"),
            std::string::npos)
      << observer_line(crs(named), 500000.0, 0.0);
  // Geographic: degrees alone. No CRS: the grid's own coordinates.
  EXPECT_NE(observer_line(crs("EPSG:4326"), -121.7604, 46.8529).find("Observer 46.8529 N, 121.7604 W; eye"),
            std::string::npos);
  EXPECT_NE(observer_line(std::nullopt, 12.0, 34.0).find("Observer x 12.0, y 34.0; eye"), std::string::npos);
}

}  // namespace
}  // namespace horizon::visibility
