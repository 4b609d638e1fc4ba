// `horizon trace` end to end: the depth, hit and footprint images a user
// opens, the shaded view, boxes, edits, a camera path, and usage errors by flag.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "horizon/terrain/dem_reader.hpp"
#include "test_support.hpp"

namespace horizon::testing {
namespace {

using Json = nlohmann::json;

const std::string kRainier = "rainier_summit_srtm3_400x400.tif";  // EPSG:4326, 3 arc-seconds
const std::vector<std::string> kCamera = {"--lat", "46.70", "--lon",   "-121.90", "--height", "800",
                                          "--yaw", "40",    "--pitch", "-3",      "--hfov",   "60"};

CommandResult horizon(std::vector<std::string> args) {
  std::string command = shell_quote(HORIZON_CLI_PATH) + " trace";
  for (const std::string& a : args) command += ' ' + shell_quote(a);
  return run_command(command);
}

std::vector<std::string> with(std::vector<std::string> a, const std::vector<std::string>& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

terrain::Dem read_image(const std::string& path, int band = 1) {
  terrain::ReadOptions o;
  o.allow_missing_crs = true;
  o.band = band;
  auto dem = terrain::read_dem(path, o);
  EXPECT_TRUE(dem.ok()) << (dem.ok() ? "" : dem.error().message);
  return dem.ok() ? std::move(*dem) : terrain::Dem{};
}

TEST(CliTrace, WritesDepthHitsFootprintAndAViewThatAgree) {
  TempDir dir;
  const std::string depth = dir.file("depth.tif"), hits = dir.file("hits.tif"), seen = dir.file("seen.tif"),
                    png = dir.file("view.png");
  const auto r = horizon(with({bundled_dem(kRainier)}, with(kCamera, {"--size", "160x90", "-o", depth, "--hits", hits,
                                                                      "--footprint", seen, "--png", png, "--json"})));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json j = Json::parse(r.output);
  EXPECT_EQ(j["width"], 160);
  EXPECT_EQ(j["trace"]["pixels"], 160 * 90);
  const std::uint64_t sky = j["trace"]["sky_pixels"];
  EXPECT_GT(sky, 1000u);                                            // the upper part of the frame
  EXPECT_LT(sky, 160u * 90u / 2u);                                  // the lower part is terrain
  EXPECT_LT(j["read"]["cells"].get<std::uint64_t>(), 400u * 400u);  // only the wedge is read

  const terrain::Dem d = read_image(depth), col = read_image(hits, 1), elevation = read_image(hits, 3);
  ASSERT_EQ(d.width(), 160);
  ASSERT_EQ(d.height(), 90);
  std::uint64_t nan = 0;
  for (int y = 0; y < 90; ++y)
    for (int x = 0; x < 160; ++x) {
      const float v = d.elevation.at(x, y);
      ASSERT_EQ(std::isnan(v), std::isnan(col.elevation.at(x, y)));
      if (std::isnan(v)) {
        ++nan;
        continue;
      }
      EXPECT_GT(v, 0.0f);
      EXPECT_LT(v, 40000.0f);  // the crop is 25 km across
      EXPECT_GT(elevation.elevation.at(x, y), 300.0f);
      EXPECT_LT(elevation.elevation.at(x, y), 4400.0f);
    }
  EXPECT_EQ(nan, sky);
  // The footprint is georeferenced like the DEM, 1/0/255.
  auto footprint = terrain::read_dem(seen);
  ASSERT_TRUE(footprint.ok()) << footprint.error().message;
  EXPECT_EQ(footprint->georef.epsg, 4326);
  EXPECT_EQ(footprint->nodata, 255.0);
  std::uint64_t ones = 0;
  for (float v : footprint->elevation.values()) ones += v == 1.0f;
  EXPECT_GT(ones, 1000u);
  EXPECT_GT(std::filesystem::file_size(png), 10000u);
}

TEST(CliTrace, BoxesEditsAndColumnsShowInTheAnswer) {
  TempDir dir;
  // A box on the summit dome (seen from the south-west, high above the
  // ridges between) and one under the ground (never seen).
  const std::string boxes = dir.file("boxes.csv");
  std::ofstream(boxes) << "x_min,y_min,x_max,y_max,z_min,z_max\n"
                       << "-121.765,46.848,-121.755,46.856,4300,4500\n"
                       << "-121.80,46.75,-121.79,46.76,0,10\n";
  const auto r =
      horizon(with({bundled_dem(kRainier)}, with(kCamera, {"--size", "320x180", "--boxes", boxes, "--json"})));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json j = Json::parse(r.output);
  ASSERT_EQ(j["boxes"].size(), 2u);
  EXPECT_GT(j["boxes"][0]["pixels"].get<std::uint64_t>(), 0u);
  EXPECT_GT(j["boxes"][0]["fraction"].get<double>(), 0.5);
  EXPECT_EQ(j["boxes"][1]["visible_pixels"], 0);

  // A 3000 m wall raised across the view hides the summit box.
  const auto walled = horizon(with(
      {bundled_dem(kRainier)},
      with(kCamera, {"--size", "320x180", "--boxes", boxes, "--edit", "-121.89,46.72,-121.86,46.73,+3000", "--json"})));
  ASSERT_EQ(walled.exit_code, 0) << walled.output;
  const Json w = Json::parse(walled.output);
  EXPECT_GT(w["edited_cells"].get<std::uint64_t>(), 10u);
  EXPECT_EQ(w["boxes"][0]["visible_pixels"], 0);
  EXPECT_EQ(w["trace"]["crossings"], j["trace"]["crossings"]);  // the same work, nothing rebuilt

  const auto exact =
      horizon(with({bundled_dem(kRainier)}, with(kCamera, {"--size", "320x180", "--columns", "--json"})));
  ASSERT_EQ(exact.exit_code, 0) << exact.output;
  const Json e = Json::parse(exact.output);
  EXPECT_EQ(e["mode"], "rows+columns");
  EXPECT_GT(e["trace"]["crossings"].get<std::uint64_t>(), j["trace"]["crossings"].get<std::uint64_t>());
}

TEST(CliTrace, FliesACameraPathAndReportsFrameTimes) {
  TempDir dir;
  const std::string path = dir.file("path.csv"), frames = dir.file("frames");
  std::filesystem::create_directory(frames);
  std::ofstream(path) << "lon,lat,height,yaw,pitch\n"
                      << "-121.90,46.70,800,40,-3\n-121.89,46.71,800,42,-3\n-121.88,46.72,800,44,-3\n";
  const auto r =
      horizon({bundled_dem(kRainier), "--path", path, "--lonlat", "--size", "128x72", "--frames", frames, "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json j = Json::parse(r.output);
  EXPECT_EQ(j["frames"], 3);
  EXPECT_EQ(j["per_frame"].size(), 3u);
  EXPECT_GE(j["trace_ms"]["max_over_min"].get<double>(), 1.0);
  for (int i = 0; i < 3; ++i)
    EXPECT_TRUE(std::filesystem::exists(frames + "/frame_000" + std::to_string(i) + ".png")) << i;
}

TEST(CliTrace, UsageErrorsNameTheFlagAndWriteNothing) {
  TempDir dir;
  const std::string out = dir.file("depth.tif");
  const std::string dem = bundled_dem(kRainier);
  struct Case {
    std::vector<std::string> args;
    std::string says;
  };
  const Case cases[] = {
      {with({dem}, with(kCamera, {"--hfov", "175", "-o", out})), "--hfov"},
      {with({dem}, with(kCamera, {"--size", "0x10", "-o", out})), "--size"},
      {with({dem}, with(kCamera, {"--size", "100", "-o", out})), "--size"},
      {with({dem}, with(kCamera, {"--pitch", "85", "-o", out})), "--pitch"},
      {with({dem}, with(kCamera, {"--projection", "fisheye", "-o", out})), "--projection"},
      {with({dem}, with(kCamera, {"--near", "-1", "-o", out})), "--near"},
      {with({dem}, with(kCamera, {"--edit", "1,2,3", "-o", out})), "--edit"},
      {with({dem}, with(kCamera, {"--edit", "1,2,3,4,5", "-o", out})), "--edit"},
      {with({dem}, with(kCamera, {"--frames", dir.path().string(), "-o", out})), "--frames"},
      {with({dem}, with(kCamera, {"--png", out})), "--png"},
      {with({dem}, kCamera), "nothing to write"},
      {{dem, "--path", dir.file("none.csv"), "--yaw", "3"}, "--path"},
  };
  for (const Case& c : cases) {
    const auto r = horizon(c.args);
    EXPECT_EQ(r.exit_code, 2) << c.says << ": " << r.output;
    EXPECT_NE(r.output.find(c.says), std::string::npos) << r.output;
    EXPECT_FALSE(std::filesystem::exists(out)) << c.says;
  }
  // A camera off the DEM is the engine's refusal (exit 1), naming the camera.
  const auto off = horizon({dem, "--lat", "46.0", "--lon", "-121.7", "-o", out});
  EXPECT_EQ(off.exit_code, 1) << off.output;
  EXPECT_NE(off.output.find("camera"), std::string::npos) << off.output;
  EXPECT_FALSE(std::filesystem::exists(out));
}

}  // namespace
}  // namespace horizon::testing
