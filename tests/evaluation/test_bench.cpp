// The runtime-against-error sweep (evaluation/bench.hpp): the knob table, the
// observer picks, the measured error of every setting and peer, the Pareto
// front, and the CSV / Markdown / PNG outputs.
#include <gtest/gtest.h>

#include <algorithm>

#include <OpenImageIO/imageio.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <tuple>
#include <string>

#include "horizon/evaluation/bench.hpp"
#include "horizon/evaluation/compare.hpp"
#include "horizon/evaluation/peers.hpp"
#include "horizon/geodesy/observer.hpp"
#include "horizon/terrain/dem_reader.hpp"
#include "horizon/visibility/viewshed.hpp"
#include "test_support.hpp"

namespace horizon::evaluation {
namespace {

const std::string kOlinda = "olinda_coast_utm25s_111x111.tif";  // small, projected, real

TEST(KnobTable, EachAlgorithmHasExactlyOneDefaultAndUniqueNames) {
  for (const std::string algorithm : {"fast", "exact", "conservative", "r3"}) {
    const std::vector<std::string> one = {algorithm};
    auto settings = settings_for(one);
    ASSERT_TRUE(settings.ok());
    int defaults = 0;
    std::set<std::string> names;
    for (const SweepSetting& k : *settings) {
      defaults += k.is_default;
      EXPECT_TRUE(names.insert(k.name).second) << algorithm << " " << k.name;
    }
    EXPECT_EQ(defaults, 1) << algorithm;
  }
}

TEST(KnobTable, FastSweepsSpacingAndBlendAndMarksTheEngineDefault) {
  const std::vector<std::string> fast = {"fast"};
  auto settings = settings_for(fast);
  ASSERT_TRUE(settings.ok());
  // ray spacing x blend {resample, linear, min}, thinning, plus the engine's
  // default when it is none of those; exactly one setting is the default.
  ASSERT_GE(settings->size(), 13u);
  std::set<std::tuple<double, int, int, int, int, bool>> seen;
  const visibility::RadialOptions engine_default;
  int defaults = 0;
  for (const SweepSetting& k : *settings) {
    visibility::ViewshedOptions o;
    if (k.apply) k.apply(o);
    EXPECT_TRUE(visibility::validate_options(o).ok()) << k.name;
    seen.insert({o.radial.ray_spacing, static_cast<int>(o.radial.blend), o.radial.thinning_levels,
                  static_cast<int>(o.backend), o.gpu ? static_cast<int>(o.gpu->method) : -1, o.gpu && o.gpu->log_step});
    // The GPU rows run the default knobs on the GL path: not the engine default.
    const bool is_engine_default = o.radial.ray_spacing == engine_default.ray_spacing &&
                                   o.radial.blend == engine_default.blend &&
                                   o.radial.thinning_levels == engine_default.thinning_levels &&
                                   o.backend != visibility::Backend::kGpu;
    EXPECT_EQ(k.is_default, is_engine_default) << k.name;
    defaults += k.is_default;
  }
  EXPECT_EQ(defaults, 1);
  EXPECT_EQ(seen.size(), settings->size());
}

TEST(KnobTable, RejectsUnknownAlgorithm) {
  const std::vector<std::string> names = {"fast", "fastest"};
  auto settings = settings_for(names);
  ASSERT_FALSE(settings.ok());
  EXPECT_EQ(settings.error().field, "algorithms");
  EXPECT_NE(settings.error().message.find("fastest"), std::string::npos);
}

TEST(PickObservers, DeterministicValidAndOfTheAskedCount) {
  auto dem = terrain::read_dem(testing::bundled_dem("everest_summit_voids_srtm3_300x300.tif"));
  ASSERT_TRUE(dem.ok());
  const auto a = pick_observers(*dem, 7), b = pick_observers(*dem, 7);
  ASSERT_EQ(a.size(), 7u);
  EXPECT_EQ(a[0].kind, "summit");
  EXPECT_EQ(a[3].kind, "edge");
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].col, b[i].col);
    EXPECT_EQ(a[i].row, b[i].row);
    EXPECT_FALSE(std::isnan(dem->elevation.at(a[i].col, a[i].row))) << a[i].kind;
  }
  // The summit is the highest valid cell.
  float top = -1e30f;
  for (float z : dem->elevation.values())
    if (!std::isnan(z)) top = std::max(top, z);
  EXPECT_EQ(dem->elevation.at(a[0].col, a[0].row), top);
}

TEST(CompareMask, CountsMissedAndExtraAgainstTheReference) {
  auto dem = terrain::read_dem(testing::bundled_dem(kOlinda));
  ASSERT_TRUE(dem.ok());
  geodesy::PointSpec spec;
  spec.x = dem->georef.transform.x_at(55);
  spec.y = dem->georef.transform.y_at(54);
  spec.height = 10;
  auto eye = geodesy::resolve_point(*dem, spec, "observer");
  visibility::ViewshedOptions o;
  o.algorithm = visibility::Algorithm::kR3;
  auto ref = visibility::compute_viewshed(*dem, *eye, o);
  ASSERT_TRUE(ref.ok());
  const auto m = visibility::visibility_mask(*ref, 0);
  terrain::Grid<float> mask(m.width(), m.height());
  for (std::size_t i = 0; i < m.size(); ++i)
    mask.data()[i] = m.data()[i] == visibility::kNoAnswer ? std::nanf("") : float(m.data()[i]);
  const visibility::Agreement same = compare_mask(mask, nullptr, *ref, 0);
  EXPECT_EQ(same.iou, 1.0);
  EXPECT_GT(same.reference_visible, 100u);
  EXPECT_TRUE(std::isnan(same.ohf_rmse));
  // Hide one visible cell far from the observer, show one hidden cell.
  int flipped_visible = 0, flipped_hidden = 0;
  for (int r = 0; r < mask.height() && (!flipped_visible || !flipped_hidden); ++r)
    for (int c = 0; c < 20; ++c) {
      if (mask.at(c, r) == 1.0f && !flipped_visible)
        mask.at(c, r) = 0.0f, flipped_visible = 1;
      else if (mask.at(c, r) == 0.0f && !flipped_hidden)
        mask.at(c, r) = 1.0f, flipped_hidden = 1;
    }
  ASSERT_TRUE(flipped_visible && flipped_hidden);
  const visibility::Agreement a = compare_mask(mask, nullptr, *ref, 0);
  EXPECT_EQ(a.missed_visible, 1u);
  EXPECT_EQ(a.extra_visible, 1u);
  EXPECT_EQ(a.cells_compared, same.cells_compared);
  // Heights equal to R3's minimum target height give zero OHF error.
  const auto mth = visibility::min_target_height(*ref);
  const visibility::Agreement h = compare_mask(mask, &mth, *ref, 0);
  EXPECT_NEAR(h.ohf_rmse, 0.0, 1e-3);
  EXPECT_NEAR(h.ohf_max_error, 0.0, 1e-3);
}

TEST(RunBench, MeasuresEverySettingAgainstR3) {
  BenchConfig c;
  c.dems = {testing::bundled_dem(kOlinda)};
  c.observers = 2;
  c.algorithms = {"fast", "r3"};
  c.repeats = 1;
  c.warmup = 0;
  c.peers = {};
  auto report = run_bench(c);
  ASSERT_TRUE(report.ok()) << report.error().message;
  const std::vector<std::string> algorithms = {"fast", "r3"};
  const auto all = settings_for(algorithms);
  ASSERT_TRUE(all.ok());
  const std::vector<SweepSetting>& listed = *all;
  std::size_t cpu_settings = 0;
  for (const SweepSetting& k : listed) cpu_settings += !k.name.starts_with("gpu");
  ASSERT_EQ(report->rows.size(), 2u * cpu_settings);  // 2 observers x settings; no EGL pool: no GPU rows
  EXPECT_NE(std::find_if(report->notes.begin(), report->notes.end(),
                         [](const std::string& n) { return n.starts_with("gpu rows skipped"); }),
            report->notes.end());
  for (const BenchRow& r : report->rows) {
    EXPECT_GT(r.seconds_median, 0.0);
    EXPECT_GT(r.error.cells_compared, 1000u);
    if (r.algorithm == "r3") {
      EXPECT_EQ(r.error.missed_visible + r.error.extra_visible, 0u);
      EXPECT_EQ(r.error.ohf_max_error, 0.0);
    }
    if (r.algorithm == "fast" && r.is_default) {
      EXPECT_GE(r.error.iou, 0.97) << r.observer;
    }
  }
  // Spacing 2 with the min blend errs towards visible: more extra than missed, pooled.
  std::uint64_t extra = 0, missed = 0;
  for (const BenchRow& r : report->rows)
    if (r.setting == "spacing 2, min") extra += r.error.extra_visible, missed += r.error.missed_visible;
  EXPECT_GT(extra, missed);
}

// One observer on the Olinda crop, one timed run per setting, no warm-up.
BenchConfig one_run_on_olinda(std::vector<std::string> algorithms, std::vector<Peer> peers) {
  BenchConfig c;
  c.dems = {testing::bundled_dem(kOlinda)};
  c.observers = 1;
  c.algorithms = std::move(algorithms);
  c.repeats = 1;
  c.warmup = 0;
  c.peers = std::move(peers);
  return c;
}

// With an EGL context the GPU rows run, and since they compute the default
// setting's rays, their error against R3 is the CPU default's, cell for cell.
TEST(RunBench, GpuRowsMatchTheCpuDefaultRow) {
  auto pool = gpu::ContextPool::create({.contexts = 1});
  ASSERT_TRUE(pool.ok()) << pool.error().message;
  BenchConfig c = one_run_on_olinda({"fast"}, {});
  c.gpu = pool->get();
  auto report = run_bench(c);
  ASSERT_TRUE(report.ok()) << report.error().message;
  const BenchRow* cpu = nullptr;
  std::vector<const BenchRow*> gpu_rows;
  for (const BenchRow& r : report->rows) {
    if (r.is_default) cpu = &r;
    if (r.setting.starts_with("gpu")) gpu_rows.push_back(&r);
  }
  ASSERT_NE(cpu, nullptr);
  ASSERT_EQ(gpu_rows.size(), 4u);
  for (const BenchRow* g : gpu_rows) {
    EXPECT_EQ(g->cells_evaluated, cpu->cells_evaluated) << g->setting;
    EXPECT_EQ(g->error.missed_visible, cpu->error.missed_visible) << g->setting;
    EXPECT_EQ(g->error.extra_visible, cpu->error.extra_visible) << g->setting;
  }
  for (const std::string& n : report->notes) EXPECT_EQ(n.find("ran on the CPU"), std::string::npos) << n;
}

TEST(RunBench, RejectsBadConfigByField) {
  BenchConfig c;
  c.peers = {};
  EXPECT_EQ(run_bench(c).error().field, "dems");
  c.dems = {testing::bundled_dem(kOlinda)};
  c.repeats = 0;
  EXPECT_EQ(run_bench(c).error().field, "repeats");
  c.repeats = 1;
  c.algorithms = {"r4"};
  EXPECT_EQ(run_bench(c).error().field, "algorithms");
}

TEST(RunBench, PeersAreMeasuredWhenInstalled) {
  if (!peer_installed("gdal")) GTEST_SKIP() << "gdal_viewshed not installed";
  testing::TempDir work;
  BenchConfig c = one_run_on_olinda({"r3"}, {Peer::kGdal});
  c.work_dir = work.path().string();
  auto report = run_bench(c);
  ASSERT_TRUE(report.ok()) << report.error().message;
  const BenchRow* gdal = nullptr;
  for (const BenchRow& r : report->rows)
    if (r.algorithm == "gdal") gdal = &r;
  ASSERT_NE(gdal, nullptr) << (report->notes.empty() ? "" : report->notes.front());
  EXPECT_TRUE(gdal->is_peer);
  // Aligned on the same window: most cells compared, a real but imperfect agreement.
  EXPECT_GT(gdal->error.cells_compared, 111u * 111u * 9 / 10);
  EXPECT_GT(gdal->error.iou, 0.3);
  EXPECT_LT(gdal->error.iou, 1.0);
  // Heights from -om GROUND (above ground): on a DEM of 88 m relief the OHF
  // error is metres, not the hundreds that another mode would give.
  EXPECT_TRUE(std::isfinite(gdal->error.ohf_rmse));
  EXPECT_LT(gdal->error.ohf_rmse, 30.0);
  EXPECT_GT(gdal->seconds_median, 0.0);
}

TEST(RunBench, MissingPeerIsANoteNotAnError) {
  // A PATH without the peers' programs.
  const char* old_path = std::getenv("PATH");
  const std::string saved = old_path ? old_path : "";
  ::setenv("PATH", "/nonexistent", 1);
  BenchConfig c;
  c.dems = {testing::bundled_dem(kOlinda)};
  c.observers = 1;
  c.algorithms = {"r3"};
  c.repeats = 1;
  c.warmup = 0;
  c.work_dir = "/tmp";
  auto report = run_bench(c);
  ::setenv("PATH", saved.c_str(), 1);
  ASSERT_TRUE(report.ok()) << report.error().message;
  ASSERT_EQ(report->notes.size(), 2u);
  EXPECT_NE(report->notes[0].find("gdal: not installed"), std::string::npos);
  EXPECT_NE(report->notes[1].find("grass: not installed"), std::string::npos);
}

BenchRow row(const std::string& dem, const std::string& observer, const std::string& setting, double seconds,
             std::uint64_t both, std::uint64_t missed, std::uint64_t extra) {
  BenchRow r;
  r.dem = dem;
  r.observer = observer;
  r.algorithm = "fast";
  r.setting = setting;
  r.seconds_median = seconds;
  r.error.cells_compared = 1000;
  r.error.reference_visible = both + missed;
  r.error.both_visible = both;
  r.error.missed_visible = missed;
  r.error.extra_visible = extra;
  return r;
}

TEST(Aggregate, PoolsObserversAndMarksTheParetoFront) {
  // Per observer: a fast-and-rough, a slow-and-exact, a dominated, a front middle.
  std::vector<BenchRow> rows;
  for (const char* obs : {"a", "b"}) {
    rows.push_back(row("d.tif", obs, "rough", 1.0, 90, 5, 5));    // 1 - IoU = 0.1
    rows.push_back(row("d.tif", obs, "exact", 10.0, 100, 0, 0));  // 0
    rows.push_back(row("d.tif", obs, "worse", 5.0, 80, 10, 10));  // 0.2, slower than rough
    rows.push_back(row("d.tif", obs, "middle", 3.0, 98, 1, 1));   // 0.02
  }
  const auto agg = aggregate(rows, false);
  ASSERT_EQ(agg.size(), 4u);
  for (const Aggregate& a : agg) {
    EXPECT_EQ(a.observers, 2);
    if (a.setting == "rough") {
      EXPECT_DOUBLE_EQ(a.seconds, 2.0);
      EXPECT_NEAR(a.iou, 0.9, 1e-12);
      EXPECT_EQ(a.missed, 10u);
    }
    EXPECT_EQ(a.on_front, a.setting != "worse") << a.setting;
  }
}

TEST(Aggregate, PoolsAcrossDemsOnlyCompleteSettings) {
  std::vector<BenchRow> rows = {row("x.tif", "a", "s1", 1, 10, 0, 0), row("y.tif", "a", "s1", 2, 10, 0, 0),
                                row("x.tif", "a", "s2", 1, 10, 0, 0)};  // s2 missing on y.tif
  const auto agg = aggregate(rows, true);
  int pooled = 0;
  for (const Aggregate& a : agg)
    if (a.dem.empty()) {
      ++pooled;
      EXPECT_EQ(a.setting, "s1");
      EXPECT_DOUBLE_EQ(a.seconds, 3.0);
    }
  EXPECT_EQ(pooled, 1);
}

TEST(BenchOutputs, CsvMarkdownAndChartAreWritten) {
  testing::TempDir dir;
  std::vector<BenchRow> rows = {row("d.tif", "a", "rough", 0.002, 90, 5, 5),
                                row("d.tif", "a", "exact", 0.5, 100, 0, 0)};
  rows[1].algorithm = "r3";
  rows[1].is_default = true;
  const std::string csv = dir.file("b.csv");
  ASSERT_TRUE(write_csv(csv, rows).ok());
  std::ifstream in(csv);
  std::string line;
  int lines = 0;
  while (std::getline(in, line)) ++lines;
  EXPECT_EQ(lines, 3);

  const auto agg = aggregate(rows, false);
  BenchReport report;
  report.rows = rows;
  report.notes = {"grass: not installed"};
  const std::string md = dir.file("b.md");
  ASSERT_TRUE(write_markdown(md, report, agg, "horizon bench d.tif").ok());
  std::ifstream mdin(md);
  const std::string text((std::istreambuf_iterator<char>(mdin)), {});
  EXPECT_NE(text.find("horizon bench d.tif"), std::string::npos);
  EXPECT_NE(text.find("| r3 | **exact** |"), std::string::npos) << text;
  EXPECT_NE(text.find("grass: not installed"), std::string::npos);

  const std::string png = dir.file("chart.png");
  ASSERT_TRUE(write_chart(png, agg, "test chart").ok());
  auto image = OIIO::ImageInput::open(png);
  ASSERT_TRUE(image);
  EXPECT_EQ(image->spec().width, 1000);
  EXPECT_EQ(image->spec().height, 640);
  // Not blank: the two points' colours are in it.
  std::vector<unsigned char> pixels(1000 * 640 * 3);
  ASSERT_TRUE(image->read_image(0, 0, 0, 3, OIIO::TypeDesc::UINT8, pixels.data()));
  std::size_t coloured = 0;
  for (std::size_t i = 0; i < pixels.size(); i += 3)
    coloured += pixels[i] != pixels[i + 1] || pixels[i + 1] != pixels[i + 2];
  EXPECT_GT(coloured, 100u);
  EXPECT_FALSE(write_chart(dir.file("empty.png"), {}, "nothing").ok());
}

}  // namespace
}  // namespace horizon::evaluation
