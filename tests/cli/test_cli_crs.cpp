// `horizon info` and `horizon viewshed` on real GeoTIFFs in many CRSs
// (gdal_crs_cases.hpp, made by GDAL at test time): info names each CRS as
// gdalinfo does, a viewshed runs on each and its output carries the same CRS
// per gdalinfo; a CRS Horizon cannot use is named with what is unsupported,
// not reported as "none".
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <sstream>
#include <string>
#include <vector>

#include "gdal_crs_cases.hpp"
#include "horizon/geodesy/crs.hpp"
#include "horizon/terrain/dem_reader.hpp"
#include "cli_run.hpp"
#include "test_support.hpp"

namespace horizon::testing {
namespace {

using Json = nlohmann::json;

Json parse(const CommandResult& r) {
  Json j = Json::parse(r.output, nullptr, /*allow_exceptions=*/false);
  EXPECT_FALSE(j.is_discarded()) << "not JSON:\n" << r.output;
  return j;
}

// The CRS gdalinfo reads from a file, through PROJ.
geodesy::Crs gdal_crs(const std::string& path) {
  const auto r = run_command("gdalinfo -json " + shell_quote(path));
  EXPECT_EQ(r.exit_code, 0) << r.output;
  auto crs = geodesy::Crs::from_definition(parse(r)["coordinateSystem"]["wkt"].get<std::string>());
  EXPECT_TRUE(crs.ok()) << crs.error().message;
  return crs.ok() ? *crs : *geodesy::Crs::from_epsg(4326);
}

class CliCrs : public ::testing::TestWithParam<GdalCrsCase> {
 protected:
  void SetUp() override {
    if (!have_gdal()) GTEST_SKIP() << "gdal-bin is not installed (scripts/setup.sh installs it)";
    std::string error;
    path_ = make_gdal_crs_file(GetParam(), dir_.path(), &error);
    ASSERT_FALSE(path_.empty()) << error;
  }
  TempDir dir_;
  std::string path_;
};

TEST_P(CliCrs, InfoNamesTheCrsAsGdalDoes) {
  const GdalCrsCase& c = GetParam();
  const geodesy::Crs gdal = gdal_crs(path_);
  const auto r = horizon({"info", path_, "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json j = parse(r);
  ASSERT_TRUE(j["crs"].is_object()) << r.output;
  if (c.epsg) {
    EXPECT_EQ(j["crs"]["epsg"].get<int>(), c.epsg);
  } else {
    EXPECT_TRUE(j["crs"]["epsg"].is_null()) << j["crs"];
  }
  EXPECT_EQ(j["crs"]["name"].get<std::string>(), gdal.name());
  EXPECT_EQ(j["crs"]["geographic"].get<bool>(), gdal.is_geographic());
  EXPECT_EQ(j["crs"]["units"].get<std::string>(), gdal.unit_name());
  if (c.vertical_epsg) {
    EXPECT_EQ(j["crs"]["vertical"]["epsg"].get<int>(), c.vertical_epsg);
  } else {
    EXPECT_TRUE(j["crs"]["vertical"].is_null());
  }
  EXPECT_TRUE(j["crs_unusable"].is_null());
  EXPECT_TRUE(j["extent_lonlat"].is_object()) << r.output;

  const auto text = horizon({"info", path_});
  ASSERT_EQ(text.exit_code, 0) << text.output;
  // "CRS:  EPSG:27700 (OSGB36 / British National Grid), projected (Transverse
  // Mercator), units: metre"; a CRS without a code by its name, "user-defined"
  // alone where GDAL names it "unknown".
  const std::string named = c.epsg ? "EPSG:" + std::to_string(c.epsg) + " (" + gdal.horizontal_name() + ")"
                            : gdal.horizontal_name() == "unknown" ? std::string("user-defined")
                                                                  : gdal.horizontal_name() + " (user-defined)";
  const std::string kind = gdal.is_geographic() ? std::string("geographic") : "projected (" + gdal.projection() + ")";
  EXPECT_NE(text.output.find("CRS:         " + named + ", " + kind + ", units: " + gdal.unit_name() + "\n"),
            std::string::npos)
      << text.output;
  if (c.vertical_epsg) {
    EXPECT_NE(text.output.find("Heights:     EPSG:" + std::to_string(c.vertical_epsg)), std::string::npos)
        << text.output;
  }
  EXPECT_EQ(text.output.find("CRS:         none"), std::string::npos) << text.output;
}

TEST_P(CliCrs, ViewshedRunsAndItsOutputCarriesTheSameCrs) {
  auto dem = terrain::read_dem(path_);
  ASSERT_TRUE(dem.ok()) << dem.error().message;
  // The cell with data nearest the middle (SRTM has voids at the summit).
  int col = dem->width() / 2, row = dem->height() / 2;
  for (int r = 0; r < dem->height() / 2 && std::isnan(dem->elevation.at(col, row)); ++r) {
    col = dem->width() / 2 + r;
    row = dem->height() / 2 + r / 2;
  }
  ASSERT_FALSE(std::isnan(dem->elevation.at(col, row)));
  const auto& t = dem->georef.transform;
  const double x = t.x_at(col), y = t.y_at(row);
  const std::string out = dir_.file("view.tif");
  char observer[96];
  std::snprintf(observer, sizeof observer, "%.10f,%.10f", x, y);
  const auto r = horizon(
      {"viewshed", path_, "--observer", observer, "--height", "2", "--max-distance", "2000", "-o", out, "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json j = parse(r);
  EXPECT_GT(j["visible_cells"].get<long>(), 0) << r.output;

  const geodesy::Crs input = gdal_crs(path_), output = gdal_crs(out);
  EXPECT_TRUE(output.equivalent_to(input)) << output.wkt() << "\n  vs\n" << input.wkt();
  EXPECT_EQ(output.name(), input.name());
  EXPECT_EQ(output.epsg(), input.epsg());
  EXPECT_EQ(output.vertical_epsg(), input.vertical_epsg());
  // A Cloud-Optimised GeoTIFF (its layout moves every tag) carries it too.
  const std::string cog = dir_.file("view_cog.tif");
  const auto c = horizon({"viewshed", path_, "--observer", observer, "--height", "2", "--max-distance", "2000",
                          "--format", "COG", "-o", cog});
  ASSERT_EQ(c.exit_code, 0) << c.output;
  const geodesy::Crs laid_out = gdal_crs(cog);
  EXPECT_TRUE(laid_out.equivalent_to(input)) << laid_out.wkt() << "\n  vs\n" << input.wkt();
  EXPECT_EQ(laid_out.name(), input.name());
  EXPECT_EQ(laid_out.vertical_epsg(), input.vertical_epsg());

  // The same observer given in WGS 84, as gdaltransform places the cell's
  // centre (pixel/line col + 0.5, row + 0.5 of the file), lands on the same
  // cell and sees the same.
  const auto placed = run_command("echo " + std::to_string(col) + ".5 " + std::to_string(row) +
                                  ".5 | gdaltransform -output_xy -t_srs EPSG:4326 " + shell_quote(path_));
  ASSERT_EQ(placed.exit_code, 0) << placed.output;
  std::string lon, lat;
  std::istringstream(placed.output) >> lon >> lat;
  const auto wgs84 = horizon({"viewshed", path_, "--lat", lat, "--lon", lon, "--height", "2", "--max-distance", "2000",
                              "-o", dir_.file("view84.tif"), "--json"});
  ASSERT_EQ(wgs84.exit_code, 0) << wgs84.output;
  const Json k = parse(wgs84);
  EXPECT_NEAR(k["observer"]["col"].get<double>(), j["observer"]["col"].get<double>(), 1e-6);
  EXPECT_NEAR(k["observer"]["row"].get<double>(), j["observer"]["row"].get<double>(), 1e-6);
  EXPECT_EQ(k["visible_cells"], j["visible_cells"]);
}

INSTANTIATE_TEST_SUITE_P(RealFiles, CliCrs, ::testing::ValuesIn(gdal_crs_cases()),
                         [](const ::testing::TestParamInfo<GdalCrsCase>& p) { return p.param.name; });

// A CRS Horizon cannot use: `info` names it and says what is unsupported;
// the other commands refuse the file with the same words.
TEST(CliCrsUnusable, InfoSaysWhatIsUnsupported) {
  if (!have_gdal()) GTEST_SKIP() << "gdal-bin is not installed";
  TempDir dir;
  const std::string source = bundled_dem("rainier_summit_srtm3_400x400.tif");
  struct Case {
    const char* file;
    const char* srs;
    const char* says;
  };
  for (const Case& c : {
           Case{"geocentric.tif", "EPSG:4978", "geocentric"},
           Case{"local.tif", R"(LOCAL_CS["Site grid",UNIT["metre",1]])", "Site grid"},
           Case{"feet_heights.tif", "EPSG:2227+6360", "US survey foot"},
       }) {
    const std::string path = dir.file(c.file);
    const auto made = run_command("gdal_translate -q -srcwin 0 0 16 16 -a_srs " + shell_quote(c.srs) +
                                  " -a_ullr 1000 2000 1480 1520 " + shell_quote(source) + " " + shell_quote(path));
    ASSERT_EQ(made.exit_code, 0) << made.output;
    const auto text = horizon({"info", path});
    ASSERT_EQ(text.exit_code, 0) << text.output;
    EXPECT_NE(text.output.find("CRS:         cannot be used: "), std::string::npos) << text.output;
    EXPECT_NE(text.output.find(c.says), std::string::npos) << text.output;
    const Json j = parse(horizon({"info", path, "--json"}));
    EXPECT_TRUE(j["crs"].is_null());
    EXPECT_NE(j["crs_unusable"].get<std::string>().find(c.says), std::string::npos) << j.dump();

    const auto refused = horizon({"viewshed", path, "--observer", "1200,1800", "-o", dir.file("v.tif")});
    EXPECT_EQ(refused.exit_code, 1) << refused.output;
    EXPECT_NE(refused.output.find(c.says), std::string::npos) << refused.output;
    EXPECT_NE(refused.output.find(c.file), std::string::npos) << refused.output;
  }
}

TEST(CliCrsUnusable, PlainGridStillSaysNone) {
  // A TIFF with no CRS keys at all: "none", as before.
  if (!have_gdal()) GTEST_SKIP() << "gdal-bin is not installed";
  TempDir dir;
  const std::string path = dir.file("plain.tif");
  const auto made = run_command("gdal_translate -q -srcwin 0 0 16 16 -co PROFILE=BASELINE " +
                                shell_quote(bundled_dem("rainier_summit_srtm3_400x400.tif")) + " " + shell_quote(path));
  ASSERT_EQ(made.exit_code, 0) << made.output;
  const auto text = horizon({"info", path});
  ASSERT_EQ(text.exit_code, 0) << text.output;
  EXPECT_NE(text.output.find("CRS:         none (grid coordinates only)"), std::string::npos) << text.output;
}

}  // namespace
}  // namespace horizon::testing
