// `horizon ... --server`: the same outputs as embedded mode, from a real daemon.
#include <gtest/gtest.h>

#include <cstring>
#include <fstream>
#include <map>
#include <sstream>

#include <nlohmann/json.hpp>

#include "daemon_process.hpp"
#include "horizon/terrain/dem_reader.hpp"

namespace horizon::testing {
namespace {

using Json = nlohmann::json;

CommandResult horizon(const std::string& args) {
  return run_command(std::string(HORIZON_CLI_PATH) + " " + args);
}

Json json_of(const CommandResult& r) {
  // stderr is merged in; the document is the first '{' on.
  const auto start = r.output.find('{');
  return start == std::string::npos ? Json() : Json::parse(r.output.substr(start), nullptr, false);
}

class ServerCli : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { daemon_ = new DaemonProcess(); }
  static void TearDownTestSuite() {
    delete daemon_;
    daemon_ = nullptr;
  }
  void SetUp() override { ASSERT_TRUE(daemon_->ready()) << daemon_->error(); }
  std::string server() const { return " --server " + daemon_->address(); }

  static DaemonProcess* daemon_;
  TempDir dir_;
};
DaemonProcess* ServerCli::daemon_ = nullptr;

const std::string kRainierEye = " --lat 46.8529 --lon -121.7604";

// Byte-identical to embedded mode reading the whole file (--full-read): the
// daemon reads only the window's blocks through its cache, and a run's
// output georeference is the source's transform shifted once to the window.
TEST_F(ServerCli, ViewshedGeoTiffAndPngAreByteIdenticalToEmbedded) {
  for (const char* flags : {" --max-distance 8000", " --max-distance 6000 --output ohf --target-height 3",
                            " --max-distance 2500 --algorithm r3 --output min-target-height",
                            " --algorithm exact --max-distance 3000 --curvature 0"}) {
    const std::string full = dir_.file("full.tif"), remote = dir_.file("remote.tif");
    const std::string dem = bundled_dem("rainier_summit_srtm3_400x400.tif");
    const auto a = horizon("viewshed " + dem + kRainierEye + flags + " --full-read -o " + full + " --png " +
                           dir_.file("local.png") + " --json");
    ASSERT_EQ(a.exit_code, 0) << a.output;
    const auto b = horizon("viewshed rainier" + server() + kRainierEye + flags + " -o " + remote + " --png " +
                           dir_.file("remote.png") + " --json");
    ASSERT_EQ(b.exit_code, 0) << b.output;
    const std::string tif = read_bytes(full);
    ASSERT_GT(tif.size(), 1000u);
    EXPECT_TRUE(tif == read_bytes(remote)) << "GeoTIFFs differ for" << flags;
    EXPECT_TRUE(read_bytes(dir_.file("local.png")) == read_bytes(dir_.file("remote.png")))
        << "PNGs differ for" << flags;
    const Json ja = json_of(a), jb = json_of(b);
    for (const char* key : {"visible_cells", "hidden_cells", "evaluated_cells", "window", "algorithm", "output_kind"})
      EXPECT_EQ(ja[key], jb[key]) << key << flags;
    EXPECT_EQ(ja["stats"]["cells_evaluated"], jb["stats"]["cells_evaluated"]);
    EXPECT_NEAR(ja["observer"]["elevation"].get<double>(), jb["observer"]["elevation"].get<double>(), 1e-9);
  }
}

TEST_F(ServerCli, InfoReportsTheSameDataset) {
  const auto a = horizon("info " + bundled_dem("everest_summit_voids_srtm3_300x300.tif") + " --json");
  const auto b = horizon("info everest" + server() + " --json");
  ASSERT_EQ(a.exit_code, 0) << a.output;
  ASSERT_EQ(b.exit_code, 0) << b.output;
  Json ja = json_of(a), jb = json_of(b);
  ja.erase("path");
  jb.erase("path");
  jb.erase("server");
  EXPECT_EQ(ja, jb);
  const auto text = horizon("info everest" + server());
  EXPECT_EQ(text.exit_code, 0);
  EXPECT_NE(text.output.find("Voids:"), std::string::npos) << text.output;
}

TEST_F(ServerCli, LineOfSightJsonEqualsEmbedded) {
  const std::string flags = " --from-lat 46.8529 --from-lon -121.7604 --to-lat 46.80 --to-lon -121.70 --to-height 10";
  const auto a = horizon("los " + bundled_dem("rainier_summit_srtm3_400x400.tif") + flags + " --json");
  const auto b = horizon("los rainier" + server() + flags + " --json");
  ASSERT_EQ(a.exit_code, 0) << a.output;
  ASSERT_EQ(b.exit_code, 0) << b.output;
  Json ja = json_of(a), jb = json_of(b);
  ja.erase("dem");
  jb.erase("dem");
  EXPECT_EQ(ja, jb);
  EXPECT_GT(ja["profile"].size(), 10u);
}

TEST_F(ServerCli, CullEqualsEmbeddedAndHidesSomething) {
  // Boxes around the summit of Everest in lon/lat, tall and short.
  std::ostringstream csv;
  // Client ids (10 i + 7), and box 40 off the map: answered out_of_range, the others still culled.
  csv << "id,x_min,y_min,x_max,y_max,z_min,z_max\n";
  for (int i = 0; i < 40; ++i) {
    const double lon = 86.88 + 0.002 * i, lat = 27.95 + 0.0015 * (i % 20);
    csv << 10 * i + 7 << ',' << lon << ',' << lat << ',' << lon + 0.0008 << ',' << lat + 0.0005 << ",4000,"
        << (i % 2 ? 9000 : 4500) << '\n';
  }
  csv << "407,80.0,27.95,80.001,27.951,4000,4500\n";
  const std::string boxes = dir_.file("boxes.csv");
  write_file(boxes, csv.str());
  std::map<std::string, int> seen_states;
  for (const std::string mode : {"", " --conservative", " --algorithm r3", " --nodata fill:0"}) {
    const std::string flags = " --lat 27.9881 --lon 86.9250 --altitude 8850 --boxes " + boxes + " --lonlat" + mode;
    const auto a = horizon("cull " + bundled_dem("everest_summit_voids_srtm3_300x300.tif") + flags + " --json");
    const auto b = horizon("cull everest" + server() + flags + " --json");
    ASSERT_EQ(a.exit_code, 0) << a.output;
    ASSERT_EQ(b.exit_code, 0) << b.output;
    Json ja = json_of(a), jb = json_of(b);
    for (Json* j : {&ja, &jb}) {
      j->erase("dem");
      j->erase("total_seconds");
      (*j)["stats"].erase("seconds");
    }
    EXPECT_EQ(ja, jb) << mode;
    EXPECT_GT(ja["visible_count"].get<int>(), 0);
    EXPECT_LT(ja["visible_count"].get<int>(), 40) << mode;
    ASSERT_EQ(jb["boxes"].size(), 41u);
    for (std::size_t i = 0; i < 41; ++i) {  // the state as a word, agreeing with `visible`; the id echoed
      const Json& box = jb["boxes"][i];
      const std::string state = box["state"];
      seen_states[state] += 1;
      EXPECT_EQ(box["visible"].get<bool>(), state != "hidden") << mode << ": " << box;
      EXPECT_EQ(box["id"].get<std::uint64_t>(), 10 * i + 7);
      EXPECT_EQ(state == "out_of_range", i == 40) << mode << ": " << box;
      // Filled voids are terrain: every box on the map is decided.
      if (mode == " --nodata fill:0") {
        EXPECT_NE(state, "undetermined") << box;
      }
    }
    EXPECT_EQ(jb["out_of_range_count"], 1) << mode;
  }
  // The Everest crop's voids leave some buried boxes undetermined under the default policy.
  EXPECT_GT(seen_states["undetermined"], 0);
  EXPECT_GT(seen_states["hidden"], 0);
}

TEST_F(ServerCli, DatasetsListsEveryPage) {
  const auto r = horizon("datasets" + server() + " --page-size 1 --json");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json j = json_of(r);
  ASSERT_EQ(j["datasets"].size(), 4u);
  EXPECT_EQ(j["datasets"][0]["name"], "ecuador");
  EXPECT_EQ(j["datasets"][3]["name"], "rainier");
  EXPECT_GT(j["datasets"][3]["resident_bytes"].get<std::uint64_t>(), 0u);
  EXPECT_EQ(horizon("datasets").exit_code, 2);
}

TEST_F(ServerCli, DaemonErrorsAreReportedWithTheirCodeAndField) {
  const auto unknown = horizon("info nowhere" + server());
  EXPECT_EQ(unknown.exit_code, 1);
  EXPECT_NE(unknown.output.find("NOT_FOUND"), std::string::npos) << unknown.output;
  const auto outside = horizon("viewshed rainier" + server() + " --lat 10 --lon 10 -o " + dir_.file("x.tif"));
  EXPECT_EQ(outside.exit_code, 1);
  EXPECT_NE(outside.output.find("OUT_OF_RANGE"), std::string::npos) << outside.output;
  EXPECT_NE(outside.output.find("field observer"), std::string::npos) << outside.output;
  EXPECT_FALSE(std::ifstream(dir_.file("x.tif")).good());  // a failed run leaves nothing behind
  const auto slow = horizon("viewshed ecuador" + server() +
                            " --observer 713877,9558936 --algorithm r3 --deadline 0.05 -o " + dir_.file("y.tif"));
  EXPECT_EQ(slow.exit_code, 1);
  EXPECT_NE(slow.output.find("DEADLINE_EXCEEDED"), std::string::npos) << slow.output;
  const auto down = horizon("info rainier --server 127.0.0.1:1 --deadline 2");
  EXPECT_EQ(down.exit_code, 1);
  EXPECT_NE(down.output.find("UNAVAILABLE"), std::string::npos) << down.output;
}

// Many observers: the count GeoTIFF and the PNG byte for byte, the summary
// table line for line (but the times), from the daemon's union window.
TEST_F(ServerCli, ManyObserversEqualEmbeddedByteForByte) {
  const std::string towers = dir_.file("towers.csv");
  {
    std::ofstream f(towers);
    f << "lon,lat,height,max_distance\n-121.7604,46.8529,10,3000\n-121.7400,46.8600,5\n-121.7800,46.8550,20,2000\n";
  }
  const std::string flags = " --observers " + towers + " --max-distance 2500 --target-height 1.5";
  const std::string dem = bundled_dem("rainier_summit_srtm3_400x400.tif");
  const auto a = horizon("viewshed " + dem + flags + " -o " + dir_.file("local.tif") + " --png " +
                         dir_.file("local.png") + " --summary " + dir_.file("local.csv") + " --json");
  ASSERT_EQ(a.exit_code, 0) << a.output;
  const auto b = horizon("viewshed rainier" + server() + flags + " -o " + dir_.file("remote.tif") + " --png " +
                         dir_.file("remote.png") + " --summary " + dir_.file("remote.csv") + " --json");
  ASSERT_EQ(b.exit_code, 0) << b.output;
  const std::string tif = read_bytes(dir_.file("local.tif"));
  ASSERT_GT(tif.size(), 1000u);
  EXPECT_TRUE(tif == read_bytes(dir_.file("remote.tif"))) << "count GeoTIFFs differ";
  EXPECT_TRUE(read_bytes(dir_.file("local.png")) == read_bytes(dir_.file("remote.png"))) << "PNGs differ";
  const Json ja = json_of(a), jb = json_of(b);
  for (const char* key : {"cells_answered", "cells_seen_by_any", "cells_seen_by_all", "max_count", "window",
                          "work_cells", "observers", "accumulate"})
    EXPECT_EQ(ja[key], jb[key]) << key;
  EXPECT_GE(ja["max_count"].get<int>(), 2);  // the towers' views overlap: a count, not a mask
  // The tables, without the last column (seconds).
  const auto lines = [](const std::string& path) {
    std::vector<std::string> out;
    std::ifstream f(path);
    for (std::string line; std::getline(f, line);) out.push_back(line.substr(0, line.rfind(',')));
    return out;
  };
  const auto la = lines(dir_.file("local.csv")), lb = lines(dir_.file("remote.csv"));
  ASSERT_EQ(la.size(), 4u);
  EXPECT_EQ(la, lb);

  // A site off the dataset is named as the user gave it, and nothing is written.
  {
    std::ofstream f(towers, std::ios::app);
    f << "10,10\n";
  }
  const auto off = horizon("viewshed rainier" + server() + flags + " -o " + dir_.file("off.tif"));
  EXPECT_EQ(off.exit_code, 1);
  EXPECT_NE(off.output.find("OUT_OF_RANGE"), std::string::npos) << off.output;
  EXPECT_NE(off.output.find("observer 4 (line 5)"), std::string::npos) << off.output;
  EXPECT_FALSE(std::ifstream(dir_.file("off.tif")).good());
}

}  // namespace
}  // namespace horizon::testing
