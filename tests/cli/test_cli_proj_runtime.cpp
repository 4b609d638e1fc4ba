// test_cli_proj_runtime.cpp — PROJ and libgeotiff are opened only when a CRS
// needs them (core/src/geodesy/proj_runtime.cpp,
// core/src/terrain/geotiff_runtime.cpp): a DEM in a built-in CRS (WGS 84, a
// UTM zone of WGS 84 or SIRGAS 2000, NAD83) is read and its viewshed written
// without loading either, though NAD83 loads PROJ for a position in WGS 84;
// another CRS loads PROJ; a user-defined CRS loads
// libgeotiff too; and a library that cannot be loaded is named in the CRS's
// error, while built-in CRSs work without it.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "cli_run.hpp"
#include "gdal_crs_cases.hpp"
#include "horizon/terrain/dem_reader.hpp"
#include "horizon/terrain/geotiff_writer.hpp"

namespace horizon::testing {
namespace {

namespace fs = std::filesystem;

// A 16 x 16 crop of the bundled Rainier DEM in a transverse Mercator CRS
// with no EPSG code (user-defined GeoKeys), made with gdal_translate; "" if
// that fails.
std::string user_defined_crs_dem(const TempDir& dir) {
  const std::string path = dir.file("tmerc.tif");
  const auto made = run_command(
      "gdal_translate -q -srcwin 0 0 16 16 -a_srs '+proj=tmerc +lat_0=0 +lon_0=-121 +k=0.9996 "
      "+x_0=500000 +y_0=0 +ellps=GRS80 +units=m +no_defs' -a_ullr 500000 5200000 500480 5199520 " +
      shell_quote(bundled_dem("rainier_summit_srtm3_400x400.tif")) + " " + shell_quote(path));
  EXPECT_EQ(made.exit_code, 0) << made.output;
  return made.exit_code == 0 ? path : std::string();
}

// A copy of a bundled DEM tagged with another EPSG code.
std::string retagged_dem(const TempDir& dir, const std::string& bundled, int epsg) {
  auto dem = terrain::read_dem(bundled_dem(bundled));
  EXPECT_TRUE(dem.ok());
  if (!dem.ok()) return {};
  dem->georef.epsg = epsg;
  const std::string path = dir.file("epsg" + std::to_string(epsg) + ".tif");
  const Status written = terrain::write_geotiff(path, dem->elevation, dem->georef, std::nullopt);
  EXPECT_TRUE(written.ok()) << written.error().message;
  return written.ok() ? path : std::string();
}

// The bundled Olinda DEM (SIRGAS 2000 / UTM zone 25S, built in) tagged
// SAD69 / UTM zone 25S (EPSG:29195), which is not: the same coordinates on
// a datum PROJ shifts to WGS 84 by a Helmert transformation.
std::string other_crs_dem(const TempDir& dir) {
  return retagged_dem(dir, "olinda_coast_utm25s_111x111.tif", 29195);
}

bool loaded(const CommandResult& r, const std::string& soname) {
  std::string needle = "file=";
  needle += soname;
  return r.output.find(needle) != std::string::npos;
}

TEST(CliProjRuntime, BuiltInCrsLoadsNeitherProjNorGeotiff) {
  TempDir dir;
  const std::vector<std::vector<std::string>> runs = {
      {"info", bundled_dem("ecuador_andes_utm17s_10m_383x415.tif")},
      {"viewshed", bundled_dem("rainier_summit_srtm3_400x400.tif"), "--observer", "-121.76,46.85", "-o",
       dir.file("v.tif")},
      {"viewshed", bundled_dem("olinda_coast_utm25s_111x111.tif"), "--observer", "293770,9115766", "-o",
       dir.file("o.tif")},
  };
  for (const auto& args : runs) {
    const auto r = horizon_with_env("LD_DEBUG", "files", args);
    ASSERT_EQ(r.exit_code, 0) << r.output;
    ASSERT_TRUE(loaded(r, "libtiff")) << "LD_DEBUG gave no list:\n" << r.output;
    EXPECT_FALSE(loaded(r, HORIZON_PROJ_SONAME)) << args[0] << " loaded PROJ";
    EXPECT_FALSE(loaded(r, HORIZON_GEOTIFF_SONAME)) << args[0] << " loaded libgeotiff";
  }
  EXPECT_TRUE(fs::exists(dir.file("v.tif")));
  EXPECT_TRUE(fs::exists(dir.file("o.tif")));
}

TEST(CliProjRuntime, Nad83LoadsProjOnlyForWgs84Positions) {
  // The Rainier crop's longitudes and latitudes tagged NAD83 (EPSG:4269).
  TempDir dir;
  const std::string path = retagged_dem(dir, "rainier_summit_srtm3_400x400.tif", 4269);
  ASSERT_FALSE(path.empty());
  const std::vector<std::string> viewshed = {"viewshed", path, "--observer", "-121.76,46.85", "-o", dir.file("n.tif")};
  const auto plain = horizon_with_env("LD_DEBUG", "files", viewshed);
  ASSERT_EQ(plain.exit_code, 0) << plain.output;
  ASSERT_TRUE(loaded(plain, "libtiff")) << "LD_DEBUG gave no list:\n" << plain.output;
  EXPECT_FALSE(loaded(plain, HORIZON_PROJ_SONAME)) << "a NAD83 viewshed loaded PROJ";
  // --json gives the observer's WGS 84 longitude and latitude: PROJ's datum transformation.
  std::vector<std::string> json = viewshed;
  json.push_back("--json");
  const auto with_json = horizon_with_env("LD_DEBUG", "files", json);
  ASSERT_EQ(with_json.exit_code, 0) << with_json.output;
  EXPECT_TRUE(loaded(with_json, HORIZON_PROJ_SONAME)) << with_json.output;
}

TEST(CliProjRuntime, OtherCrsLoadsProjWhenRead) {
  TempDir dir;
  const std::string path = other_crs_dem(dir);
  ASSERT_FALSE(path.empty());
  const auto r = horizon_with_env("LD_DEBUG", "files", {"info", path});
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(loaded(r, HORIZON_PROJ_SONAME)) << r.output;
  EXPECT_FALSE(loaded(r, HORIZON_GEOTIFF_SONAME)) << "an EPSG code needs no libgeotiff";
  EXPECT_NE(r.output.find("CRS:         EPSG:29195 (SAD69 / UTM zone 25S)"), std::string::npos) << r.output;
}

TEST(CliProjRuntime, UserDefinedCrsLoadsGeotiff) {
  if (!have_gdal()) GTEST_SKIP() << "gdal-bin is not installed (scripts/setup.sh installs it)";
  TempDir dir;
  const std::string path = user_defined_crs_dem(dir);
  ASSERT_FALSE(path.empty());
  const auto r = horizon_with_env("LD_DEBUG", "files", {"info", path});
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(loaded(r, HORIZON_GEOTIFF_SONAME)) << r.output;
  EXPECT_NE(r.output.find("projected (Transverse Mercator)"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("cannot be used"), std::string::npos) << r.output;
}

// A directory holding a file that is not a shared object under `soname`,
// for LD_LIBRARY_PATH to find first.
fs::path broken_library(const TempDir& dir, const std::string& soname) {
  const fs::path libs = dir.path() / ("broken_" + soname);
  fs::create_directories(libs);
  std::ofstream(libs / soname) << "not a shared object\n";
  return libs;
}

TEST(CliProjRuntime, UnloadableProjIsNamed) {
  TempDir dir;
  const fs::path libs = broken_library(dir, HORIZON_PROJ_SONAME);

  // Built-in CRSs need neither.
  const auto v = horizon_with_env("LD_LIBRARY_PATH", libs.string(),
                                  {"viewshed", bundled_dem("rainier_summit_srtm3_400x400.tif"), "--observer",
                                   "-121.76,46.85", "-o", dir.file("v.tif")});
  EXPECT_EQ(v.exit_code, 0) << v.output;
  const auto olinda =
      horizon_with_env("LD_LIBRARY_PATH", libs.string(), {"info", bundled_dem("olinda_coast_utm25s_111x111.tif")});
  EXPECT_NE(olinda.output.find("CRS:         EPSG:31985 (SIRGAS 2000 / UTM zone 25S)"), std::string::npos)
      << olinda.output;

  const std::string other = other_crs_dem(dir);
  ASSERT_FALSE(other.empty());
  const auto info = horizon_with_env("LD_LIBRARY_PATH", libs.string(), {"info", other});
  ASSERT_EQ(info.exit_code, 0) << info.output;
  EXPECT_NE(info.output.find("CRS:         cannot be used: "), std::string::npos) << info.output;
  // dlerror()'s reason, its directory cut as in every PROJ message.
  EXPECT_NE(info.output.find("PROJ cannot be loaded (" HORIZON_PROJ_SONAME ": "), std::string::npos) << info.output;

  const auto refused = horizon_with_env("LD_LIBRARY_PATH", libs.string(),
                                        {"viewshed", other, "--observer", "293770,9115766", "-o", dir.file("o.tif")});
  EXPECT_EQ(refused.exit_code, 1) << refused.output;
  EXPECT_NE(refused.output.find("PROJ cannot be loaded"), std::string::npos) << refused.output;
  EXPECT_FALSE(fs::exists(dir.file("o.tif")));
}

TEST(CliProjRuntime, UnloadableGeotiffIsNamed) {
  if (!have_gdal()) GTEST_SKIP() << "gdal-bin is not installed (scripts/setup.sh installs it)";
  TempDir dir;
  const std::string path = user_defined_crs_dem(dir);
  ASSERT_FALSE(path.empty());
  const fs::path libs = broken_library(dir, HORIZON_GEOTIFF_SONAME);
  const auto info = horizon_with_env("LD_LIBRARY_PATH", libs.string(), {"info", path});
  ASSERT_EQ(info.exit_code, 0) << info.output;
  EXPECT_NE(info.output.find("CRS:         cannot be used: a user-defined CRS whose keys libgeotiff cannot read "
                             "(libgeotiff cannot be loaded ("),
            std::string::npos)
      << info.output;
  // An EPSG code PROJ reads needs no libgeotiff.
  const auto other = horizon_with_env("LD_LIBRARY_PATH", libs.string(), {"info", other_crs_dem(dir)});
  EXPECT_NE(other.output.find("CRS:         EPSG:29195"), std::string::npos) << other.output;
}

}  // namespace
}  // namespace horizon::testing
