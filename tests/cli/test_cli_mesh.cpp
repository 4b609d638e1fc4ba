// `horizon mesh prepare|cull` end to end: a DEM made a TIN, prepared and culled; the
// JSON's counts and ranges against each other, the raster of drawn
// triangles and the mesh written in group order; a mesh file as input;
// usage errors by flag.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "cli_run.hpp"
#include "horizon/terrain/dem_reader.hpp"
#include "test_support.hpp"

namespace horizon::testing {
namespace {

using Json = nlohmann::json;

const std::string kAndes = "ecuador_andes_utm17s_10m_383x415.tif";  // UTM 17S, 10 m

std::vector<std::string> mesh_args(std::vector<std::string> more) {
  std::vector<std::string> args = {"mesh", "cull",       bundled_dem(kAndes), "--vertices",
                                   "3000", "--observer", "713500,9558500"};
  args.insert(args.end(), more.begin(), more.end());
  return args;
}

TEST(CliMesh, CullsATinOfADemAndWritesWhatItDraws) {
  TempDir dir;
  const std::string raster = dir.file("drawn.tif"), obj = dir.file("prepared.obj");
  const auto r = horizon(mesh_args({"--json", "-o", raster, "--mesh-out", obj}));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json j = Json::parse(r.output);
  const std::uint64_t triangles = j["triangles"];
  EXPECT_EQ(j["vertices"], 3000);
  EXPECT_EQ(j["mode"], "approximate");
  EXPECT_EQ(j["local_frame"], "the CRS");
  const Json& cull = j["cull"];
  EXPECT_GT(cull["triangles_culled"].get<std::uint64_t>(), 0u);
  EXPECT_EQ(cull["triangles_culled"].get<std::uint64_t>() + cull["triangles_drawn"].get<std::uint64_t>(), triangles);
  // Drawn ranges are disjoint runs before the always-visible run.
  std::vector<bool> drawn(triangles, false);
  std::uint64_t drawn_count = 0;
  for (const Json& g : j["drawn_groups"]) {
    const std::uint64_t first = g["first_triangle"], count = g["triangle_count"];
    ASSERT_LE(first + count, j["always_visible"]["first_triangle"].get<std::uint64_t>());
    for (std::uint64_t t = first; t < first + count; ++t) {
      EXPECT_FALSE(drawn[t]);
      drawn[t] = true;
    }
    drawn_count += count;
  }
  EXPECT_EQ(drawn_count + j["always_visible"]["triangle_count"].get<std::uint64_t>(),
            cull["triangles_drawn"].get<std::uint64_t>());

  // The raster: the DEM's grid, each value one of the four.
  auto grid = terrain::read_dem(raster);
  ASSERT_TRUE(grid.ok()) << grid.error().message;
  auto dem = terrain::read_dem(bundled_dem(kAndes));
  ASSERT_TRUE(dem.ok());
  EXPECT_EQ(grid->width(), dem->width());
  EXPECT_EQ(grid->height(), dem->height());
  EXPECT_EQ(grid->georef.transform, dem->georef.transform);
  std::uint64_t counts[4] = {};
  for (int row = 0; row < grid->height(); ++row)
    for (int col = 0; col < grid->width(); ++col) {
      const float v = grid->elevation.at(col, row);
      if (std::isnan(v)) continue;  // 255, no triangle
      ASSERT_TRUE(v == 0 || v == 1 || v == 2) << v;
      ++counts[static_cast<int>(v)];
    }
  EXPECT_GT(counts[0], 0u);  // culled ground
  EXPECT_GT(counts[1], 0u);  // drawn
  EXPECT_GT(counts[2], 0u);  // always visible

  // The prepared mesh, read back as input, keeps its size.
  std::ifstream in(obj);
  std::size_t v = 0, f = 0;
  for (std::string line; std::getline(in, line);) {
    v += line.rfind("v ", 0) == 0;
    f += line.rfind("f ", 0) == 0;
  }
  EXPECT_EQ(v, 3000u);
  EXPECT_EQ(f, triangles);
  const auto again = horizon({"mesh", "cull", obj, "--observer", "713500,9558500", "--json", "--conservative"});
  ASSERT_EQ(again.exit_code, 0) << again.output;
  const Json k = Json::parse(again.output);
  EXPECT_EQ(k["triangles"], triangles);
  EXPECT_EQ(k["mode"], "conservative");
}

TEST(CliMesh, ACacheDirectoryKeepsThePreparedMesh) {
  TempDir dir;
  const std::string cache = dir.file("prepared");
  const auto first = horizon(mesh_args({"--json", "--cache", cache}));
  ASSERT_EQ(first.exit_code, 0) << first.output;
  const auto second = horizon(mesh_args({"--json", "--cache", cache}));
  ASSERT_EQ(second.exit_code, 0) << second.output;
  const Json a = Json::parse(first.output), b = Json::parse(second.output);
  EXPECT_FALSE(a["cache"]["hit"].get<bool>());
  EXPECT_TRUE(b["cache"]["hit"].get<bool>());
  EXPECT_EQ(a["cache"]["path"], b["cache"]["path"]);
  EXPECT_EQ(a["drawn_groups"], b["drawn_groups"]);
  EXPECT_EQ(a["cull"]["triangles_culled"], b["cull"]["triangles_culled"]);
  // Other knobs are another entry.
  const auto other = horizon(mesh_args({"--json", "--cache", cache, "--random-seed", "5"}));
  ASSERT_EQ(other.exit_code, 0) << other.output;
  EXPECT_FALSE(Json::parse(other.output)["cache"]["hit"].get<bool>());
}

// `prepare` stops before the cull: what it keeps in the cache is what `cull`
// then loads, and its --mesh-out is the same TIN in the same order.
TEST(CliMesh, PrepareFillsTheCacheThatCullThenUses) {
  TempDir dir;
  const std::string cache = dir.file("prepared"), a = dir.file("a.obj"), b = dir.file("b.obj");
  const auto prepared = horizon(
      {"mesh", "prepare", bundled_dem(kAndes), "--vertices", "3000", "--json", "--cache", cache, "--mesh-out", a});
  ASSERT_EQ(prepared.exit_code, 0) << prepared.output;
  const Json p = Json::parse(prepared.output);
  EXPECT_EQ(p["vertices"], 3000);
  EXPECT_GT(p["prepare"]["groups"].get<int>(), 0);
  EXPECT_GT(p["prepare"]["resident_bytes"].get<std::uint64_t>(), 0u);
  EXPECT_GT(p["fit"]["max_error_m"].get<double>(), 0.0);
  EXPECT_FALSE(p["cache"]["hit"].get<bool>());
  EXPECT_FALSE(p.contains("cull"));
  EXPECT_EQ(p["mesh_out"], a);

  const auto culled = horizon(mesh_args({"--json", "--cache", cache, "--mesh-out", b}));
  ASSERT_EQ(culled.exit_code, 0) << culled.output;
  const Json c = Json::parse(culled.output);
  EXPECT_TRUE(c["cache"]["hit"].get<bool>());
  EXPECT_EQ(c["prepare"]["groups"], p["prepare"]["groups"]);
  EXPECT_EQ(c["prepare"]["always_visible_triangles"], p["prepare"]["always_visible_triangles"]);
  std::ifstream fa(a), fb(b);
  const std::string ta((std::istreambuf_iterator<char>(fa)), {}), tb((std::istreambuf_iterator<char>(fb)), {});
  EXPECT_FALSE(ta.empty());
  EXPECT_EQ(ta, tb);

  // The plain report names the fit and the groups.
  const auto text = horizon({"mesh", "prepare", bundled_dem(kAndes), "--vertices", "1000"});
  ASSERT_EQ(text.exit_code, 0) << text.output;
  EXPECT_NE(text.output.find("1000 vertices"), std::string::npos) << text.output;
  EXPECT_NE(text.output.find("against the DEM"), std::string::npos) << text.output;
}

TEST(CliMesh, BoxesMayBeGivenInLongitudeAndLatitude) {
  const auto r = horizon({"mesh", "cull", bundled_dem("rainier_summit_srtm3_400x400.tif"), "--vertices", "2000",
                          "--lat", "46.80", "--lon", "-121.70", "--boxes",
                          std::string(HORIZON_DATA_DIR) + "/../../examples/rainier_boxes.csv", "--lonlat", "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json j = Json::parse(r.output);
  EXPECT_GT(j["boxes"]["count"].get<int>(), 0);
  EXPECT_EQ(j["boxes"]["boxes"].size(), j["boxes"]["count"].get<std::size_t>());
}

TEST(CliMesh, TheVerbIsRequiredAndEachTakesItsOwnFlags) {
  struct Case {
    std::vector<std::string> args;
    std::string says;
  };
  const Case cases[] = {
      {{"mesh"}, "missing the verb"},
      {{"mesh", "draw", bundled_dem(kAndes)}, "unknown verb 'draw'"},
      {{"mesh", "prepare"}, "missing the DEM or mesh file operand"},
      {{"mesh", "prepare", bundled_dem(kAndes), "--observer", "713500,9558500"},
       "--observer: a flag of `horizon mesh cull`"},
      {{"mesh", "prepare", bundled_dem(kAndes), "--conservative"}, "--conservative: a flag of `horizon mesh cull`"},
      {{"mesh", "prepare", bundled_dem(kAndes), "--server", "localhost:1"}, "--server: a daemon prepares its meshes"},
      {{"mesh", "cull", bundled_dem(kAndes), "--observer", "713500,9558500", "--registered-boxes"},
       "--registered-boxes: a flag of --server"},
      {{"mesh", "cull", "tin", "--server", "localhost:1", "--observer", "1,2", "--cache", "x"},
       "--cache: applies to a local input"},
      {{"mesh", "cull", bundled_dem(kAndes), "--observer", "713500,9558500", "--lonlat"}, "--lonlat: says how --boxes"},
  };
  for (const Case& c : cases) {
    const auto r = horizon(c.args);
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_NE(r.output.find(c.says), std::string::npos) << c.says << "\n" << r.output;
  }
}

TEST(CliMesh, AnswersBoxesWithTheMesh) {
  TempDir dir;
  const std::string boxes = dir.file("boxes.csv");
  std::ofstream(boxes) << "# id,x_min,y_min,x_max,y_max,z_min,z_max\n"
                          "7,713000,9558000,713020,9558020,2000,2020\n"
                          "9,714000,9559000,714030,9559030,2100,2110\n";
  const auto r = horizon(mesh_args({"--json", "--boxes", boxes}));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json j = Json::parse(r.output);
  EXPECT_EQ(j["boxes"]["count"], 2);
  EXPECT_EQ(j["boxes"]["boxes"][0]["id"], 7);
  EXPECT_EQ(j["boxes"]["boxes"][1]["id"], 9);
  EXPECT_TRUE(j["boxes"]["boxes"][0]["hidden"].is_boolean());
  std::ofstream(boxes) << "1,2,3\n";
  const auto bad = horizon(mesh_args({"--json", "--boxes", boxes}));
  EXPECT_EQ(bad.exit_code, 2) << bad.output;
  EXPECT_NE(bad.output.find("boxes.csv"), std::string::npos) << bad.output;
}

TEST(CliMesh, BenchSweepsShapesAndModesAgainstExactSight) {
  TempDir dir;
  const auto r = horizon({"bench", "--mesh", bundled_dem(kAndes), "--vertices", "1500", "--sectors", "8/1,16/4",
                          "--cameras", "6", "--exact", "2", "--out", dir.path().string()});
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::ifstream csv(dir.file("bench_mesh.csv"));
  std::vector<std::string> lines;
  for (std::string line; std::getline(csv, line);) lines.push_back(line);
  ASSERT_EQ(lines.size(), 5u);  // header, 2 shapes x 2 modes
  EXPECT_EQ(lines[0].rfind("dem,vertices,triangles,sectors,subsectors,mode,", 0), 0u);
  EXPECT_NE(lines[1].find(",8,1,approximate,"), std::string::npos) << lines[1];
  EXPECT_NE(lines[4].find(",16,4,conservative,"), std::string::npos) << lines[4];
  // The last column, false hidden, is 0 for the conservative rows.
  for (std::size_t i : {2u, 4u}) EXPECT_EQ(lines[i].substr(lines[i].rfind(',') + 1), "0") << lines[i];
  EXPECT_TRUE(std::filesystem::exists(dir.file("bench_mesh.md")));

  const auto stray = horizon({"bench", bundled_dem(kAndes), "--vertices", "10", "--out", dir.path().string()});
  EXPECT_EQ(stray.exit_code, 2) << stray.output;
  EXPECT_NE(stray.output.find("--vertices: a flag of the mesh sweep; add --mesh"), std::string::npos) << stray.output;
  const auto flat =
      horizon({"bench", "--mesh", bundled_dem(kAndes), "--curvature", "0.5", "--out", dir.path().string()});
  EXPECT_EQ(flat.exit_code, 2) << flat.output;
  EXPECT_NE(flat.output.find("--curvature: the mesh sweep reads R3 on a flat earth"), std::string::npos) << flat.output;
}

TEST(CliMesh, GeographicDemsArePreparedInMetres) {
  const auto r = horizon({"mesh", "cull", bundled_dem("rainier_summit_srtm3_400x400.tif"), "--vertices", "2000",
                          "--lat", "46.80", "--lon", "-121.70", "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json j = Json::parse(r.output);
  EXPECT_EQ(j["local_frame"], "tangent plane at the DEM's centre");
  EXPECT_GT(j["cull"]["triangles_culled"].get<std::uint64_t>(), 0u);
}

TEST(CliMesh, UsageErrorsNameTheFlagAndWriteNothing) {
  TempDir dir;
  const std::string out = dir.file("drawn.tif");
  const std::string obj = dir.file("m.obj");
  std::ofstream(obj) << "v 0 0 0\nv 10 0 0\nv 0 10 1\nf 1 2 3\n";
  struct Case {
    std::vector<std::string> args;
    std::string says;
  };
  const Case cases[] = {
      {mesh_args({"--sectors", "16", "-o", out}), "--sectors"},
      {mesh_args({"--height", "2", "--altitude", "3000", "-o", out}), "--altitude"},
      {mesh_args({"--azimuth", "10", "-o", out}), "--azimuth"},
      {{"mesh", "cull", obj, "--lat", "1", "--lon", "2", "-o", out}, "--observer"},
      {{"mesh", "cull", obj, "--observer", "1,1", "-o", out}, "need a DEM"},
  };
  for (const Case& c : cases) {
    const auto r = horizon(c.args);
    EXPECT_EQ(r.exit_code, 2) << c.says << ": " << r.output;
    EXPECT_NE(r.output.find(c.says), std::string::npos) << r.output;
    EXPECT_FALSE(std::filesystem::exists(out)) << c.says;
  }
  // The engine's refusals (exit 1) name what is wrong.
  const auto cutoff = horizon(mesh_args({"--merge-cutoff", "2", "-o", out}));
  EXPECT_EQ(cutoff.exit_code, 1) << cutoff.output;
  EXPECT_NE(cutoff.output.find("merge_cutoff must be"), std::string::npos) << cutoff.output;
  const auto off = horizon({"mesh", "cull", obj, "--observer", "50,50"});
  EXPECT_EQ(off.exit_code, 1) << off.output;
  EXPECT_NE(off.output.find("off the mesh"), std::string::npos) << off.output;
  EXPECT_FALSE(std::filesystem::exists(out));
}

}  // namespace
}  // namespace horizon::testing
