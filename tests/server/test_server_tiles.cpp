// A daemon serving a folder of tiles answers as it does for the file they
// were cut from (viewsheds byte for byte, culling, lines of sight), reads
// through one block cache whose resident bytes stay under its budget, and
// fails only the requests that need a missing tile.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "daemon_process.hpp"
#include "horizon/terrain/dem_reader.hpp"
#include "rpc_helpers.hpp"
#include "test_support.hpp"

namespace horizon::testing {
namespace {

namespace fs = std::filesystem;

CommandResult horizon(const std::string& args) {
  return run_command(std::string(HORIZON_CLI_PATH) + " " + args);
}

// A Prometheus sample's value ("name 123" or "name{labels} 123"); -1 when absent.
double metric(const std::string& text, const std::string& series) {
  const auto at = text.find("\n" + series + " ");
  if (at == std::string::npos) return -1;
  return std::stod(text.substr(at + series.size() + 2));
}

class ServerTiles : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    data_ = new TempDir();
    const std::string file = "zion_canyon_srtm3_465x457.tif";
    fs::copy_file(bundled_dem(file), data_->path() / file);
    auto dem = terrain::read_dem(bundled_dem(file));
    ASSERT_TRUE(dem.ok());
    for (const char* folder : {"tiles", "holey"}) {
      fs::create_directory(data_->path() / folder);
      ASSERT_EQ(write_tiles(*dem, 3, 3, data_->file(folder)).size(), 9u);
    }
    // The centre tile (cells 155..309 x 152..303) gone from one of them.
    fs::remove(data_->path() / "holey" / "tile_1_1.tif");
    DaemonOptions o;
    o.data_root = data_->path().string();
    o.datasets = {{"zion", file}, {"tiles", "tiles"}, {"holey", "holey"}};
    // 2 MiB of cache: less than the three datasets' 2.5 MiB of elevations.
    o.extra_json = R"("block_cache_mb": 2, "engine_threads": 1,)";
    daemon_ = new DaemonProcess(o);
  }
  static void TearDownTestSuite() {
    delete daemon_;
    delete data_;
  }
  void SetUp() override { ASSERT_TRUE(daemon_->ready()) << daemon_->error(); }
  std::string server() const { return " --server " + daemon_->address(); }

  static TempDir* data_;
  static DaemonProcess* daemon_;
  TempDir out_;
};
TempDir* ServerTiles::data_ = nullptr;
DaemonProcess* ServerTiles::daemon_ = nullptr;

// The centre tile's north-west corner, cell (155, 152), and cell (60, 60) inside the north-west tile.
const std::string kOnTheCorner = " --observer -113.109999879,37.385833430";
const std::string kNorthWest = " --observer -113.189167,37.4625";

TEST_F(ServerTiles, ViewshedsOfTheTilesAreByteIdenticalToTheFile) {
  for (const std::string& eye : {kOnTheCorner, kNorthWest})
    for (const char* flags : {" --max-distance 4000", " --max-distance 9000 --output ohf",
                              " --algorithm exact --max-distance 3000 --output min-target-height"}) {
      const std::string a = out_.file("a.tif"), b = out_.file("b.tif");
      const auto ra = horizon("viewshed zion" + server() + eye + flags + " -o " + a);
      const auto rb = horizon("viewshed tiles" + server() + eye + flags + " -o " + b);
      ASSERT_EQ(ra.exit_code, 0) << ra.output;
      ASSERT_EQ(rb.exit_code, 0) << rb.output;
      const std::string bytes = read_bytes(a);
      ASSERT_GT(bytes.size(), 1000u);
      EXPECT_TRUE(bytes == read_bytes(b)) << eye << flags;
    }
}

TEST_F(ServerTiles, CullingAndLinesOfSightOfTheTilesEqualTheFile) {
  auto visibility = v1::VisibilityService::NewStub(daemon_->channel());
  v1::CullBoxesResponse answers[2];
  v1::LineOfSightResponse lines[2];
  int k = 0;
  for (const char* name : {"zion", "tiles"}) {
    v1::CullBoxesRequest cull;
    cull.set_dataset(name);
    // Cell (310.5, 287.5): on the border of the east and centre tiles.
    *cull.mutable_observer() = point(-112.980416667, 37.2729166667, 10, v1::FRAME_WGS84);
    for (int i = 0; i < 60; ++i) {
      v1::Box* b = cull.add_boxes();
      b->set_frame(v1::FRAME_WGS84);
      b->set_x_min(-113.08 + 0.003 * i);
      b->set_x_max(-113.08 + 0.003 * i + 0.0008);
      b->set_y_min(37.20 + 0.002 * (i % 30));
      b->set_y_max(37.20 + 0.002 * (i % 30) + 0.0006);
      b->set_z_min(1000);
      b->set_z_max(1300 + 60 * i);
    }
    grpc::Status s = visibility->CullBoxes(context_with_deadline().get(), cull, &answers[k]);
    ASSERT_TRUE(s.ok()) << s.error_message();
    v1::LineOfSightRequest los;
    los.set_dataset(name);
    los.set_include_profile(true);
    for (double lon : {-113.07, -112.95, -112.91}) {
      v1::SightLine* l = los.add_lines();
      *l->mutable_from() = point(-112.980416667, 37.2729166667, 10, v1::FRAME_WGS84);
      *l->mutable_to() = point(lon, 37.33, 2, v1::FRAME_WGS84);
    }
    s = visibility->LineOfSight(context_with_deadline().get(), los, &lines[k]);
    ASSERT_TRUE(s.ok()) << s.error_message();
    ++k;
  }
  ASSERT_EQ(answers[0].boxes_size(), 60);
  EXPECT_GT(answers[0].visible_count(), 0u);
  EXPECT_LT(answers[0].visible_count(), 60u);
  EXPECT_EQ(answers[0].visible_count(), answers[1].visible_count());
  for (int i = 0; i < 60; ++i) {
    EXPECT_EQ(answers[0].boxes(i).state(), answers[1].boxes(i).state()) << i;
    EXPECT_EQ(answers[0].boxes(i).ohf_min(), answers[1].boxes(i).ohf_min()) << i;
  }
  EXPECT_EQ(answers[0].window().SerializeAsString(), answers[1].window().SerializeAsString());
  EXPECT_EQ(lines[0].SerializeAsString(), lines[1].SerializeAsString());
}

TEST_F(ServerTiles, TheCacheStaysUnderItsBudgetAndServesRepeatsFromMemory) {
  // A second request for the same window decodes nothing.
  const std::string args = server() + kNorthWest + " --max-distance 3000 -o " + out_.file("v.tif");
  ASSERT_EQ(horizon("viewshed tiles" + args).exit_code, 0);
  const std::string before = daemon_->metrics();
  ASSERT_EQ(horizon("viewshed tiles" + args).exit_code, 0);
  const std::string after = daemon_->metrics();
  const double decoded = metric(after, "horizon_block_cache_decoded_bytes_total");
  ASSERT_GT(decoded, 0);
  EXPECT_EQ(decoded, metric(before, "horizon_block_cache_decoded_bytes_total"));
  EXPECT_GT(metric(after, "horizon_block_cache_requests_total{result=\"hit\"}"),
            metric(before, "horizon_block_cache_requests_total{result=\"hit\"}"));
  // Whole-dataset requests on all three datasets pass through a 2 MiB cache.
  for (const char* name : {"zion", "tiles"})
    ASSERT_EQ(horizon(std::string("viewshed ") + name + server() + kNorthWest + " -o " + out_.file("w.tif")).exit_code,
              0);
  const std::string m = daemon_->metrics();
  EXPECT_EQ(metric(m, "horizon_block_cache_budget_bytes"), 2 << 20);
  EXPECT_LE(metric(m, "horizon_block_cache_peak_resident_bytes"), 2 << 20);
  EXPECT_GT(metric(m, "horizon_block_cache_evictions_total"), 0);
}

TEST_F(ServerTiles, AMissingTileFailsOnlyTheRequestsThatNeedIt) {
  const auto away = horizon("viewshed holey" + server() + kNorthWest + " --max-distance 2000 -o " + out_.file("a.tif"));
  EXPECT_EQ(away.exit_code, 0) << away.output;
  const auto over =
      horizon("viewshed holey" + server() + kOnTheCorner + " --max-distance 2000 -o " + out_.file("b.tif"));
  EXPECT_EQ(over.exit_code, 1);
  EXPECT_NE(over.output.find("NOT_FOUND"), std::string::npos) << over.output;
  EXPECT_NE(over.output.find("no file covers cols 155.."), std::string::npos) << over.output;
  // Named relative to the daemon's data_root: clients learn the dataset's file, not the server's paths.
  EXPECT_NE(over.output.find("dem 'holey'"), std::string::npos) << over.output;
  EXPECT_EQ(over.output.find(data_->path().string()), std::string::npos) << over.output;
  EXPECT_FALSE(fs::exists(out_.file("b.tif")));
  // The daemon is unharmed.
  EXPECT_EQ(
      horizon("viewshed zion" + server() + kOnTheCorner + " --max-distance 2000 -o " + out_.file("c.tif")).exit_code,
      0);
}

}  // namespace
}  // namespace horizon::testing
