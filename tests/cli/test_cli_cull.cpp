// `horizon cull` end to end (embedded): per-box answers with the file's ids,
// a box off the map answered rather than failing the run, the void policy,
// and the boxes file's mistakes named by line.
#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

#include "test_support.hpp"

namespace horizon::testing {
namespace {

using Json = nlohmann::json;

CommandResult horizon_cull(const std::string& boxes, const std::string& extra = "") {
  return run_command(shell_quote(HORIZON_CLI_PATH) + " cull " +
                     shell_quote(bundled_dem("everest_summit_voids_srtm3_300x300.tif")) +
                     " --lat 27.9881 --lon 86.9250 --altitude 8850 --lonlat --boxes " + shell_quote(boxes) + extra);
}

void write(const std::string& path, const std::string& text) {
  std::ofstream(path) << text;
}

TEST(CliCull, AnswersEveryBoxByItsIdAndTheOffMapOneAsOutOfRange) {
  TempDir dir;
  const std::string boxes = dir.file("boxes.csv");
  // Box 31 sits low over a void south-west of the summit, 77 spans most of the
  // crop up to 20 km high, 99 is in the Pacific.
  write(boxes,
        "id,x_min,y_min,x_max,y_max,z_min,z_max\n"
        "31,86.90,27.96,86.901,27.961,4000,4500\n"
        "77,86.80,27.80,86.95,27.95,4000,20000\n"
        "99,-150.0,10.0,-149.99,10.01,0,10\n");
  const auto r = horizon_cull(boxes, " --json");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json j = Json::parse(r.output);
  ASSERT_EQ(j["boxes"].size(), 3u);
  EXPECT_EQ(j["boxes"][0]["id"], 31);
  EXPECT_EQ(j["boxes"][0]["state"], "undetermined");  // hidden where the OHF is known
  EXPECT_EQ(j["boxes"][1]["id"], 77);
  EXPECT_EQ(j["boxes"][1]["state"], "visible");  // 650 m above the summit's eye
  EXPECT_EQ(j["boxes"][2]["id"], 99);
  EXPECT_EQ(j["boxes"][2]["state"], "out_of_range");
  EXPECT_TRUE(j["boxes"][2]["visible"].get<bool>());  // never culled
  EXPECT_TRUE(j["boxes"][2]["ohf_min"].is_null());
  EXPECT_EQ(j["out_of_range_count"], 1);
  EXPECT_EQ(j["box_count"], 3);

  // Text: labelled by id, the off-map one said so.
  const auto text = horizon_cull(boxes);
  ASSERT_EQ(text.exit_code, 0) << text.output;
  EXPECT_NE(text.output.find("  99  out_of_range  (footprint not wholly on the dataset)"), std::string::npos)
      << text.output;
  EXPECT_NE(text.output.find("  77  visible"), std::string::npos) << text.output;
  EXPECT_NE(text.output.find("  31  undetermined  ohf_min"), std::string::npos) << text.output;
  EXPECT_NE(text.output.find("1 off the map"), std::string::npos) << text.output;
}

TEST(CliCull, FilledVoidsDecideEveryBoxTheTransparentPolicyLeavesUndetermined) {
  TempDir dir;
  const std::string boxes = dir.file("boxes.csv");
  std::string csv;
  for (int i = 0; i < 40; ++i) {
    const double lon = 86.88 + 0.002 * i, lat = 27.95 + 0.0015 * (i % 20);
    csv += std::to_string(lon) + ',' + std::to_string(lat) + ',' + std::to_string(lon + 0.0008) + ',' +
           std::to_string(lat + 0.0005) + ",4000,4500\n";
  }
  write(boxes, csv);
  const auto count = [&](const std::string& extra, const std::string& state) {
    const auto r = horizon_cull(boxes, extra + " --json");
    EXPECT_EQ(r.exit_code, 0) << r.output;
    const Json j = Json::parse(r.output);
    int n = 0;
    for (const Json& b : j["boxes"]) n += b["state"] == state;
    EXPECT_FALSE(j["boxes"][0].contains("id"));  // the file gave none
    return n;
  };
  EXPECT_GT(count("", "undetermined"), 0);
  EXPECT_EQ(count(" --nodata fill:4000", "undetermined"), 0);
  EXPECT_GT(count(" --nodata fill:4000", "hidden"), 0);
}

TEST(CliCull, TheBoxesFilesMistakesAreNamedByLine) {
  TempDir dir;
  const std::string boxes = dir.file("boxes.csv");
  const auto error_of = [&](const std::string& csv, const std::string& extra = "") {
    write(boxes, csv);
    const auto r = horizon_cull(boxes, extra);
    EXPECT_EQ(r.exit_code, 2) << r.output;  // a usage error, before any work
    return r.output;
  };
  EXPECT_NE(error_of("1,86.9,27.96,86.901,27.961,4000,4500\n86.9,27.96,86.901,27.961,4000,4500\n")
                .find("line 2: 6 numbers where the first box had 7"),
            std::string::npos);
  EXPECT_NE(error_of("1.5,86.9,27.96,86.901,27.961,4000,4500\n").find("line 1: the id must be a whole number"),
            std::string::npos);
  EXPECT_NE(error_of("86.9,27.96,86.901,27.961,4000\n").find("line 1: expected six numbers"), std::string::npos);
  EXPECT_NE(error_of("86.9,27.96,86.901,27.961,4000,4500\n", " --nodata fill").find("--nodata: expected"),
            std::string::npos);
}

}  // namespace
}  // namespace horizon::testing
