// GeoTIFFs in many CRSs, made by GDAL at test time (gdal_crs_cases.hpp),
// read by Horizon and checked against GDAL itself: the georeference and CRS
// against gdalinfo -json, WGS 84 <-> CRS conversions against gdaltransform,
// ground cell sizes against geodesic distances (GeographicLib) between
// neighbouring cell centres placed by gdaltransform, and the GeoTIFF writer's
// keys against what gdalinfo reads back. Then every projection method the
// writer carries as user-defined keys, both ways through GDAL.
#include <gtest/gtest.h>

#include <GeographicLib/Geodesic.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "gdal_crs_cases.hpp"
#include "horizon/geodesy/crs.hpp"
#include "horizon/terrain/dem_reader.hpp"
#include "horizon/terrain/geotiff_writer.hpp"
#include "test_support.hpp"

namespace horizon::terrain {
namespace {

using geodesy::Crs;
using geodesy::LonLat;
using geodesy::XY;
using Json = nlohmann::json;
using testing::GdalCrsCase;
using testing::run_command;
using testing::shell_quote;
using testing::TempDir;

Json gdalinfo(const std::string& path) {
  const auto r = run_command("gdalinfo -json " + shell_quote(path));
  EXPECT_EQ(r.exit_code, 0) << r.output;
  Json j = Json::parse(r.output, nullptr, /*allow_exceptions=*/false);
  EXPECT_FALSE(j.is_discarded()) << r.output;
  return j;
}

// gdaltransform -s_srs FROM -t_srs TO on each point (x y per line).
std::vector<XY> gdaltransform(const std::string& from, const std::string& to, const std::vector<XY>& points,
                              const std::string& dir) {
  std::ofstream input(dir + "/points.txt");
  input.precision(17);
  for (const XY& p : points) input << p.x << ' ' << p.y << '\n';
  input.close();
  const auto r = run_command("gdaltransform -output_xy -s_srs " + shell_quote(from) + " -t_srs " + shell_quote(to) +
                             " < " + shell_quote(dir + "/points.txt"));
  EXPECT_EQ(r.exit_code, 0) << r.output;
  std::vector<XY> out;
  std::istringstream lines(r.output);
  XY p;
  while (lines >> p.x >> p.y) out.push_back(p);
  EXPECT_EQ(out.size(), points.size()) << r.output;
  return out;
}

// The WKT gdalinfo reports, saved to a file gdaltransform can be given.
std::string save_wkt(const Json& info, const std::string& path) {
  std::ofstream(path) << info["coordinateSystem"]["wkt"].get<std::string>();
  return path;
}

double metres_between(LonLat a, LonLat b) {
  double s12 = 0;
  GeographicLib::Geodesic::WGS84().Inverse(a.lat, a.lon, b.lat, b.lon, s12);
  return s12;
}

// Largest differences seen over all cases, printed at the end of the suite.
struct Worst {
  double to_lonlat_mm = 0, from_lonlat_mm = 0, cell_size_relative = 0;
  ~Worst() {
    if (to_lonlat_mm > 0 || from_lonlat_mm > 0)
      std::printf("[ crs vs GDAL ] worst CRS->WGS84 %.4f mm, WGS84->CRS %.4f mm, cell size %.2e relative\n",
                  to_lonlat_mm, from_lonlat_mm, cell_size_relative);
  }
};
Worst worst;

class GdalCrs : public ::testing::TestWithParam<GdalCrsCase> {
 protected:
  void SetUp() override {
    if (!testing::have_gdal()) GTEST_SKIP() << "gdal-bin is not installed (scripts/setup.sh installs it)";
    std::string error;
    path_ = make_gdal_crs_file(GetParam(), dir_.path(), &error);
    ASSERT_FALSE(path_.empty()) << error;
  }
  TempDir dir_;
  std::string path_;
};

TEST_P(GdalCrs, GeoreferenceAndCrsMatchGdalinfo) {
  const GdalCrsCase& c = GetParam();
  auto header = read_dem_header(path_);
  ASSERT_TRUE(header.ok()) << header.error().message;
  const Json info = gdalinfo(path_);
  EXPECT_EQ(header->width, info["size"][0].get<int>());
  EXPECT_EQ(header->height, info["size"][1].get<int>());
  const auto& t = header->georef.transform;
  const Json& g = info["geoTransform"];
  // gdalinfo prints 16 significant digits.
  const auto same = [](double ours, const Json& theirs) {
    EXPECT_NEAR(ours, theirs.get<double>(), 1e-14 * std::max(1.0, std::abs(ours))) << theirs;
  };
  same(t.origin_x, g[0]);
  same(t.pixel_width, g[1]);
  same(t.origin_y, g[3]);
  same(t.pixel_height, g[5]);
  EXPECT_EQ(g[2].get<double>(), 0.0);
  EXPECT_EQ(g[4].get<double>(), 0.0);

  EXPECT_EQ(header->georef.epsg, c.epsg);
  auto ours = Crs::of(header->georef);
  ASSERT_TRUE(ours.ok()) << ours.error().message;
  auto gdals = Crs::from_definition(info["coordinateSystem"]["wkt"].get<std::string>());
  ASSERT_TRUE(gdals.ok()) << gdals.error().message;
  EXPECT_TRUE(ours->equivalent_to(*gdals)) << ours->wkt() << "\n  vs GDAL's\n" << gdals->wkt();
  EXPECT_EQ(ours->name(), gdals->name());
  EXPECT_EQ(ours->horizontal_epsg(), gdals->horizontal_epsg());
  EXPECT_EQ(ours->vertical_epsg(), c.vertical_epsg);
  EXPECT_EQ(gdals->vertical_epsg(), c.vertical_epsg);
  EXPECT_EQ(ours->is_geographic(), c.srs == "EPSG:4326");
}

TEST_P(GdalCrs, ConversionsMatchGdaltransformToAMillimetre) {
  auto header = read_dem_header(path_);
  ASSERT_TRUE(header.ok()) << header.error().message;
  const Json info = gdalinfo(path_);
  const std::string wkt = save_wkt(info, dir_.file("crs.wkt"));
  auto crs = Crs::of(header->georef);
  ASSERT_TRUE(crs.ok()) << crs.error().message;
  const auto& t = header->georef.transform;
  // Cell centres at the corners, the middle and in between.
  std::vector<XY> cells;
  const double w = header->width - 1, h = header->height - 1;
  for (const auto& [col, row] : {std::pair{0.0, 0.0}, {w, 0.0}, {0.0, h}, {w, h}, {w / 2, h / 2}, {w / 3, 2 * h / 3}})
    cells.push_back({t.x_at(col), t.y_at(row)});

  const std::vector<XY> lonlats = gdaltransform(wkt, "EPSG:4326", cells, dir_.path());
  ASSERT_EQ(lonlats.size(), cells.size());
  for (std::size_t i = 0; i < cells.size(); ++i) {
    auto ll = crs->to_lonlat(cells[i]);
    ASSERT_TRUE(ll.ok()) << ll.error().message;
    const double mm = 1000.0 * metres_between(*ll, {lonlats[i].x, lonlats[i].y});
    EXPECT_LT(mm, 1.0) << "cell centre " << i << " (" << cells[i].x << ", " << cells[i].y << ")";
    worst.to_lonlat_mm = std::max(worst.to_lonlat_mm, mm);
  }

  const std::vector<XY> back = gdaltransform("EPSG:4326", wkt, lonlats, dir_.path());
  ASSERT_EQ(back.size(), lonlats.size());
  for (std::size_t i = 0; i < lonlats.size(); ++i) {
    auto xy = crs->from_lonlat({lonlats[i].x, lonlats[i].y});
    ASSERT_TRUE(xy.ok()) << xy.error().message;
    const double mm = 1000.0 * std::hypot(xy->x - back[i].x, xy->y - back[i].y) * crs->unit_size() *
                      (crs->is_geographic() ? 111320.0 : 1.0);
    EXPECT_LT(mm, 1.0) << "point " << i;
    worst.from_lonlat_mm = std::max(worst.from_lonlat_mm, mm);
  }
}

TEST_P(GdalCrs, GroundCellSizesAreGeodesicDistancesBetweenCellCentres) {
  auto header = read_dem_header(path_);
  ASSERT_TRUE(header.ok()) << header.error().message;
  const std::string wkt = save_wkt(gdalinfo(path_), dir_.file("crs.wkt"));
  auto crs = Crs::of(header->georef);
  ASSERT_TRUE(crs.ok()) << crs.error().message;
  const auto& t = header->georef.transform;
  // The centre cell and its east and north neighbours, placed by GDAL.
  const double col = header->width / 2, row = header->height / 2;
  const XY centre{t.x_at(col), t.y_at(row)};
  const std::vector<XY> cells = {{t.x_at(col - 0.5), centre.y},
                                 {t.x_at(col + 0.5), centre.y},
                                 {centre.x, t.y_at(row - 0.5)},
                                 {centre.x, t.y_at(row + 0.5)}};
  const std::vector<XY> ll = gdaltransform(wkt, "EPSG:4326", cells, dir_.path());
  ASSERT_EQ(ll.size(), 4u);
  const double east_west = metres_between({ll[0].x, ll[0].y}, {ll[1].x, ll[1].y});
  const double north_south = metres_between({ll[2].x, ll[2].y}, {ll[3].x, ll[3].y});
  const geodesy::GroundScale s = crs->ground_scale(centre);
  const double cell_x = std::abs(t.pixel_width) * s.metres_per_x, cell_y = std::abs(t.pixel_height) * s.metres_per_y;
  EXPECT_NEAR(cell_x / east_west, 1.0, 1e-3) << cell_x << " m against " << east_west << " m";
  EXPECT_NEAR(cell_y / north_south, 1.0, 1e-3) << cell_y << " m against " << north_south << " m";
  worst.cell_size_relative =
      std::max({worst.cell_size_relative, std::abs(cell_x / east_west - 1.0), std::abs(cell_y / north_south - 1.0)});
}

TEST_P(GdalCrs, WriterKeysReadBackTheSameCrsInGdal) {
  auto dem = read_dem(path_);
  ASSERT_TRUE(dem.ok()) << dem.error().message;
  const std::string out = dir_.file("written.tif");
  ASSERT_TRUE(write_geotiff(out, dem->elevation, dem->georef, dem->nodata).ok());
  const Json info = gdalinfo(out), source = gdalinfo(path_);
  auto written = Crs::from_definition(info["coordinateSystem"]["wkt"].get<std::string>());
  auto original = Crs::from_definition(source["coordinateSystem"]["wkt"].get<std::string>());
  ASSERT_TRUE(written.ok()) << written.error().message;
  ASSERT_TRUE(original.ok()) << original.error().message;
  EXPECT_TRUE(written->equivalent_to(*original)) << written->wkt() << "\n  vs\n" << original->wkt();
  EXPECT_EQ(written->name(), original->name());
  EXPECT_EQ(written->epsg(), original->epsg());
  EXPECT_EQ(written->vertical_epsg(), original->vertical_epsg());
  // And Horizon reads its own file back to the same georeference.
  auto again = read_dem_header(out);
  ASSERT_TRUE(again.ok()) << again.error().message;
  EXPECT_EQ(again->georef.transform, dem->georef.transform);
  EXPECT_EQ(again->georef.epsg, dem->georef.epsg);
  auto a = Crs::of(again->georef), b = Crs::of(dem->georef);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_TRUE(a->equivalent_to(*b));
}

INSTANTIATE_TEST_SUITE_P(RealFiles, GdalCrs, ::testing::ValuesIn(testing::gdal_crs_cases()),
                         [](const ::testing::TestParamInfo<GdalCrsCase>& p) { return p.param.name; });

// Every projection method GeoTIFF user-defined keys carry, both ways: GDAL
// writes the keys, Horizon reads them into the same CRS; Horizon writes them,
// GDAL reads the same CRS.
struct Method {
  const char* name;
  const char* proj;
  // Corners (-a_ullr) inside the projection's domain: near its false origin.
  const char* ullr = "1000 9000 1080 8920";
};

class UserDefinedMethod : public ::testing::TestWithParam<Method> {};

TEST_P(UserDefinedMethod, RoundTripsThroughGdal) {
  if (!testing::have_gdal()) GTEST_SKIP() << "gdal-bin is not installed";
  TempDir dir;
  const std::string made = dir.file("gdal.tif"), ours = dir.file("horizon.tif");
  const auto r = run_command(
      "gdal_translate -q -srcwin 0 0 8 8 -a_srs " + shell_quote(GetParam().proj) + " -a_ullr " + GetParam().ullr + " " +
      shell_quote(testing::bundled_dem("rainier_summit_srtm3_400x400.tif")) + " " + shell_quote(made));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  auto dem = read_dem(made);
  ASSERT_TRUE(dem.ok()) << dem.error().message;
  auto read = Crs::of(dem->georef);
  ASSERT_TRUE(read.ok()) << read.error().message;
  auto gdal_read = Crs::from_definition(gdalinfo(made)["coordinateSystem"]["wkt"].get<std::string>());
  ASSERT_TRUE(gdal_read.ok()) << gdal_read.error().message;
  EXPECT_TRUE(read->equivalent_to(*gdal_read)) << read->wkt() << "\n  vs GDAL's\n" << gdal_read->wkt();
  EXPECT_EQ(read->projection(), gdal_read->projection());

  const Status written = write_geotiff(ours, dem->elevation, dem->georef, dem->nodata);
  ASSERT_TRUE(written.ok()) << written.error().message;
  auto gdal_written = Crs::from_definition(gdalinfo(ours)["coordinateSystem"]["wkt"].get<std::string>());
  ASSERT_TRUE(gdal_written.ok()) << gdal_written.error().message;
  EXPECT_TRUE(gdal_written->equivalent_to(*gdal_read)) << gdal_written->wkt() << "\n  vs\n" << gdal_read->wkt();
}

INSTANTIATE_TEST_SUITE_P(
    Methods, UserDefinedMethod,
    ::testing::Values(
        Method{"TransverseMercator", "+proj=tmerc +lat_0=10 +lon_0=-3 +k=0.9995 +x_0=1000 +y_0=-50 +ellps=intl"},
        Method{"MercatorA", "+proj=merc +lon_0=20 +k=0.997 +x_0=100 +y_0=200 +ellps=WGS84"},
        Method{"MercatorB", "+proj=merc +lat_ts=33 +lon_0=20 +x_0=100 +y_0=200 +datum=WGS84"},
        Method{"LambertConformal1SP",
               "+proj=lcc +lat_1=46.8 +lat_0=46.8 +lon_0=2.3 +k_0=0.99987742 +x_0=600000 "
               "+y_0=2200000 +ellps=clrk80ign"},
        Method{"LambertConformal2SP",
               "+proj=lcc +lat_0=46.5 +lon_0=3 +lat_1=49 +lat_2=44 +x_0=700000 "
               "+y_0=6600000 +ellps=GRS80 +units=ft"},
        Method{"LambertAzimuthalEqualArea", "+proj=laea +lat_0=52 +lon_0=10 +x_0=4321000 +y_0=3210000 +ellps=GRS80"},
        Method{"AlbersEqualArea",
               "+proj=aea +lat_0=23 +lon_0=-96 +lat_1=29.5 +lat_2=45.5 +x_0=1 +y_0=2 "
               "+datum=NAD83"},
        Method{"AzimuthalEquidistant", "+proj=aeqd +lat_0=46.85 +lon_0=-121.76 +x_0=10 +y_0=20 +datum=WGS84"},
        Method{"EquidistantConic",
               "+proj=eqdc +lat_0=40 +lon_0=-96 +lat_1=20 +lat_2=60 +x_0=0 +y_0=0 "
               "+datum=WGS84"},
        Method{"PolarStereographicA",
               "+proj=stere +lat_0=-90 +lon_0=0 +k=0.994 +x_0=2000000 +y_0=2000000 "
               "+datum=WGS84"},
        Method{"PolarStereographicB", "+proj=stere +lat_0=90 +lat_ts=70 +lon_0=-45 +x_0=0 +y_0=0 +datum=WGS84"},
        Method{"ObliqueStereographic",
               "+proj=sterea +lat_0=52.156160556 +lon_0=5.387638889 +k=0.9999079 "
               "+x_0=155000 +y_0=463000 +ellps=bessel "
               "+towgs84=565.417,50.3319,465.552,-0.398957,0.343988,-1.8774,4.0725"},
        Method{"EquidistantCylindrical", "+proj=eqc +lat_ts=30 +lon_0=10 +x_0=0 +y_0=0 +datum=WGS84"},
        Method{"CassiniSoldner",
               "+proj=cass +lat_0=10.4416666666667 +lon_0=-61.3333333333333 +x_0=86501.46392052 "
               "+y_0=65379.0134283 +a=6378293.645208759 +b=6356617.987679838"},
        Method{"Orthographic", "+proj=ortho +lat_0=40 +lon_0=-100 +x_0=0 +y_0=0 +datum=WGS84"},
        Method{"Polyconic", "+proj=poly +lat_0=0 +lon_0=-54 +x_0=5000000 +y_0=10000000 +ellps=aust_SA",
               "5000000 10000080 5000080 10000000"},
        Method{"Sinusoidal", "+proj=sinu +lon_0=0 +x_0=0 +y_0=0 +datum=WGS84"},
        Method{"CylindricalEqualArea", "+proj=cea +lat_ts=30 +lon_0=0 +x_0=0 +y_0=0 +datum=WGS84"},
        Method{"HotineObliqueMercatorA",
               "+proj=omerc +lat_0=4 +lonc=102.25 +alpha=323.0257905 +k=0.99984 "
               "+x_0=804670.24 +y_0=0 +no_uoff +gamma=323.1301023611111 +ellps=evrst69"},
        Method{"HotineObliqueMercatorB",
               "+proj=omerc +lat_0=46.9524055555556 +lonc=7.43958333333333 +alpha=90 "
               "+gamma=90 +k=1 +x_0=2600000 +y_0=1200000 +ellps=bessel"},
        Method{"GeographicWithTowgs84", "+proj=longlat +ellps=bessel +towgs84=598.1,73.7,418.2,0.202,0.045,-2.455,6.7",
               "10 50 10.08 49.92"},
        Method{"GeographicOtherDatumCode", "EPSG:4230", "10 50 10.08 49.92"}),
    [](const ::testing::TestParamInfo<Method>& p) { return std::string(p.param.name); });

}  // namespace
}  // namespace horizon::terrain
