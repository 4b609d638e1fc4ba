// `horizon region` end to end: the three-valued GeoTIFF QGIS opens, the
// R3 check it can run on itself, box verdicts, and usage errors by flag.
#include <gtest/gtest.h>

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

const std::string kAndes = "ecuador_andes_utm17s_10m_383x415.tif";  // EPSG:32717
const std::vector<std::string> kBox = {"--from-box", "713850,9558900,713900,9558950"};

CommandResult horizon(std::vector<std::string> args) {
  std::string command = shell_quote(HORIZON_CLI_PATH) + " region";
  for (const std::string& a : args) command += ' ' + shell_quote(a);
  return run_command(command);
}

std::vector<std::string> with(std::vector<std::string> a, const std::vector<std::string>& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

TEST(CliRegion, WritesAThreeValuedGeoTiffThatR3Confirms) {
  TempDir dir;
  const std::string out = dir.file("region.tif"), png = dir.file("region.png");
  const auto r =
      horizon(with({bundled_dem(kAndes)}, with(kBox, {"--heights", "2,20", "--max-distance", "1500", "--target-height",
                                                      "1.5", "-o", out, "--png", png, "--check", "40", "--json"})));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json j = Json::parse(r.output);
  EXPECT_EQ(j["check"]["wrong_hidden"], 0);
  EXPECT_EQ(j["check"]["wrong_visible"], 0);
  EXPECT_GT(j["stats"]["always_hidden"].get<std::uint64_t>(), 1000u);
  const std::uint64_t items = j["stats"]["items"];
  EXPECT_EQ(items, j["stats"]["always_hidden"].get<std::uint64_t>() +
                       j["stats"]["always_visible"].get<std::uint64_t>() +
                       j["stats"]["undetermined"].get<std::uint64_t>());
  // The raster holds only the four codes, with 255 as its nodata.
  auto grid = terrain::read_dem(out);
  ASSERT_TRUE(grid.ok()) << grid.error().message;
  EXPECT_EQ(grid->nodata, 255.0);
  EXPECT_EQ(grid->georef.epsg, 32717);
  std::uint64_t answered = 0;
  for (int row = 0; row < grid->height(); ++row)
    for (int col = 0; col < grid->width(); ++col) {
      const float v = grid->elevation.at(col, row);
      if (v == v) {
        EXPECT_TRUE(v == 0 || v == 1 || v == 2) << v;
        ++answered;
      }
    }
  EXPECT_EQ(answered, items);
  EXPECT_TRUE(std::filesystem::file_size(png) > 1000);
}

TEST(CliRegion, ClassifiesBoxesFromAPath) {
  TempDir dir;
  const std::string boxes = dir.file("boxes.csv");
  std::ofstream(boxes) << "x_min,y_min,x_max,y_max,z_min,z_max\n"
                       << "713300,9557500,713320,9557520,0,100\n"       // low, far down a valley side
                       << "713860,9558910,713880,9558930,2000,9000\n";  // a tower over the region
  const auto r = horizon({bundled_dem(kAndes), "--from-path", "713850,9558900,713900,9558950", "--half-size", "10",
                          "--boxes", boxes, "--check", "20", "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json j = Json::parse(r.output);
  ASSERT_EQ(j["boxes"].size(), 2u);
  EXPECT_EQ(j["boxes"][0], "always_hidden");  // buried under the terrain: every centre is below ground
  EXPECT_EQ(j["check"]["wrong_hidden"], 0);
  EXPECT_EQ(j["check"]["wrong_visible"], 0);
}

TEST(CliRegion, MistakesAreUsageErrorsNamingTheFlag) {
  TempDir dir;
  const std::string dem = bundled_dem(kAndes), out = dir.file("r.tif");
  struct Case {
    std::vector<std::string> args;
    std::string says;
  };
  const std::vector<Case> cases = {
      {{dem, "-o", out}, "--from-box"},
      {with({dem, "--from-path", "1,2,3,4"}, with(kBox, {"-o", out})), "--from-box"},
      {{dem, "--from-box", "1,2,3", "-o", out}, "--from-box"},
      {{dem, "--from-box", "3,2,1,4", "-o", out}, "--from-box"},
      {with({dem}, kBox), "-o OUT.tif"},
      {with({dem}, with(kBox, {"--heights", "10,2", "-o", out})), "--heights"},
      {with({dem}, with(kBox, {"--face-resolution", "4", "-o", out})), "--face-resolution"},
      {with({dem}, with(kBox, {"--splits", "99", "-o", out})), "--splits"},
      {with({dem}, with(kBox, {"--half-size", "3", "-o", out})), "--half-size"},
  };
  for (const Case& c : cases) {
    const auto r = horizon(c.args);
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_NE(r.output.find(c.says), std::string::npos) << r.output;
  }
  // Outside the DEM: the engine's error, exit 1, nothing written.
  const auto far = horizon({dem, "--from-box", "0,0,10,10", "-o", out});
  EXPECT_EQ(far.exit_code, 1) << far.output;
  EXPECT_NE(far.output.find("region"), std::string::npos) << far.output;
  EXPECT_FALSE(std::filesystem::exists(out));
}

}  // namespace
}  // namespace horizon::testing
