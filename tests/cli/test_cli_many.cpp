// `horizon viewshed` with many observers, end to end (embedded): the count
// and any/all rasters equal the engine's, the per-observer table agrees with
// them, CSV and GeoJSON both place observers, and every mistake is named
// with nothing written.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "horizon/terrain/dem_reader.hpp"
#include "horizon/visibility/many_observers.hpp"
#include "test_support.hpp"

namespace horizon::testing {
namespace {

using Json = nlohmann::json;

constexpr const char* kEcuador = "ecuador_andes_utm17s_10m_383x415.tif";

CommandResult horizon_viewshed(const std::string& args) {
  return run_command(shell_quote(HORIZON_CLI_PATH) + " viewshed " + shell_quote(bundled_dem(kEcuador)) + " " + args);
}

void write(const std::string& path, const std::string& text) {
  std::ofstream(path) << text;
}

std::vector<std::string> lines_of(const std::string& path) {
  std::ifstream in(path);
  std::vector<std::string> out;
  for (std::string line; std::getline(in, line);) out.push_back(line);
  return out;
}

// The engine's answer for the same observers.
visibility::ManyObserversResult engine(const std::vector<visibility::ObserverSite>& sites, double max_distance) {
  auto dem = terrain::read_dem(bundled_dem(kEcuador));
  EXPECT_TRUE(dem.ok());
  visibility::ManyObserversOptions options;
  options.viewshed.max_distance = max_distance;
  auto plan = visibility::plan_many_observers(*dem, sites, options);
  EXPECT_TRUE(plan.ok()) << plan.error().message;
  auto res = visibility::compute_many_observers(*dem, *plan);
  EXPECT_TRUE(res.ok()) << res.error().message;
  return std::move(*res);
}

visibility::ObserverSite site(double x, double y, double height, double reach = 0) {
  visibility::ObserverSite s;
  s.point.x = x;
  s.point.y = y;
  s.point.height = height;
  s.max_distance = reach;
  return s;
}

TEST(CliMany, TheCountRasterAndTheTableAreTheEngines) {
  TempDir dir;
  write(dir.file("towers.csv"),
        "x,y,height,max_distance\n"
        "713877,9558936,10,2000\n"
        "# a comment\n"
        "713200,9559800,20\n"
        "714500,9558200\n");
  const auto r = horizon_viewshed(
      "--observers " + shell_quote(dir.file("towers.csv")) + " --observer 713600,9558500 --max-distance 1500 -o " +
      shell_quote(dir.file("count.tif")) + " --summary " + shell_quote(dir.file("seen.csv")) + " --json");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json j = Json::parse(r.output);
  EXPECT_EQ(j["observers"], 4);
  EXPECT_EQ(j["accumulate"], "count");

  // --observer first, then the file's lines in order; heights and reaches filled in.
  const auto want = engine(
      {site(713600, 9558500, 2), site(713877, 9558936, 10, 2000), site(713200, 9559800, 20), site(714500, 9558200, 2)},
      1500);
  auto count = terrain::read_dem(dir.file("count.tif"));
  ASSERT_TRUE(count.ok()) << count.error().message;
  ASSERT_EQ(count->width(), want.window.width());
  ASSERT_EQ(count->height(), want.window.height());
  std::uint64_t seen = 0;
  for (int r2 = 0; r2 < count->height(); ++r2)
    for (int c = 0; c < count->width(); ++c) {
      const float got = count->elevation.at(c, r2);
      if (!want.answered.at(c, r2)) {
        ASSERT_TRUE(std::isnan(got)) << c << "," << r2;  // nodata
      } else {
        ASSERT_EQ(got, static_cast<float>(want.count.at(c, r2))) << c << "," << r2;
        seen += want.count.at(c, r2) > 0;
      }
    }
  EXPECT_EQ(j["cells_seen_by_any"], seen);
  EXPECT_GT(seen, 1000u);

  const auto table = lines_of(dir.file("seen.csv"));
  ASSERT_EQ(table.size(), 5u);  // header and four observers
  EXPECT_EQ(table[0].rfind("observer,name,x,y,", 0), 0u);
  for (std::size_t i = 0; i < 4; ++i) {
    std::stringstream fields(table[i + 1]);
    std::vector<std::string> f;
    for (std::string field; std::getline(fields, field, ',');) f.push_back(field);
    ASSERT_GE(f.size(), 14u) << table[i + 1];
    const std::size_t n = f.size();  // the name may hold a comma
    EXPECT_EQ(f[0], std::to_string(i + 1));
    EXPECT_EQ(std::stoull(f[n - 4]), want.observers[i].cells_visible) << table[i + 1];
    EXPECT_EQ(std::stoull(f[n - 5]), want.observers[i].cells_answered) << table[i + 1];
  }
  EXPECT_NE(table[2].find("\"line 2\""), std::string::npos) << table[2];  // the file's line
  EXPECT_NE(table[2].find(",2000.0,"), std::string::npos) << table[2];    // its own reach

  // Seen from any and from all: UInt8 1/0/255 from the same count.
  for (const char* kind : {"any", "all"}) {
    const std::string out = dir.file(std::string(kind) + ".tif");
    const auto k = horizon_viewshed("--observers " + shell_quote(dir.file("towers.csv")) +
                                    " --observer 713600,9558500 --max-distance 1500 --accumulate " + kind + " -o " +
                                    shell_quote(out));
    ASSERT_EQ(k.exit_code, 0) << k.output;
    auto raster = terrain::read_dem(out);
    ASSERT_TRUE(raster.ok()) << raster.error().message;
    EXPECT_EQ(raster->format, "GeoTIFF UInt8 (deflate, tiled 256x256)");
    const auto expect = std::string(kind) == "any" ? visibility::seen_from_any(want) : visibility::seen_from_all(want);
    for (int r2 = 0; r2 < raster->height(); ++r2)
      for (int c = 0; c < raster->width(); ++c) {
        const std::uint8_t e = expect.at(c, r2);
        const float got = raster->elevation.at(c, r2);
        if (e == 255) {
          ASSERT_TRUE(std::isnan(got)) << kind << " " << c << "," << r2;
        } else {
          ASSERT_EQ(got, static_cast<float>(e)) << kind << " " << c << "," << r2;
        }
      }
  }
}

TEST(CliMany, GeoJsonPointsCarryTheirHeightsReachesAndNames) {
  TempDir dir;
  // The first two towers of the CSV test, as WGS84 points.
  write(dir.file("towers.geojson"), R"({"type": "FeatureCollection", "features": [
    {"type": "Feature", "geometry": {"type": "Point", "coordinates": [-79.0736689, -3.9881168]},
     "properties": {"name": "ridge mast", "height": 10, "max_distance": 2000}},
    {"type": "Feature", "geometry": {"type": "Point", "coordinates": [-79.0797823, -3.9803190, 2147.6]},
     "properties": {"id": 7}}]})");
  const auto r =
      horizon_viewshed("--observers " + shell_quote(dir.file("towers.geojson")) +
                       " --height 20 --max-distance 1500 -o " + shell_quote(dir.file("count.tif")) + " --png " +
                       shell_quote(dir.file("count.png")) + " --summary " + shell_quote(dir.file("seen.csv")));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("from 2 observers"), std::string::npos) << r.output;
  EXPECT_TRUE(std::filesystem::exists(dir.file("count.png")));
  const auto table = lines_of(dir.file("seen.csv"));
  ASSERT_EQ(table.size(), 3u);
  EXPECT_NE(table[1].find("\"ridge mast\""), std::string::npos) << table[1];
  EXPECT_NE(table[1].find(",2000.0,"), std::string::npos) << table[1];
  EXPECT_NE(table[2].find("\"7\""), std::string::npos) << table[2];
  EXPECT_NE(table[2].find(",1500.0,"), std::string::npos) << table[2];  // the shared reach
  // Eye 10 m and 20 m above the ground the table reports.
  std::stringstream first(table[1]), second(table[2]);
  std::vector<std::string> a, b;
  for (std::string f; std::getline(first, f, ',');) a.push_back(f);
  for (std::string f; std::getline(second, f, ',');) b.push_back(f);
  EXPECT_NEAR(std::stod(a[7]) - std::stod(a[6]), 10.0, 1e-6);
  EXPECT_NEAR(std::stod(b[7]) - std::stod(b[6]), 20.0, 1e-6);
}

TEST(CliMany, MistakesAreNamedAndNothingIsWritten) {
  TempDir dir;
  const std::string out = dir.file("count.tif");
  const auto refused = [&](const std::string& args, int code, const std::string& says) {
    const auto r = horizon_viewshed(args + " -o " + shell_quote(out));
    EXPECT_EQ(r.exit_code, code) << args << "\n" << r.output;
    EXPECT_NE(r.output.find(says), std::string::npos) << args << "\n" << r.output;
    EXPECT_FALSE(std::filesystem::exists(out)) << args;
  };
  write(dir.file("short.csv"), "713877,9558936\n713200\n");
  refused("--observers " + shell_quote(dir.file("short.csv")), 2, "short.csv' line 2");
  write(dir.file("reach.csv"), "713877,9558936,2,-5\n");
  refused("--observers " + shell_quote(dir.file("reach.csv")), 2, "max_distance must be a positive number");
  write(dir.file("late_header.csv"), "713877,9558936\nx,y\n");
  refused("--observers " + shell_quote(dir.file("late_header.csv")), 2, "line 2: expected numbers");
  write(dir.file("empty.csv"), "# nothing\n");
  refused("--observers " + shell_quote(dir.file("empty.csv")), 2, "holds no observers");
  write(dir.file("line.geojson"), R"({"type": "FeatureCollection", "features": [
    {"type": "Feature", "geometry": {"type": "Point", "coordinates": [-79.07, -3.99]}},
    {"type": "Feature", "geometry": {"type": "LineString", "coordinates": [[-79.07, -3.99], [-79.06, -3.98]]}}]})");
  refused("--observers " + shell_quote(dir.file("line.geojson")), 2, "features[1]: expected a Feature with a Point");
  write(dir.file("broken.geojson"), "{\"type\": ");
  refused("--observers " + shell_quote(dir.file("broken.geojson")), 2, "not JSON");
  refused("--observers " + shell_quote(dir.file("missing.csv")), 2, "cannot open");

  // The engine's refusal names the observer as the user gave it.
  write(dir.file("far.csv"), "713877,9558936\n813877,9558936\n");
  refused("--observers " + shell_quote(dir.file("far.csv")), 1, "observer 2 (line 2)");

  // Flags for one observer, or for many, in the wrong place.
  write(dir.file("ok.csv"), "713877,9558936\n");
  refused("--observers " + shell_quote(dir.file("ok.csv")) + " --lat -3.99 --lon -79.07", 2, "--lat: places one");
  refused("--observers " + shell_quote(dir.file("ok.csv")) + " --output ohf", 2, "--output: not with many");
  refused("--observers " + shell_quote(dir.file("ok.csv")) + " --accumulate most", 2, "--accumulate");
  refused("--observer 713877,9558936 --summary " + shell_quote(dir.file("s.csv")), 2,
          "--summary: only with many observers");
  refused("--observer 713877,9558936 --observer 713877", 2, "--observer (2): expected X,Y");
  // Only --observer repeats.
  refused("--observer 713877,9558936 --observer 713200,9559800 --height 2 --height 3", 2,
          "--height: given more than once");
}

}  // namespace
}  // namespace horizon::testing
