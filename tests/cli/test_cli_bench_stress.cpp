// `horizon bench` and `horizon stress` end to end: flags reach the sweep,
// outputs are written, usage mistakes are exit status 2, failing checks 1.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "test_support.hpp"

namespace horizon::testing {
namespace {

namespace fs = std::filesystem;

CommandResult horizon(const std::string& args) {
  return run_command(std::string(HORIZON_CLI_PATH) + " " + args);
}

TEST(CliBench, WritesCsvMarkdownAndChartsForEachDem) {
  TempDir dir;
  const std::string out = dir.file("bench");
  const std::string md = dir.file("table.md");
  auto r = horizon(
      "bench " + bundled_dem("olinda_coast_utm25s_111x111.tif") + " " + bundled_dem("zion_canyon_srtm3_465x457.tif") +
      " --observers 1 --algorithms fast,r3 --repeats 1 --warmup 0 --peers none -o " + out + " --markdown " + md);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(fs::exists(out + "/bench.csv"));
  EXPECT_TRUE(fs::exists(out + "/bench.md"));
  EXPECT_TRUE(fs::exists(md));
  EXPECT_TRUE(fs::exists(out + "/pareto_olinda_coast_utm25s_111x111.png"));
  EXPECT_TRUE(fs::exists(out + "/pareto_zion_canyon_srtm3_465x457.png"));
  EXPECT_TRUE(fs::exists(out + "/pareto_all.png"));
  EXPECT_FALSE(fs::exists(out + "/peer-work"));
  EXPECT_NE(r.output.find("r3           reference"), std::string::npos) << r.output;
  // One CSV line per DEM x observer x setting, plus the header.
  std::ifstream csv(out + "/bench.csv");
  int lines = 0;
  for (std::string line; std::getline(csv, line);) ++lines;
  EXPECT_GE(lines, 1 + 2 * 9);
}

TEST(CliBench, RejectsBadFlagsWithUsageStatus) {
  const std::string dem = bundled_dem("olinda_coast_utm25s_111x111.tif");
  auto a = horizon("bench " + dem + " --algorithms fast,quick --peers none");
  EXPECT_EQ(a.exit_code, 2);
  EXPECT_NE(a.output.find("--algorithms: 'quick'"), std::string::npos) << a.output;
  auto p = horizon("bench " + dem + " --peers arcgis");
  EXPECT_EQ(p.exit_code, 2);
  EXPECT_NE(p.output.find("--peers"), std::string::npos);
  auto o = horizon("bench " + dem + " --observers 2 --observer 1,2");
  EXPECT_EQ(o.exit_code, 2);
  auto none = horizon("bench --peers none");
  EXPECT_EQ(none.exit_code, 2);
}

TEST(CliBench, RegionSweepWritesItsTablesAndChartAndChecksEveryVerdict) {
  TempDir dir;
  const std::string out = dir.file("region");
  auto r = horizon("bench --region " + bundled_dem("ecuador_andes_utm17s_10m_383x415.tif") +
                   " --sizes 20,200 --face-resolutions 64,1024 --regions 1 --max-distance 600 --check 20 --repeats 1"
                   " --warmup 0 -o " +
                   out);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(fs::exists(out + "/bench_region.csv"));
  EXPECT_TRUE(fs::exists(out + "/bench_region.md"));
  EXPECT_TRUE(fs::exists(out + "/region_ecuador_andes_utm17s_10m_383x415.png"));
  EXPECT_NE(r.output.find("R3 check: 0 wrong verdicts"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("200 m region"), std::string::npos) << r.output;
  std::ifstream csv(out + "/bench_region.csv");
  int lines = 0;
  for (std::string line; std::getline(csv, line);) ++lines;
  EXPECT_EQ(lines, 1 + 2 * 2);
}

TEST(CliBench, RegionAndViewshedFlagsDoNotMix) {
  const std::string dem = bundled_dem("olinda_coast_utm25s_111x111.tif");
  auto a = horizon("bench " + dem + " --sizes 20 --peers none");
  EXPECT_EQ(a.exit_code, 2);
  EXPECT_NE(a.output.find("--sizes: a flag of the region sweep; add --region"), std::string::npos) << a.output;
  auto b = horizon("bench --region " + dem + " --algorithms fast");
  EXPECT_EQ(b.exit_code, 2);
  EXPECT_NE(b.output.find("--algorithms: not a flag of the region sweep"), std::string::npos) << b.output;
  auto c = horizon("bench --region " + dem + " --face-resolutions 64,5");
  EXPECT_EQ(c.exit_code, 2);
  EXPECT_NE(c.output.find("--face-resolutions: each must be a whole number in [8, 65536]"), std::string::npos)
      << c.output;
  auto d = horizon("bench --region " + dem + " --heights 30,2");
  EXPECT_EQ(d.exit_code, 2);
  EXPECT_NE(d.output.find("--heights"), std::string::npos) << d.output;
  auto e = horizon("bench --region " + dem + " --rows 0,1");
  EXPECT_EQ(e.exit_code, 2);
  EXPECT_NE(e.output.find("--rows: 0 (the continuous cover) or at least 2 rows, got 1"), std::string::npos) << e.output;
  auto f = horizon("bench --region " + dem + " --seed-rows 5");
  EXPECT_EQ(f.exit_code, 2);
  EXPECT_NE(f.output.find("--seed-rows: must be a whole number in [8, 4096]"), std::string::npos) << f.output;
  auto g = horizon("bench " + dem + " --seed-rows 64 --peers none");
  EXPECT_EQ(g.exit_code, 2);
  EXPECT_NE(g.output.find("--seed-rows: a flag of the region sweep; add --region"), std::string::npos) << g.output;
}

TEST(CliStress, PrintsAReportAndExitsZeroWhenChecksPass) {
  TempDir dir;
  auto r = horizon("stress --algorithms r3 --checks flat_all_visible,wall_1000m --markdown " + dir.file("s.md"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("flat_all_visible      r3"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("all pass"), std::string::npos);
  std::ifstream md(dir.file("s.md"));
  const std::string text((std::istreambuf_iterator<char>(md)), {});
  EXPECT_NE(text.find("| wall_1000m | r3 |"), std::string::npos) << text;
}

TEST(CliStress, RejectsUnknownCheck) {
  auto r = horizon("stress --checks no_such_check");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("'no_such_check'"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace horizon::testing
