// `horizon viewshed --max-distance` on a tiled file reads only the tiles
// within reach, says so in its JSON and text output, and writes the same
// bytes as a whole-file read (--full-read).
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "horizon/terrain/geotiff_writer.hpp"
#include "test_support.hpp"

namespace horizon::testing {
namespace {

using Json = nlohmann::json;

std::string bytes_of(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

CommandResult horizon(const std::string& args) {
  return run_command(std::string(HORIZON_CLI_PATH) + " " + args);
}

// 2000 x 1800 cells of 10 m (8 x 8 = 64 tiles of 256), rough enough to hide things.
std::string write_tiled_dem(const TempDir& dir) {
  terrain::Dem dem = make_random_terrain(2000, 1800, 7, 300.0, 10.0);
  dem.georef.epsg = 32633;
  dem.georef.transform = {500000.0, 10.0, 5000000.0, -10.0};
  const std::string path = dir.file("big_tiled.tif");
  EXPECT_TRUE(terrain::write_geotiff(path, dem.elevation, dem.georef, std::nullopt).ok());
  return path;
}

TEST(CliWindowRead, MaxDistanceReadsFewTilesAndWritesTheFullReadBytes) {
  TempDir dir;
  const std::string dem = write_tiled_dem(dir);
  // Observer at cell (1003.3, 907.6); 1500 m = 150 cells: a 301-cell disc box, 4 to 9 tiles.
  const std::string common = dem + " --observer 510038.5,4990919 --height 5 --max-distance 1500 --json";
  for (const std::string algorithm : {"fast", "r3", "exact", "conservative"}) {
    for (const std::string output : {"visible", "ohf"}) {
      const std::string window_out = dir.file("w_" + algorithm + output + ".tif");
      const std::string full_out = dir.file("f_" + algorithm + output + ".tif");
      auto w =
          horizon("viewshed " + common + " --algorithm " + algorithm + " --output " + output + " -o " + window_out);
      auto f = horizon("viewshed " + common + " --algorithm " + algorithm + " --output " + output + " --full-read -o " +
                       full_out);
      ASSERT_EQ(w.exit_code, 0) << w.output;
      ASSERT_EQ(f.exit_code, 0) << f.output;
      const Json jw = Json::parse(w.output), jf = Json::parse(f.output);
      EXPECT_EQ(jw["read"]["blocks_total"], 64);
      EXPECT_LE(jw["read"]["blocks_read"].get<int>(), 9);
      EXPECT_GE(jw["read"]["blocks_read"].get<int>(), 4);
      EXPECT_EQ(jf["read"]["blocks_read"], 64);
      EXPECT_EQ(jw["read"]["block"], "tile");
      // The same answer, in the file's grid.
      EXPECT_EQ(jw["window"], jf["window"]);
      EXPECT_EQ(jw["observer"]["col"], jf["observer"]["col"]);
      EXPECT_EQ(jw["visible_cells"], jf["visible_cells"]);
      EXPECT_EQ(jw["stats"]["dem_cells"], 2000 * 1800);
      EXPECT_EQ(jw["stats"]["cells_evaluated"], jf["stats"]["cells_evaluated"]);
      EXPECT_EQ(bytes_of(window_out), bytes_of(full_out)) << algorithm << " " << output;
    }
  }
}

TEST(CliWindowRead, TextSummaryNamesTheTilesRead) {
  TempDir dir;
  const std::string dem = write_tiled_dem(dir);
  // Cell (895, 895), the middle of tile (3, 3); 500 m = 50 cells stays inside it.
  auto r = horizon("viewshed " + dem + " --observer 508955,4991045 --max-distance 500 -o " + dir.file("v.tif"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("read:       1 of 64 tiles (256x256)"), std::string::npos) << r.output;
}

TEST(CliWindowRead, RejectsObserverOutsideTheFileWithoutReadingIt) {
  TempDir dir;
  const std::string dem = write_tiled_dem(dir);
  auto r = horizon("viewshed " + dem + " --observer 400000,4990919 --max-distance 500 -o " + dir.file("v.tif"));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.output.find("is outside"), std::string::npos) << r.output;
  EXPECT_FALSE(std::ifstream(dir.file("v.tif")).good());
}

}  // namespace
}  // namespace horizon::testing
