// The from-region sweep (evaluation/region_bench.hpp): one row per region x
// size x resolution x split, each the classification region::classify_cells
// gives for that square, a finer fuzzy array deciding at least as many
// cells hidden, no verdict contradicting R3, and the outputs written.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>

#include "horizon/evaluation/region_bench.hpp"
#include "horizon/region/region.hpp"
#include "horizon/terrain/dem_reader.hpp"
#include "test_support.hpp"

namespace horizon::evaluation {
namespace {

RegionBenchConfig small_sweep() {
  RegionBenchConfig c;
  c.dems = {testing::bundled_dem("ecuador_andes_utm17s_10m_383x415.tif")};
  c.regions = 2;
  c.sizes = {20, 200};
  c.face_resolutions = {64, 256, 1024};
  c.footprint_splits = {1, 2};
  c.max_distance = 800;
  c.repeats = 1;
  c.warmup = 0;
  c.check_points = 40;
  c.check_cells = 600;
  c.threads = 2;
  return c;
}

TEST(RegionBench, EveryRowIsTheClassificationOfItsSquareAndNoneIsWrong) {
  const RegionBenchConfig c = small_sweep();
  auto report = run_region_bench(c);
  ASSERT_TRUE(report.ok()) << report.error().message;
  ASSERT_EQ(report->rows.size(), 2u * 2 * 3 * 2) << (report->notes.empty() ? "" : report->notes.front());
  auto dem = terrain::read_dem(c.dems[0]);
  ASSERT_TRUE(dem.ok());

  // Per (region, size, splits), the hidden count against the resolution.
  std::map<std::tuple<std::string, double, int>, std::uint64_t> hidden_before;
  for (const RegionBenchRow& r : report->rows) {
    SCOPED_TRACE(r.region + " " + std::to_string(r.size_m) + " m, face " + std::to_string(r.face_resolution) +
                 ", splits " + std::to_string(r.footprint_splits));
    EXPECT_EQ(r.always_hidden + r.always_visible + r.undetermined, r.cells);
    EXPECT_GT(r.cells, 0u);
    EXPECT_GT(r.checked_cells, 0u);
    EXPECT_GT(r.viewpoints, 40u);  // the corners, edges and faces too
    EXPECT_EQ(r.wrong, 0u);
    EXPECT_LE(r.hidden_checked, r.sampled_hidden);  // sound: decided hidden is hidden from every sample

    // The same square (UTM: CRS units are metres), classified here: the same verdicts.
    region::RegionSpec spec;
    spec.x_min = r.x_min;
    spec.x_max = r.x_max;
    spec.y_min = r.y_min;
    spec.y_max = r.y_max;
    EXPECT_NEAR(r.x_max - r.x_min, r.size_m, 0.01 * r.size_m);
    spec.z_min = c.z_min;
    spec.z_max = c.z_max;
    region::RegionOptions o;
    o.face_resolution = r.face_resolution;
    o.footprint_splits = r.footprint_splits;
    o.max_distance = c.max_distance;
    o.target_height = c.target_height;
    o.threads = 1;
    auto want = region::classify_cells(*dem, spec, o);
    ASSERT_TRUE(want.ok()) << want.error().message;
    EXPECT_EQ(r.cells, want->stats.items);
    EXPECT_EQ(r.always_hidden, want->stats.always_hidden);
    EXPECT_EQ(r.always_visible, want->stats.always_visible);

    // A finer fuzzy array (columns split in four) hides at least as much.
    auto& before = hidden_before[{r.region, r.size_m, r.footprint_splits}];
    EXPECT_GE(r.always_hidden, before);
    before = r.always_hidden;
  }

  // A larger region decides less, pooled over the regions at the default resolution.
  const auto pooled = aggregate_regions(report->rows);
  double small = -1, large = -1;
  for (const Aggregate& a : pooled)
    if (a.setting == "1024") (a.algorithm == "20 m region" ? small : large) = a.iou;
  EXPECT_GT(small, large);
  EXPECT_GT(large, 0.0);
}

TEST(RegionBench, WritesCsvAndMarkdownWithEveryRow) {
  RegionBenchConfig c = small_sweep();
  c.regions = 1;
  c.sizes = {40};
  c.footprint_splits = {2};
  c.fuzzy_rows = {0, 64};  // the continuous cover, and the seed's array of 64 slope rows
  c.check_points = 0;
  auto report = run_region_bench(c);
  ASSERT_TRUE(report.ok()) << report.error().message;
  ASSERT_EQ(report->rows.size(), 3u * 2);
  for (std::size_t i = 0; i < report->rows.size(); i += 2) {
    const RegionBenchRow &continuous = report->rows[i], &rows = report->rows[i + 1];
    ASSERT_EQ(continuous.fuzzy_rows, 0);
    ASSERT_EQ(rows.fuzzy_rows, 64);
    EXPECT_LE(rows.always_hidden, continuous.always_hidden) << "the rows only ever lose verdicts";
    EXPECT_EQ(rows.always_visible, continuous.always_visible);
  }
  testing::TempDir dir;
  const std::string csv = dir.file("r.csv"), md = dir.file("r.md");
  ASSERT_TRUE(write_region_csv(csv, report->rows).ok());
  ASSERT_TRUE(write_region_markdown(md, *report, "horizon bench --region x").ok());
  std::ifstream f(csv);
  int lines = 0;
  for (std::string line; std::getline(f, line);) ++lines;
  EXPECT_EQ(lines, 1 + 6);
  std::ifstream m(md);
  const std::string text((std::istreambuf_iterator<char>(m)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("| 40 m | walls | 256 | 2 | continuous | 1 |"), std::string::npos) << text;
  EXPECT_NE(text.find("| 40 m | walls | 256 | 2 | 64 | 1 |"), std::string::npos) << text;
  EXPECT_NE(text.find("<!-- horizon bench --region x -->"), std::string::npos);
  const auto pooled = aggregate_regions(report->rows);
  ASSERT_EQ(pooled.size(), 6u);
  EXPECT_EQ(pooled[1].setting, "64, 64 rows");
  const std::string png = dir.file("r.png");
  ASSERT_TRUE(write_chart(png, pooled, "t", region_chart_text()).ok());
  EXPECT_GT(std::filesystem::file_size(png), 1000u);
}

// The seed's own construction beside the walls, one piece: a row for each
// region, size and resolution, on the walls' cells, checked with R3.
TEST(RegionBench, TheSeedsConstructionRunsBesideTheWallsOnTheSameCells) {
  RegionBenchConfig c = small_sweep();
  c.sizes = {20};
  c.face_resolutions = {256};
  c.footprint_splits = {1};
  c.seed_rows = 256;
  auto report = run_region_bench(c);
  ASSERT_TRUE(report.ok()) << report.error().message;
  ASSERT_EQ(report->rows.size(), 2u * 2);
  for (std::size_t i = 0; i < report->rows.size(); i += 2) {
    const RegionBenchRow &walls = report->rows[i], &seed = report->rows[i + 1];
    EXPECT_EQ(walls.construction, "walls");
    ASSERT_EQ(seed.construction, "seed");
    EXPECT_EQ(seed.cells, walls.cells);
    EXPECT_EQ(seed.always_visible, 0u);
    EXPECT_EQ(seed.always_hidden + seed.undetermined, seed.cells);
    EXPECT_GT(seed.patches, 0u);
    EXPECT_GT(seed.checked_cells, 0u);
    EXPECT_EQ(seed.wrong, 0u);
  }
  const auto pooled = aggregate_regions(report->rows);
  ASSERT_EQ(pooled.size(), 2u);
  EXPECT_EQ(pooled[1].setting, "seed 256x256");
}

TEST(RegionBench, AWrongConfigNamesItsField) {
  const auto field_of = [](const RegionBenchConfig& c) {
    auto r = run_region_bench(c);
    EXPECT_FALSE(r.ok());
    return r.ok() ? std::string() : r.error().field;
  };
  RegionBenchConfig c = small_sweep();
  c.sizes = {20, -5};
  EXPECT_EQ(field_of(c), "sizes");
  c = small_sweep();
  c.face_resolutions = {4};
  EXPECT_EQ(field_of(c), "face_resolutions");
  c = small_sweep();
  c.footprint_splits = {17};
  EXPECT_EQ(field_of(c), "footprint_splits");
  c = small_sweep();
  c.fuzzy_rows = {0, 1};
  EXPECT_EQ(field_of(c), "fuzzy_rows");
  c = small_sweep();
  c.seed_rows = 5;
  EXPECT_EQ(field_of(c), "seed_rows");
  c = small_sweep();
  c.seed_rows = 64;
  c.footprint_splits = {2};
  EXPECT_EQ(field_of(c), "footprint_splits");
  c = small_sweep();
  c.z_min = 30;  // above z_max
  EXPECT_EQ(field_of(c), "heights");
  c = small_sweep();
  c.max_distance = 0;
  EXPECT_EQ(field_of(c), "max_distance");
  c = small_sweep();
  c.dems = {};
  EXPECT_EQ(field_of(c), "dems");
}

}  // namespace
}  // namespace horizon::evaluation
