// The `horizon` binary end to end: exit codes, error messages that name the
// flag, nothing written on failure, and outputs (GeoTIFF, PNG, JSON) that are
// consistent with the input DEM.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "cli_run.hpp"
#include "test_support.hpp"

namespace horizon::testing {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

const std::string kRainier = "rainier_summit_srtm3_400x400.tif";    // EPSG:4326, nodata -32768
const std::string kAndes = "ecuador_andes_utm17s_10m_383x415.tif";  // EPSG:32717, nodata NaN
// Rainier's summit crater and a point on its western flank, both inside the crop.
const std::vector<std::string> kSummit = {"--lat", "46.8529", "--lon", "-121.7604"};

std::vector<std::string> concat(std::vector<std::string> a, const std::vector<std::string>& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

std::vector<std::string> files_in(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& entry : fs::recursive_directory_iterator(dir)) names.push_back(entry.path().string());
  return names;
}

bool have_gdalinfo() {
  return run_command("command -v gdalinfo").exit_code == 0;
}

CommandResult gdalinfo_json(const std::string& path) {
  std::string command = "gdalinfo -json ";
  command += shell_quote(path);
  return run_command(command);
}

Json parse_json(const CommandResult& r) {
  Json j = Json::parse(r.output, nullptr, /*allow_exceptions=*/false);
  EXPECT_FALSE(j.is_discarded()) << "not JSON:\n" << r.output;
  return j;
}

// ---------------------------------------------------------------- help, version

TEST(CliHelp, TopLevelHelpListsEveryCommand) {
  const auto r = horizon({"--help"});
  EXPECT_EQ(r.exit_code, 0) << r.output;
  for (const char* command : {"info", "viewshed", "los"}) EXPECT_NE(r.output.find(command), std::string::npos);
}

TEST(CliHelp, EveryCommandHasHelpBothWays) {
  for (const std::string command : {"info", "viewshed", "los"}) {
    const auto a = horizon({command, "--help"});
    const auto b = horizon({"help", command});
    EXPECT_EQ(a.exit_code, 0) << a.output;
    EXPECT_EQ(b.exit_code, 0) << b.output;
    EXPECT_EQ(a.output, b.output);
    EXPECT_NE(a.output.find("Usage: horizon " + command), std::string::npos) << a.output;
  }
  EXPECT_NE(horizon({"viewshed", "-h"}).output.find("--max-distance"), std::string::npos);
}

TEST(CliHelp, VersionPrintsProjectVersion) {
  const auto r = horizon({"--version"});
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_EQ(r.output.rfind("horizon ", 0), 0u) << r.output;
  EXPECT_NE(r.output.find('.'), std::string::npos) << r.output;
}

TEST(CliUsage, NoArgumentsIsAUsageError) {
  EXPECT_EQ(horizon({}).exit_code, 2);
}

TEST(CliUsage, UnknownCommandIsNamedWithAHint) {
  const auto r = horizon({"viewshad"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("'viewshad'"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("--help"), std::string::npos) << r.output;
  EXPECT_EQ(horizon({"help", "nope"}).exit_code, 2);
}

// ---------------------------------------------------------------- usage errors

struct UsageCase {
  std::vector<std::string> args;  // after "horizon"; DEM stands for the bundled Rainier crop, OUT for a fresh .tif
  std::string must_mention;       // the flag the message has to name
};

void PrintTo(const UsageCase& c, std::ostream* os) {
  for (const auto& a : c.args) *os << a << ' ';
}

class CliRejectsUsage : public ::testing::TestWithParam<UsageCase> {};

// "viewshed_DEM_o_OUT_lat_95_lon_121_76": the command line, readable.
std::string usage_name(const ::testing::TestParamInfo<UsageCase>& info) {
  std::string line;
  for (const auto& a : info.param.args) line += a + ' ';
  return readable_name(line);
}

TEST_P(CliRejectsUsage, ExitsTwoNamingTheFlagAndWritesNothing) {
  TempDir dir;
  std::vector<std::string> args;
  for (const std::string& a : GetParam().args)
    args.push_back(a == "DEM" ? bundled_dem(kRainier) : a == "OUT" ? dir.file("out.tif") : a);
  const auto r = horizon(args);
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("horizon: error: "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find(GetParam().must_mention), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("--help"), std::string::npos) << "no hint to run --help:\n" << r.output;
  EXPECT_TRUE(files_in(dir.path()).empty());
}

const std::vector<std::string> V = {"viewshed", "DEM", "-o", "OUT"};

INSTANTIATE_TEST_SUITE_P(
    Viewshed, CliRejectsUsage,
    ::testing::Values(UsageCase{{"viewshed", "DEM", "--bogus", "1"}, "--bogus"},
                      UsageCase{{"viewshed", "-o", "OUT", "--observer", "1,2"}, "DEM"},
                      UsageCase{{"viewshed", "DEM", "extra.tif", "--observer", "1,2", "-o", "OUT"}, "extra.tif"},
                      UsageCase{{"viewshed", "DEM", "-o", "OUT"}, "--observer"},
                      UsageCase{{"viewshed", "DEM", "--observer", "-121.76,46.85"}, "-o"},
                      UsageCase{concat(V, {"--observer", "1"}), "--observer"},
                      UsageCase{concat(V, {"--observer", "1,2,3"}), "--observer"},
                      UsageCase{concat(V, {"--observer", "a,b"}), "--observer"},
                      UsageCase{concat(V, {"--observer", "1,2", "--lat", "46"}), "--observer"},
                      UsageCase{concat(V, {"--lat", "46.85"}), "--lon"},
                      UsageCase{concat(V, {"--lat", "95", "--lon", "-121.76"}), "--lat"},
                      UsageCase{concat(concat(V, kSummit), {"--height", "nan"}), "--height"},
                      UsageCase{concat(concat(V, kSummit), {"--height", "inf"}), "--height"},
                      UsageCase{concat(concat(V, kSummit), {"--height", "-1"}), "--height"},
                      UsageCase{concat(concat(V, kSummit), {"--height", "2m"}), "--height"},
                      UsageCase{concat(concat(V, kSummit), {"--height"}), "--height"},
                      UsageCase{concat(concat(V, kSummit), {"--height", "1", "--height", "2"}), "--height"},
                      UsageCase{concat(concat(V, kSummit), {"--height", "1", "--altitude", "4400"}), "--altitude"},
                      UsageCase{concat(concat(V, kSummit), {"--altitude", "-inf"}), "--altitude"},
                      UsageCase{concat(concat(V, kSummit), {"--target-height", "-3"}), "--target-height"},
                      UsageCase{concat(concat(V, kSummit), {"--max-distance", "-5"}), "--max-distance"},
                      UsageCase{concat(concat(V, kSummit), {"--max-distance", "abc"}), "--max-distance"},
                      UsageCase{concat(concat(V, kSummit), {"-md", "-0.5"}), "-md"},
                      UsageCase{concat(V, {"-ox", "-121.76"}), "--observer-y"},
                      UsageCase{concat(V, {"-oy", "46.85", "-ox", "-121.76", "--lat", "46.85"}), "--lat"},
                      UsageCase{concat(concat(V, kSummit), {"--observer-ground", "centre"}), "--observer-ground"},
                      UsageCase{concat(concat(V, kSummit), {"--azimuth", "0,361"}), "--azimuth"},
                      UsageCase{concat(concat(V, kSummit), {"--pitch", "-91,0"}), "--pitch"},
                      UsageCase{concat(concat(V, kSummit), {"--min-distance", "x"}), "--min-distance"},
                      UsageCase{concat(concat(V, kSummit), {"--refraction", "-2"}), "--refraction"},
                      UsageCase{concat(concat(V, kSummit), {"-cc", "0.5", "--refraction", "0.5"}), "-cc"},
                      UsageCase{concat(concat(V, kSummit), {"-f", "JPEG"}), "-f"},
                      UsageCase{concat(concat(V, kSummit), {"-co", "BIGTIFF=MAYBE"}), "-co"},
                      UsageCase{concat(concat(V, kSummit), {"--curvature", "3"}), "--curvature"},
                      UsageCase{concat(concat(V, kSummit), {"--curvature", "NaN"}), "--curvature"},
                      UsageCase{concat(concat(V, kSummit), {"--nodata", "opaque"}), "--nodata"},
                      UsageCase{concat(concat(V, kSummit), {"--nodata", "fill:x"}), "--nodata"},
                      UsageCase{concat(concat(V, kSummit), {"--algorithm", "slow"}), "--algorithm"},
                      UsageCase{concat(concat(V, kSummit), {"--ray-spacing", "9"}), "--ray-spacing"},
                      UsageCase{concat(concat(V, kSummit), {"--backend", "quantum"}), "--backend"},
                      UsageCase{concat(concat(V, kSummit), {"--backend", "gpu", "--algorithm", "exact"}), "--backend"},
                      UsageCase{concat(concat(V, kSummit), {"--gpu-method", "x"}), "--gpu-method"},
                      UsageCase{concat(concat(V, kSummit), {"--gpu-propagation", "sideways"}), "--gpu-propagation"},
                      UsageCase{concat(concat(V, kSummit), {"--threads", "-2"}), "--threads"},
                      UsageCase{concat(concat(V, kSummit), {"--threads", "1.5"}), "--threads"},
                      UsageCase{concat(concat(V, kSummit), {"--output", "everything"}), "--output"},
                      UsageCase{concat(concat(V, kSummit), {"--band", "0"}), "--band"},
                      UsageCase{concat(concat(V, kSummit), {"--valid-range", "9000"}), "--valid-range"},
                      UsageCase{concat(concat(V, kSummit), {"--valid-range", "10,-10"}), "--valid-range"},
                      UsageCase{concat(concat(V, kSummit), {"--valid-range", "0,1", "--server", "h:1"}),
                                "--valid-range"},
                      UsageCase{concat(concat(V, kSummit), {"--json=yes"}), "--json"},
                      UsageCase{concat({"viewshed", "DEM", "-o", "x.png"}, kSummit), "-o"},
                      UsageCase{concat(concat(V, kSummit), {"--png", "preview.jpg"}), "--png"},
                      UsageCase{concat(concat(V, kSummit), {"--png", "OUT"}), "--png"}),
    usage_name);

INSTANTIATE_TEST_SUITE_P(
    InfoAndLos, CliRejectsUsage,
    ::testing::Values(
        UsageCase{{"info"}, "DEM"}, UsageCase{{"info", "DEM", "--band", "x"}, "--band"},
        UsageCase{{"info", "DEM", "--observer", "1,2"}, "--observer"},
        UsageCase{{"los", "DEM", "--from", "1,2"}, "--to"}, UsageCase{{"los", "DEM", "--to", "1,2"}, "--from"},
        UsageCase{{"los", "DEM", "--from", "1,2", "--to", "3"}, "--to"},
        UsageCase{{"los", "DEM", "--from", "1,2", "--to", "3,4", "--valid-range", "5,5"}, "--valid-range"},
        UsageCase{{"los", "DEM", "--from", "1,2", "--to-lat", "46"}, "--to-lon"},
        UsageCase{{"los", "DEM", "--from", "1,2", "--to", "3,4", "--from-height", "nan"}, "--from-height"},
        UsageCase{{"los", "DEM", "--from", "1,2", "--to", "3,4", "--to-height", "-1"}, "--to-height"},
        UsageCase{{"los", "DEM", "--from", "1,2", "--to", "3,4", "--curvature", "5"}, "--curvature"}),
    usage_name);

TEST(CliUsage, RefusesToOverwriteTheInputDem) {
  TempDir dir;
  const std::string dem = dir.file("dem.tif");
  fs::copy_file(bundled_dem(kRainier), dem);
  const std::string before = read_bytes(dem);
  for (const std::string& out : {dem, dir.path().string() + "/./dem.tif"}) {
    const auto r = horizon(concat({"viewshed", dem, "-o", out}, kSummit));
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_NE(r.output.find("input DEM"), std::string::npos) << r.output;
  }
  EXPECT_EQ(read_bytes(dem), before);
  EXPECT_EQ(files_in(dir.path()).size(), 1u);
}

// ---------------------------------------------------------------- failures (exit 1)

TEST(CliFailure, MissingDemIsNamed) {
  TempDir dir;
  const std::string missing = dir.file("no_such_dem.tif");
  for (const auto& args :
       {std::vector<std::string>{"info", missing}, concat({"viewshed", missing, "-o", dir.file("out.tif")}, kSummit),
        std::vector<std::string>{"los", missing, "--from", "1,2", "--to", "3,4"}}) {
    const auto r = horizon(args);
    EXPECT_EQ(r.exit_code, 1) << r.output;
    EXPECT_NE(r.output.find("horizon: error: "), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("no_such_dem.tif"), std::string::npos) << r.output;
  }
  EXPECT_EQ(files_in(dir.path()).size(), 0u);
}

TEST(CliFailure, ObserverOutsideTheDem) {
  TempDir dir;
  const auto r =
      horizon({"viewshed", bundled_dem(kRainier), "--lat", "45.0", "--lon", "-121.76", "-o", dir.file("out.tif")});
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("observer"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("outside"), std::string::npos) << r.output;
  EXPECT_TRUE(files_in(dir.path()).empty());

  const auto los = horizon({"los", bundled_dem(kRainier), "--from", "-121.76,46.85", "--to", "10,10"});
  EXPECT_EQ(los.exit_code, 1) << los.output;
  EXPECT_NE(los.output.find("to "), std::string::npos) << los.output;
}

TEST(CliFailure, MissingOutputDirectoryWritesNothing) {
  TempDir dir;
  const std::string out = dir.file("missing/sub/out.tif");
  const auto r = horizon(concat({"viewshed", bundled_dem(kRainier), "-o", out, "--png", dir.file("p.png")}, kSummit));
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("does not exist"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("missing/sub"), std::string::npos) << r.output;
  EXPECT_TRUE(files_in(dir.path()).empty()) << "the PNG must not be written either";

  const auto png = horizon(
      concat({"viewshed", bundled_dem(kRainier), "-o", dir.file("out.tif"), "--png", dir.file("nope/p.png")}, kSummit));
  EXPECT_EQ(png.exit_code, 1) << png.output;
  EXPECT_NE(png.output.find("--png"), std::string::npos) << png.output;
  EXPECT_TRUE(files_in(dir.path()).empty()) << "checked before computing: the GeoTIFF must not be written";
}

TEST(CliFailure, MissingImagePluginIsNamedAndNothingIsWritten) {
  // The PNG preview goes through libhorizon_imageio.so (OpenImageIO), opened on
  // first use; when it cannot be loaded the command says where it looked.
  TempDir dir;
  const std::string env = "HORIZON_IMAGEIO_PLUGIN=/nonexistent/libhorizon_imageio.so ";
  auto with_env = [&env](const std::vector<std::string>& args) {
    std::string command = env;
    command += shell_quote(HORIZON_CLI_PATH);
    for (const std::string& a : args) {
      command += ' ';
      command += shell_quote(a);
    }
    return run_command(command);
  };
  const auto r = with_env(
      concat({"viewshed", bundled_dem(kRainier), "-o", dir.file("out.tif"), "--png", dir.file("p.png")}, kSummit));
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("libhorizon_imageio.so"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("/nonexistent/libhorizon_imageio.so (absent)"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("HORIZON_IMAGEIO_PLUGIN"), std::string::npos) << r.output;
  EXPECT_TRUE(files_in(dir.path()).empty()) << "checked before computing: nothing must be written";

  // Without --png the plugin is never needed.
  const auto ok = with_env(concat({"viewshed", bundled_dem(kRainier), "-o", dir.file("out.tif")}, kSummit));
  EXPECT_EQ(ok.exit_code, 0) << ok.output;
  EXPECT_TRUE(fs::exists(dir.file("out.tif")));
}

// ---------------------------------------------------------------- success

TEST(CliInfo, JsonDescribesTheDem) {
  const auto r = horizon({"info", bundled_dem(kRainier), "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json j = parse_json(r);
  EXPECT_EQ(j["width"], 400);
  EXPECT_EQ(j["height"], 400);
  EXPECT_EQ(j["crs"]["epsg"], 4326);
  EXPECT_TRUE(j["crs"]["geographic"].get<bool>());
  EXPECT_FALSE(j["crs"]["name"].get<std::string>().empty());
  EXPECT_EQ(j["nodata"], -32768.0);
  ASSERT_EQ(j["geotransform"].size(), 6u);
  EXPECT_NEAR(j["geotransform"][1].get<double>(), 3.0 / 3600.0, 1e-9);
  // A 3" cell at 46.8 N: ~92.6 m north-south, ~63.6 m east-west.
  EXPECT_NEAR(j["cell_size_m"]["y"].get<double>(), 92.6, 0.5);
  EXPECT_NEAR(j["cell_size_m"]["x"].get<double>(), 63.6, 0.5);
  EXPECT_NEAR(j["extent_lonlat"]["west"].get<double>(), j["extent"]["x_min"].get<double>(), 1e-9);
  EXPECT_GT(j["elevation"]["max"].get<double>(), 4000.0);
  EXPECT_EQ(j["valid_cells"].get<std::uint64_t>() + j["void_cells"].get<std::uint64_t>(), 160000u);
  EXPECT_GT(j["void_cells"].get<std::uint64_t>(), 0u);
}

TEST(CliInfo, ProjectedDemHasLonLatExtent) {
  const auto r = horizon({"info", bundled_dem(kAndes), "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json j = parse_json(r);
  EXPECT_EQ(j["crs"]["epsg"], 32717);
  EXPECT_NEAR(j["cell_size_m"]["x"].get<double>(), 10.0, 0.02);
  EXPECT_NEAR(j["extent_lonlat"]["west"].get<double>(), -79.09, 0.01);
  EXPECT_NEAR(j["extent_lonlat"]["south"].get<double>(), -4.007, 0.01);

  const auto text = horizon({"info", bundled_dem(kAndes)});
  EXPECT_EQ(text.exit_code, 0);
  EXPECT_NE(text.output.find("EPSG:32717"), std::string::npos) << text.output;
}

class CliViewshed : public ::testing::Test {
 protected:
  TempDir dir;
};

TEST_F(CliViewshed, WritesGeoTiffPngAndJsonSummary) {
  const std::string out = dir.file("view.tif"), png = dir.file("view.png");
  const auto r = horizon(
      concat({"viewshed", bundled_dem(kRainier), "--height", "10", "-o", out, "--png", png, "--json"}, kSummit));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json j = parse_json(r);  // also proves stderr stayed quiet (no progress bar off a terminal)
  for (const char* key : {"dem", "output", "output_kind", "png", "algorithm", "observer", "options", "window",
                          "cell_size_m", "visible_cells", "hidden_cells", "evaluated_cells", "visible_area_km2",
                          "visible_percent", "stats", "preview_seconds", "total_seconds"})
    EXPECT_TRUE(j.contains(key)) << key;
  for (const char* key : {"dem_cells", "window_cells", "cells_evaluated", "terrain_samples", "rays", "seconds"})
    EXPECT_TRUE(j["stats"].contains(key)) << key;
  EXPECT_GT(j["preview_seconds"].get<double>(), 0.0);
  EXPECT_LT(j["preview_seconds"].get<double>(), j["total_seconds"].get<double>());
  // The phases are the run's own clocks and add up to no more than its total.
  const Json& phases = j["phases"];
  double phase_sum = 0.0;
  for (const char* key : {"open", "read", "compute", "mask", "encode", "preview"}) {
    ASSERT_TRUE(phases.contains(key)) << key;
    EXPECT_GE(phases[key].get<double>(), 0.0) << key;
    phase_sum += phases[key].get<double>();
  }
  EXPECT_GT(phases["encode"].get<double>(), 0.0);
  EXPECT_EQ(phases["compute"], j["stats"]["seconds"]);
  EXPECT_EQ(phases["read"], j["read"]["seconds"]);
  EXPECT_EQ(phases["preview"], j["preview_seconds"]);
  EXPECT_LE(phase_sum, j["total_seconds"].get<double>());
  EXPECT_NEAR(phase_sum + phases["other"].get<double>(), j["total_seconds"].get<double>(), 1e-9);
  EXPECT_EQ(j["algorithm"], "fast");
  EXPECT_EQ(j["stats"]["dem_cells"], 160000);
  const auto visible = j["visible_cells"].get<std::uint64_t>();
  const auto evaluated = j["evaluated_cells"].get<std::uint64_t>();
  EXPECT_GT(visible, 0u);
  EXPECT_LT(visible, evaluated);
  EXPECT_EQ(visible + j["hidden_cells"].get<std::uint64_t>(), evaluated);
  EXPECT_NEAR(j["visible_percent"].get<double>(), 100.0 * double(visible) / double(evaluated), 1e-9);
  EXPECT_NEAR(j["visible_area_km2"].get<double>(),
              double(visible) * j["cell_size_m"]["x"].get<double>() * j["cell_size_m"]["y"].get<double>() / 1e6, 1e-9);
  EXPECT_NEAR(j["observer"]["lat"].get<double>(), 46.8529, 1e-9);
  EXPECT_NEAR(j["observer"]["elevation"].get<double>() - j["observer"]["ground"].get<double>(), 10.0, 1e-9);

  EXPECT_TRUE(fs::is_regular_file(out));
  EXPECT_TRUE(fs::is_regular_file(png));
  EXPECT_EQ(read_bytes(png).substr(1, 3), "PNG");
  EXPECT_TRUE(fs::is_regular_file(dir.file("view.qml")));
  EXPECT_EQ(files_in(dir.path()).size(), 3u) << "no temporary files left behind";
}

// OUT.qml beside OUT.tif: QGIS's default style for the layer, an XML
// document with the previews' colours; the mask also carries them as a
// GeoTIFF colour table.
TEST_F(CliViewshed, WritesAQgisStyleBesideTheRaster) {
  struct Case {
    std::string output, renderer;
    int entries;  // palette entries or ramp items
  };
  for (const Case& k : {Case{"visible", "paletted", 2}, Case{"ohf", "singlebandpseudocolor", 9}}) {
    const std::string out = dir.file(k.output + ".tif"), qml = dir.file(k.output + ".qml");
    const auto r = horizon(
        concat({"viewshed", bundled_dem(kRainier), "--max-distance", "3000", "--output", k.output, "-o", out, "--json"},
               kSummit));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_EQ(parse_json(r)["style"], qml);
    ASSERT_TRUE(fs::is_regular_file(qml));
    const auto xml = run_command(
        "python3 -c 'import sys, xml.etree.ElementTree as E; r = E.parse(sys.argv[1]).getroot(); "
        "n = r.find(\"pipe/rasterrenderer\"); "
        "print(n.get(\"type\"), len(r.findall(\".//paletteEntry\")) + len(r.findall(\".//item\")))' " +
        shell_quote(qml));
    ASSERT_EQ(xml.exit_code, 0) << xml.output;
    EXPECT_EQ(xml.output, k.renderer + " " + std::to_string(k.entries) + "\n");
  }
  const std::string qml = read_bytes(dir.file("visible.qml"));
  EXPECT_NE(qml.find("value=\"1\" color=\"#0072b2\" alpha=\"255\" label=\"visible\""), std::string::npos);
  EXPECT_NE(qml.find("value=\"0\" color=\"#d55e00\" alpha=\"255\" label=\"hidden\""), std::string::npos);
  if (run_command("gdalinfo --version").exit_code != 0) GTEST_SKIP() << "gdalinfo not installed";
  const auto info = run_command("gdalinfo " + shell_quote(dir.file("visible.tif")));
  EXPECT_NE(info.output.find("ColorInterp=Palette"), std::string::npos) << info.output;
  EXPECT_NE(info.output.find("1: 0,114,178,255"), std::string::npos) << info.output;
}

TEST_F(CliViewshed, GeoreferencingMatchesTheInput) {
  const std::string out = dir.file("view.tif");
  const auto r =
      horizon(concat({"viewshed", bundled_dem(kRainier), "--max-distance", "5000", "-o", out, "--json"}, kSummit));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json j = parse_json(r);
  const Json& w = j["window"];
  // A 5 km radius is a ~158 x 108 cell window inside the 400 x 400 crop.
  EXPECT_LT(w["width"].get<int>(), 400);
  EXPECT_LT(w["height"].get<int>(), 400);
  EXPECT_EQ(j["stats"]["window_cells"].get<std::uint64_t>(),
            w["width"].get<std::uint64_t>() * w["height"].get<std::uint64_t>());
  EXPECT_LE(j["stats"]["cells_evaluated"].get<std::uint64_t>(), j["stats"]["window_cells"].get<std::uint64_t>());

  if (!have_gdalinfo()) GTEST_SKIP() << "gdalinfo not installed";
  const auto input = gdalinfo_json(bundled_dem(kRainier));
  const auto output = gdalinfo_json(out);
  ASSERT_EQ(input.exit_code, 0) << input.output;
  ASSERT_EQ(output.exit_code, 0) << output.output;
  const Json in = Json::parse(input.output), o = Json::parse(output.output);
  EXPECT_EQ(o["size"][0], w["width"]);
  EXPECT_EQ(o["size"][1], w["height"]);
  const Json& gi = in["geoTransform"];
  const Json& go = o["geoTransform"];
  const double col0 = w["col0"].get<double>(), row0 = w["row0"].get<double>();
  EXPECT_NEAR(go[0].get<double>(), gi[0].get<double>() + col0 * gi[1].get<double>(), 1e-9);
  EXPECT_NEAR(go[3].get<double>(), gi[3].get<double>() + row0 * gi[5].get<double>(), 1e-9);
  EXPECT_NEAR(go[1].get<double>(), gi[1].get<double>(), 1e-12);
  EXPECT_NEAR(go[5].get<double>(), gi[5].get<double>(), 1e-12);
  EXPECT_NE(o["coordinateSystem"]["wkt"].get<std::string>().find("ID[\"EPSG\",4326]]"), std::string::npos);
  EXPECT_EQ(o["bands"][0]["type"], "Byte");
  EXPECT_EQ(o["bands"][0]["noDataValue"], 255);
}

TEST_F(CliViewshed, FloatOutputsKeepTheDemNodata) {
  const std::string mth = dir.file("mth.tif");
  const auto r = horizon(
      concat({"viewshed", bundled_dem(kRainier), "--max-distance", "3000", "--output", "min-target-height", "-o", mth},
             kSummit));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("km²"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("visible"), std::string::npos) << r.output;
  if (!have_gdalinfo()) GTEST_SKIP() << "gdalinfo not installed";
  const Json o = Json::parse(gdalinfo_json(mth).output);
  EXPECT_EQ(o["bands"][0]["type"], "Float32");
  EXPECT_EQ(o["bands"][0]["noDataValue"], -32768.0);
}

TEST_F(CliViewshed, ExactR3AndProjectedObserver) {
  // Centre of the Andes crop, given in its own UTM coordinates.
  const double x = 711962.726935 + 191.5 * 10, y = 9561011.759956 - 207.5 * 10;
  const std::string observer = std::to_string(x) + "," + std::to_string(y);
  const auto r = horizon({"viewshed", bundled_dem(kAndes), "--observer", observer, "--algorithm", "r3",
                          "--max-distance", "600", "--output", "ohf", "-o", dir.file("ohf.tif"), "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json j = parse_json(r);
  EXPECT_EQ(j["algorithm"], "r3");
  EXPECT_EQ(j["output_kind"], "ohf");
  EXPECT_NEAR(j["observer"]["col"].get<double>(), 191.0, 1e-6);
  EXPECT_NEAR(j["observer"]["row"].get<double>(), 207.0, 1e-6);
  EXPECT_EQ(j["window"]["width"], 121);  // 600 m / 10 m each way plus the centre
  EXPECT_GT(j["stats"]["rays"].get<std::uint64_t>(), 0u);
  if (!have_gdalinfo()) GTEST_SKIP() << "gdalinfo not installed";
  const Json o = Json::parse(gdalinfo_json(dir.file("ohf.tif")).output);
  EXPECT_EQ(o["bands"][0]["type"], "Float32");
  EXPECT_NE(o["coordinateSystem"]["wkt"].get<std::string>().find("32717"), std::string::npos);
}

TEST_F(CliViewshed, RaisingTheEyeNeverShrinksTheViewshed) {
  std::uint64_t previous = 0;
  for (const char* height : {"2", "10", "50"}) {
    const auto r = horizon(concat({"viewshed", bundled_dem(kRainier), "--height", height, "-o",
                                   dir.file(std::string("v") + height + ".tif"), "--json"},
                                  kSummit));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const auto visible = parse_json(r)["visible_cells"].get<std::uint64_t>();
    EXPECT_GE(visible, previous) << "height " << height;
    previous = visible;
  }
}

TEST_F(CliViewshed, BackendGpuAnswersOnTheGpuAsTheCpuDoes) {
  // On a machine without a GPU the GPU path runs on Mesa's llvmpipe: slower, but the same rays.
  Json stats[2];
  std::uint64_t visible[2] = {};
  const char* backends[] = {"gpu", "cpu"};
  for (int i = 0; i < 2; ++i) {
    const auto r = horizon(concat({"viewshed", bundled_dem(kRainier), "--max-distance", "5000", "--backend",
                                   backends[i], "-o", dir.file(std::string(backends[i]) + ".tif"), "--json"},
                                  kSummit));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const Json j = parse_json(r);  // also: no warning on stderr
    EXPECT_EQ(j["options"]["backend"], backends[i]);
    // No variant named: the device's measured fastest (fragment, log-step until measured).
    EXPECT_TRUE(j["options"]["gpu_method"].is_null());
    EXPECT_TRUE(j["options"]["gpu_propagation"].is_null());
    stats[i] = j["stats"];
    visible[i] = j["visible_cells"].get<std::uint64_t>();
  }
  EXPECT_EQ(stats[0]["backend"], "gpu") << stats[0];
  EXPECT_EQ(stats[0]["gpu_variant"], "fragment, log-step") << stats[0];
  EXPECT_TRUE(stats[1]["gpu_variant"].is_null()) << stats[1];
  EXPECT_TRUE(stats[0]["gpu_fallback"].is_null()) << stats[0];
  EXPECT_EQ(stats[1]["backend"], "cpu") << stats[1];
  EXPECT_EQ(stats[0]["cells_evaluated"], stats[1]["cells_evaluated"]);
  // Within float rounding of the two OHFs: at most 0.1 % of the visible cells.
  EXPECT_LE(std::max(visible[0], visible[1]) - std::min(visible[0], visible[1]), visible[1] / 1000);
}

TEST_F(CliViewshed, GpuMethodAndPropagationAreEchoed) {
  const auto r =
      horizon(concat({"viewshed", bundled_dem(kRainier), "--max-distance", "2000", "--backend", "gpu", "--gpu-method",
                      "compute", "--gpu-propagation", "one-step", "-o", dir.file("v.tif"), "--json"},
                     kSummit));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json j = parse_json(r);
  EXPECT_EQ(j["options"]["gpu_method"], "compute");
  EXPECT_EQ(j["options"]["gpu_propagation"], "one-step");
  EXPECT_EQ(j["stats"]["backend"], "gpu");
}

TEST_F(CliViewshed, BackendGpuWithoutEglWarnsAndAnswersOnTheCpu) {
  // GLVND with no vendor library to load: no EGL display can be had.
  std::string command = "__EGL_VENDOR_LIBRARY_FILENAMES=/nonexistent.json ";
  command += shell_quote(HORIZON_CLI_PATH);
  for (const std::string& a : concat({"viewshed", bundled_dem(kRainier), "--max-distance", "2000", "--backend", "gpu",
                                      "-o", dir.file("v.tif"), "--json"},
                                     kSummit)) {
    command += ' ';
    command += shell_quote(a);
  }
  const auto r = run_command(command);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto warning = r.output.find("horizon: warning: GPU failed (");
  ASSERT_NE(warning, std::string::npos) << r.output;
  EXPECT_NE(r.output.find("EGL", warning), std::string::npos) << r.output;  // names why
  const Json j = Json::parse(r.output.substr(r.output.find('{')), nullptr, false);
  ASSERT_FALSE(j.is_discarded()) << r.output;
  EXPECT_EQ(j["stats"]["backend"], "cpu");
  EXPECT_NE(j["stats"]["gpu_fallback"].get<std::string>().find("EGL"), std::string::npos) << j["stats"];
  EXPECT_TRUE(fs::is_regular_file(dir.file("v.tif")));
}

TEST_F(CliViewshed, BackendAutoOnASoftwareRasteriserRunsOnTheCpu) {
  const auto r = horizon(concat(
      {"viewshed", bundled_dem(kRainier), "--max-distance", "2000", "-o", dir.file("v.tif"), "--json"}, kSummit));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json j = parse_json(r);
  EXPECT_EQ(j["options"]["backend"], "auto");
  EXPECT_TRUE(j["stats"]["gpu_fallback"].is_null()) << j["stats"];
  if (!fs::exists("/dev/dri") && !fs::exists("/dev/nvidiactl")) {
    EXPECT_EQ(j["stats"]["backend"], "cpu");
  }
}

// ---------------------------------------------------------------- line of sight

TEST(CliLos, JsonHasProfileAndConsistentVerdict) {
  const auto r = horizon({"los", bundled_dem(kRainier), "--from-lat", "46.8529", "--from-lon", "-121.7604", "--to-lat",
                          "46.75", "--to-lon", "-121.70", "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json j = parse_json(r);
  for (const char* key : {"visible", "distance", "clearance", "from", "to", "first_block", "profile"})
    EXPECT_TRUE(j.contains(key)) << key;
  ASSERT_TRUE(j["profile"].is_array());
  ASSERT_GT(j["profile"].size(), 10u);
  double last = -1.0;
  for (const Json& s : j["profile"]) {
    for (const char* key : {"distance", "col", "row", "x", "y", "terrain", "sight_line"}) ASSERT_TRUE(s.contains(key));
    EXPECT_GE(s["distance"].get<double>(), last);
    last = s["distance"].get<double>();
  }
  EXPECT_LE(last, j["distance"].get<double>());
  // ~12.5 km between the two points.
  EXPECT_NEAR(j["distance"].get<double>(), 12500.0, 1000.0);
  EXPECT_EQ(j["visible"].get<bool>(), j["first_block"].is_null());
  if (!j["first_block"].is_null()) {
    EXPECT_GT(j["first_block"]["terrain"].get<double>(), j["first_block"]["sight_line"].get<double>());
  }
}

TEST(CliLos, HighEyeSeesWhatALowEyeCannot) {
  // From 2 m on the summit dome its own shoulder hides the flank; from 500 m up it does not.
  const std::vector<std::string> base = {"los",        bundled_dem(kRainier),
                                         "--from-lat", "46.8529",
                                         "--from-lon", "-121.7604",
                                         "--to-lat",   "46.80",
                                         "--to-lon",   "-121.76",
                                         "--json"};
  const auto low = horizon(concat(base, {"--from-height", "2"}));
  const auto high = horizon(concat(base, {"--from-height", "500"}));
  ASSERT_EQ(low.exit_code, 0) << low.output;
  ASSERT_EQ(high.exit_code, 0) << high.output;
  const Json l = parse_json(low), h = parse_json(high);
  EXPECT_LT(l["clearance"].get<double>(), h["clearance"].get<double>());
  EXPECT_TRUE(h["visible"].get<bool>());

  const auto text = horizon(std::vector<std::string>(base.begin(), base.end() - 1));
  EXPECT_EQ(text.exit_code, 0);
  EXPECT_NE(text.output.find("visible:"), std::string::npos) << text.output;
}

}  // namespace
}  // namespace horizon::testing
