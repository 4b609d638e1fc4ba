// `horizon session`: a conservative flight, traced on the CPU or the GPU,
// never counts fewer boxes visible than exact culling from the same pose; every pose is answered in order
// when the client waits for each; wrong files and shapes are usage errors
// naming the line or the flag.
#include <gtest/gtest.h>

#include <fstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "test_support.hpp"

namespace horizon::testing {
namespace {

using Json = nlohmann::json;


CommandResult horizon(const std::vector<std::string>& args) {
  std::string command = shell_quote(HORIZON_CLI_PATH);
  for (const std::string& a : args) {
    command.push_back(' ');
    command.append(shell_quote(a));
  }
  command.append(" 2>&1");
  return run_command(command);
}

struct Flight {
  TempDir dir;
  std::string poses = dir.file("flight.csv"), boxes = dir.file("boxes.csv");
  const std::string dem = bundled_dem("rainier_summit_srtm3_400x400.tif");
  Flight() {
    std::ofstream p(poses);
    p << "lon,lat,altitude,east,north\n";
    for (int i = 0; i < 12; ++i) p << -121.86 + i * 0.01 << ",46.8529,3500,250,0\n";
    std::ofstream b(boxes);
    for (int i = 0; i < 60; ++i) {
      const double x = -121.9 + 0.005 * i, y = 46.7 + 0.0045 * i;
      b << x << "," << y << "," << x + 0.002 << "," << y + 0.001 << ",0," << 1800 + 35 * i << "\n";
    }
  }
};

TEST(CliSession, AConservativeFlightNeverCountsFewerVisibleThanExactCullingOnTheCpuOrTheGpu) {
  Flight f;
  for (const std::string backend : {"cpu", "gpu"}) {
    const CommandResult r = horizon({"session", f.dem, "--path", f.poses, "--boxes", f.boxes, "--lonlat", "--absolute",
                                     "--level-size", "64", "--subtile", "16", "--conservative", "--backend", backend,
                                     "--json"});
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const Json j = Json::parse(r.output);
    EXPECT_EQ(j["clipmap"]["levels"], 4);
    EXPECT_EQ(j["answered"], 12);
    EXPECT_EQ(j["dropped"], 0);
    EXPECT_EQ(j["backend"], backend);
    EXPECT_EQ(j["answers_on_gpu"], backend == "gpu" ? 12 : 0) << j.value("gpu_fallback", "");
    ASSERT_EQ(j["poses"].size(), 12u);
    for (int i = 0; i < 12; i += 5) {
      const Json& pose = j["poses"][static_cast<std::size_t>(i)];
      EXPECT_EQ(pose["seq"], i + 1);
      EXPECT_EQ(pose["backend"], backend);
      const CommandResult cull =
          horizon({"cull", f.dem, "--lon", std::to_string(-121.86 + i * 0.01), "--lat", "46.8529", "--altitude",
                   "3500", "--boxes", f.boxes, "--lonlat", "--algorithm", "exact", "--json"});
      ASSERT_EQ(cull.exit_code, 0) << cull.output;
      const int exact_visible = Json::parse(cull.output)["visible_count"];
      EXPECT_GE(pose["visible"].get<int>(), exact_visible) << backend << " pose " << i + 1;
      EXPECT_LT(exact_visible, 60) << "the terrain hides something";
    }
  }
}

TEST(CliSession, AnExactFlightCountsWhatExactCullingCountsAtEveryPose) {
  Flight f;
  const CommandResult r = horizon({"session", f.dem, "--path", f.poses, "--boxes", f.boxes, "--lonlat", "--absolute",
                                   "--exact", "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json j = Json::parse(r.output);
  EXPECT_EQ(j["mode"], "exact");
  EXPECT_FALSE(j.contains("clipmap")) << "an exact session keeps no clip-map";
  ASSERT_EQ(j["poses"].size(), 12u);
  for (int i = 0; i < 12; i += 4) {
    const CommandResult cull =
        horizon({"cull", f.dem, "--lon", std::to_string(-121.86 + i * 0.01), "--lat", "46.8529", "--altitude", "3500",
                 "--boxes", f.boxes, "--lonlat", "--algorithm", "exact", "--json"});
    ASSERT_EQ(cull.exit_code, 0) << cull.output;
    EXPECT_EQ(j["poses"][static_cast<std::size_t>(i)]["visible"], Json::parse(cull.output)["visible_count"])
        << "pose " << i + 1;
  }
  const CommandResult both = horizon({"session", f.dem, "--path", f.poses, "--boxes", f.boxes, "--lonlat",
                                      "--absolute", "--exact", "--conservative"});
  EXPECT_EQ(both.exit_code, 2) << both.output;
  EXPECT_NE(both.output.find("--conservative or --exact"), std::string::npos) << both.output;
}

TEST(CliSession, PerPoseViewshedsCountWhatTheViewshedCommandCounts) {
  Flight f;
  for (const char* mode : {"--exact", "--conservative"}) {
    const CommandResult r = horizon({"session", f.dem, "--path", f.poses, "--boxes", f.boxes, "--lonlat", "--absolute",
                                     "--level-size", "64", "--subtile", "16", mode, "--viewshed-radius", "6000",
                                     "--json"});
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const Json j = Json::parse(r.output);
    for (int i = 0; i < 12; i += 6) {
      const Json& v = j["poses"][static_cast<std::size_t>(i)]["viewshed"];
      TempDir out;
      const CommandResult exact =
          horizon({"viewshed", f.dem, "--lon", std::to_string(-121.86 + i * 0.01), "--lat", "46.8529", "--altitude",
                   "3500", "--max-distance", "6000", "--algorithm", "exact", "--json", "-o", out.file("v.tif")});
      ASSERT_EQ(exact.exit_code, 0) << exact.output;
      const Json e = Json::parse(exact.output);
      EXPECT_GT(e["hidden_cells"].get<int>(), 100) << "the terrain hides something";
      const int cells = e["visible_cells"].get<int>() + e["hidden_cells"].get<int>();
      if (std::string(mode) == "--exact") {
        EXPECT_EQ(v["visible_cells"], e["visible_cells"]) << "pose " << i + 1;
        EXPECT_EQ(v["hidden_cells"], e["hidden_cells"]) << "pose " << i + 1;
      } else {
        // The clip-map measures the radius with the eye's cell size (flat), the viewshed along the
        // geographic grid's rows: on this lon/lat DEM their discs differ by a few per cent. Where
        // the loader has not brought level 0 yet (the loader runs on its own thread, and lags
        // under load), a cell counts as seen even if it is a void, so the session may count more
        // cells than the viewshed, never fewer than the disc's difference allows.
        const int got = v["visible_cells"].get<int>() + v["hidden_cells"].get<int>();
        EXPECT_GE(got, cells * 0.94) << "pose " << i + 1;
        EXPECT_LE(got, cells * 1.25) << "pose " << i + 1;
        EXPECT_LE(v["hidden_cells"].get<int>(), e["hidden_cells"].get<int>() + cells * 0.06) << "pose " << i + 1;
      }
    }
  }
  const CommandResult bad = horizon({"session", f.dem, "--path", f.poses, "--boxes", f.boxes, "--lonlat",
                                     "--absolute", "--viewshed-radius", "-3"});
  EXPECT_EQ(bad.exit_code, 2) << bad.output;
  EXPECT_NE(bad.output.find("--viewshed-radius"), std::string::npos) << bad.output;
}

TEST(CliSession, WrongFilesAndShapesAreUsageErrorsNamingTheLineOrFlag) {
  Flight f;
  {
    std::ofstream p(f.poses, std::ios::app);
    p << "-121.7,46.8\n";
  }
  CommandResult r = horizon({"session", f.dem, "--path", f.poses, "--boxes", f.boxes, "--lonlat"});
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("line 14"), std::string::npos) << r.output;
  Flight g;
  r = horizon({"session", g.dem, "--path", g.poses, "--boxes", g.boxes, "--lonlat", "--absolute", "--level-size", "100"});
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--level-size"), std::string::npos) << r.output;
  r = horizon({"session", g.dem, "--path", g.poses, "--boxes", g.boxes, "--lonlat", "--absolute", "--level-size", "64",
               "--levels", "2"});
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--levels"), std::string::npos) << r.output;
  r = horizon({"session", g.dem, "--path", g.poses, "--boxes", g.boxes, "--lonlat", "--session-id", "a"});
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--session-id needs --server"), std::string::npos) << r.output;
  r = horizon({"session", "rainier", "--server", "127.0.0.1:1", "--path", g.poses, "--boxes", g.boxes, "--lonlat",
               "--session-id", "no spaces"});
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--session-id: 1 to 64"), std::string::npos) << r.output;
  r = horizon({"session", g.dem, "--path", g.poses, "--boxes", g.boxes, "--lonlat", "--exact", "--backend", "gpu"});
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--backend gpu traces clip-maps"), std::string::npos) << r.output;
  r = horizon({"session", g.dem, "--path", g.poses, "--boxes", g.boxes, "--lonlat", "--backend", "tpu"});
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--backend"), std::string::npos) << r.output;
  r = horizon({"session", g.dem, "--boxes", g.boxes});
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--path"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace horizon::testing
