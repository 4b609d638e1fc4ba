// `horizon ... --server`: the same outputs as embedded mode, from a real daemon.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
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

// The bundled Rainier DEM under the daemon's name for it, "rainier": the
// PNG's title names the DEM by its file's stem embedded and by the dataset's
// name through the daemon, so with this copy both pictures are the same.
std::string rainier_named_as_the_dataset(const TempDir& dir) {
  const std::string copy = dir.file("rainier.tif");
  std::filesystem::copy_file(bundled_dem("rainier_summit_srtm3_400x400.tif"), copy,
                             std::filesystem::copy_options::overwrite_existing);
  return copy;
}

// Byte-identical to embedded mode reading the whole file (--full-read): the
// daemon reads only the window's blocks through its cache, and a run's
// output georeference is the source's transform shifted once to the window.
TEST_F(ServerCli, ViewshedGeoTiffAndPngAreByteIdenticalToEmbedded) {
  const std::string dem = rainier_named_as_the_dataset(dir_);
  for (const char* flags :
       {" --max-distance 8000", " --max-distance 6000 --output ohf --target-height 3",
        " --max-distance 2500 --algorithm r3 --output min-target-height",
        " --algorithm exact --max-distance 3000 --curvature 0",
        // gdal_viewshed's and r.viewshed's options reach the daemon as given
        " -md 4000 --azimuth 300,60 --min-distance 500 --pitch -30,5 --observer-ground cell"
        " --refraction 0.2 -f COG -co COMPRESS=LZW -co BLOCKSIZE=64",
        " -md 5000 -vv 255 -iv 0 -ov 128 -a_nodata 64", " -md 3000 --output boolean",
        " -md 3000 --output vertical-angle -a_nodata -9999", " -md 3000 -om elevation-difference --target-height 2"}) {
    const std::string full = dir_.file("full.tif"), remote = dir_.file("remote.tif");
    const auto a = horizon("viewshed " + dem + kRainierEye + flags + " --full-read -o " + full + " --png " +
                           dir_.file("local.png") + " --json");
    ASSERT_EQ(a.exit_code, 0) << a.output;
    const auto b = horizon("viewshed rainier" + server() + kRainierEye + flags + " -o " + remote + " --png " +
                           dir_.file("remote.png") + " --json");
    ASSERT_EQ(b.exit_code, 0) << b.output;
    const std::string tif = read_bytes(full);
    ASSERT_GT(tif.size(), 1000u);
    EXPECT_TRUE(tif == read_bytes(remote)) << "GeoTIFFs differ for" << flags;
    EXPECT_EQ(read_bytes(dir_.file("full.qml")), read_bytes(dir_.file("remote.qml"))) << "styles differ for" << flags;
    EXPECT_TRUE(read_bytes(dir_.file("local.png")) == read_bytes(dir_.file("remote.png")))
        << "PNGs differ for" << flags;
    const Json ja = json_of(a), jb = json_of(b);
    for (const char* key :
         {"visible_cells", "hidden_cells", "evaluated_cells", "window", "algorithm", "output_kind", "codes"})
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
  const std::string dem = rainier_named_as_the_dataset(dir_);
  // The shared viewshed flags reach the daemon for every site, as embedded mode applies them.
  for (const char* shared : {" --azimuth 200,20 --min-distance 300 --observer-ground cell --refraction 0.2",
                             " -f COG -co BLOCKSIZE=64 -co COMPRESS=ZSTD"}) {
    const std::string flags = " --observers " + towers + " --max-distance 2500 --target-height 1.5" + shared;
    const auto a = horizon("viewshed " + dem + flags + " -o " + dir_.file("local.tif"));
    ASSERT_EQ(a.exit_code, 0) << a.output;
    const auto b = horizon("viewshed rainier" + server() + flags + " -o " + dir_.file("remote.tif"));
    ASSERT_EQ(b.exit_code, 0) << b.output;
    const std::string tif = read_bytes(dir_.file("local.tif"));
    ASSERT_GT(tif.size(), 1000u);
    EXPECT_TRUE(tif == read_bytes(dir_.file("remote.tif"))) << "count GeoTIFFs differ with" << shared;
  }
  const std::string flags = " --observers " + towers + " --max-distance 2500 --target-height 1.5";
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

// `horizon trace --server`: the depth and hit TIFFs, the footprint GeoTIFF
// and the shaded PNG byte for byte, and the JSON but the times: a pinhole
// with boxes (their ids echoed) and an edit over Rainier, and a panorama
// with column crossings over Everest's filled voids.
TEST_F(ServerCli, TraceFilesAreByteIdenticalToEmbedded) {
  const std::string boxes = dir_.file("boxes.csv");
  write_file(boxes,
             "id,x_min,y_min,x_max,y_max,z_min,z_max\n"
             "17,-121.765,46.848,-121.755,46.856,4300,4500\n"
             "23,-121.80,46.75,-121.79,46.76,0,10\n"
             "99,-80.0,46.75,-79.99,46.76,0,10\n");
  struct Run {
    std::string dataset, file, flags;
  };
  const Run runs[] = {
      {"rainier", "rainier_summit_srtm3_400x400.tif",
       " --lat 46.70 --lon -121.90 --height 800 --yaw 40 --pitch -3 --hfov 60 --size 320x180 --boxes " + boxes +
           " --lonlat --edit -121.89,46.72,-121.86,46.73,+300"},
      {"everest", "everest_summit_voids_srtm3_300x300.tif",
       " --lat 27.9881 --lon 86.925 --altitude 8850 --projection cylindrical --hfov 360 --pitch -10 --size 720x120"
       " --columns --nodata fill:0 --max-distance 12000 --near 5 --curvature 0.5"},
  };
  for (const Run& run : runs) {
    std::string outputs[2];
    for (int k = 0; k < 2; ++k) {
      const std::string p = dir_.file(k ? "remote" : "local");
      outputs[k] = " -o " + p + "_depth.tif --hits " + p + "_hits.tif --footprint " + p + "_seen.tif --png " + p +
                   "_view.png --json";
    }
    const auto a = horizon("trace " + bundled_dem(run.file) + run.flags + outputs[0]);
    ASSERT_EQ(a.exit_code, 0) << a.output;
    const auto b = horizon("trace " + run.dataset + server() + run.flags + outputs[1]);
    ASSERT_EQ(b.exit_code, 0) << b.output;
    for (const char* file : {"_depth.tif", "_hits.tif", "_seen.tif", "_view.png"}) {
      const std::string local = read_bytes(dir_.file(std::string("local") + file));
      ASSERT_GT(local.size(), 1000u) << file;
      EXPECT_TRUE(local == read_bytes(dir_.file(std::string("remote") + file)))
          << file << " differs for " << run.dataset;
    }
    Json ja = json_of(a), jb = json_of(b);
    EXPECT_EQ(jb["server"]["address"], daemon_->address());
    for (Json* j : {&ja, &jb}) {
      j->erase("dem");
      j->erase("seconds");
      j->erase("server");
      (*j)["trace"].erase("seconds");
    }
    EXPECT_EQ(ja, jb) << run.dataset;
    EXPECT_GT(ja["trace"]["sky_pixels"].get<std::uint64_t>(), 0u);
    if (run.dataset == "rainier") {
      ASSERT_EQ(jb["boxes"].size(), 3u);
      EXPECT_EQ(jb["boxes"][0]["id"], 17);
      EXPECT_EQ(jb["boxes"][1]["id"], 23);
      EXPECT_EQ(jb["boxes"][2]["id"], 99);
      EXPECT_GT(jb["boxes"][0]["visible_pixels"].get<std::uint64_t>(), 0u);
      EXPECT_EQ(jb["boxes"][2]["pixels"], 0);  // off the dataset
      EXPECT_GT(jb["edited_cells"].get<std::uint64_t>(), 10u);
    } else {
      EXPECT_EQ(jb["mode"], "rows+columns");
      EXPECT_EQ(jb["projection"], "cylindrical");
    }
  }
  // The text report names the daemon and the boxes by their ids.
  const auto text = horizon("trace rainier" + server() + runs[0].flags);
  ASSERT_EQ(text.exit_code, 0) << text.output;
  EXPECT_NE(text.output.find("Camera trace over rainier on " + daemon_->address()), std::string::npos) << text.output;
  EXPECT_NE(text.output.find("box 99:      not in the frame"), std::string::npos) << text.output;
}

TEST_F(ServerCli, TraceRefusesEmbeddedOnlyFlagsAndReportsTheDaemonsErrors) {
  const std::string out = dir_.file("depth.tif");
  const std::string camera = " --lat 46.70 --lon -121.90 --height 800 --size 64x36 -o " + out;
  for (const char* flag : {" --band 1", " --threads 2"}) {
    const auto r = horizon("trace rainier" + server() + camera + flag);
    EXPECT_EQ(r.exit_code, 2) << flag << ": " << r.output;
    EXPECT_NE(r.output.find(std::string(flag).substr(1, std::string(flag).find(' ', 1) - 1)), std::string::npos)
        << r.output;
    EXPECT_NE(r.output.find("runs embedded only"), std::string::npos) << r.output;
  }
  const std::string path = dir_.file("path.csv");
  write_file(path, "-121.90,46.70,800,40\n");
  const auto flown = horizon("trace rainier" + server() + " --path " + path + " --lonlat --json");
  EXPECT_EQ(flown.exit_code, 2) << flown.output;
  EXPECT_NE(flown.output.find("--path runs embedded only"), std::string::npos) << flown.output;
  // The daemon's refusals: a camera off the dataset, an edit off it; nothing is written.
  const auto off = horizon("trace rainier" + server() + " --lat 46.0 --lon -121.7 -o " + out);
  EXPECT_EQ(off.exit_code, 1) << off.output;
  EXPECT_NE(off.output.find("OUT_OF_RANGE"), std::string::npos) << off.output;
  EXPECT_NE(off.output.find("field camera.position"), std::string::npos) << off.output;
  const auto edit = horizon("trace rainier" + server() + camera + " --edit 0,0,1,1,=5");
  EXPECT_EQ(edit.exit_code, 1) << edit.output;
  EXPECT_NE(edit.output.find("field edits[0].rect"), std::string::npos) << edit.output;
  const auto unknown = horizon("trace nowhere" + server() + camera);
  EXPECT_EQ(unknown.exit_code, 1) << unknown.output;
  EXPECT_NE(unknown.output.find("NOT_FOUND"), std::string::npos) << unknown.output;
  EXPECT_FALSE(std::ifstream(out).good());
}

}  // namespace
}  // namespace horizon::testing
