// Plans and runs: a planned query on a window of the source answers as the
// same query on the whole raster, a mosaic answers as the raster it was cut
// from (observers on tile borders and corners), the plan names its cost
// before any pixel is read, and bad queries are refused at planning.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "horizon/terrain/dem_reader.hpp"
#include "horizon/terrain/geotiff_writer.hpp"
#include "horizon/visibility/plan.hpp"
#include "test_support.hpp"

namespace horizon::visibility {
namespace {

using testing::TempDir;

bool same_grid(const terrain::Grid<float>& a, const terrain::Grid<float>& b) {
  if (a.width() != b.width() || a.height() != b.height()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const float x = a.values()[i], y = b.values()[i];
    if (!(x == y || (std::isnan(x) && std::isnan(y)))) return false;
  }
  return true;
}

std::shared_ptr<const terrain::ElevationSource> open(const std::string& path) {
  auto s = terrain::ElevationSource::open(path);
  EXPECT_TRUE(s.ok()) << (s.ok() ? "" : s.error().message);
  return s.ok() ? *s : nullptr;
}

// A point at grid position (col, row) of a raster, in its CRS.
geodesy::PointSpec at_cell(const terrain::DemHeader& h, double col, double row, double height = 10.0) {
  geodesy::PointSpec p;
  p.x = h.georef.transform.x_at(col);
  p.y = h.georef.transform.y_at(row);
  p.height = height;
  return p;
}

ViewshedQuery query(const geodesy::PointSpec& observer, Algorithm algorithm, double max_distance) {
  ViewshedQuery q;
  q.observer = observer;
  q.options.algorithm = algorithm;
  q.options.max_distance = max_distance;
  q.options.threads = 2;
  return q;
}

terrain::BlockCache::Options cache_of(std::uint64_t budget) {
  terrain::BlockCache::Options o;
  o.budget_bytes = budget;
  o.io_threads = 2;
  return o;
}

constexpr Algorithm kAlgorithms[] = {Algorithm::kRadial, Algorithm::kConservative, Algorithm::kExact};

TEST(Plan, ARunOnTheReadWindowEqualsTheViewshedOfTheWholeRaster) {
  const std::string path = testing::bundled_dem("zion_canyon_srtm3_465x457.tif");
  auto source = open(path);
  ASSERT_TRUE(source);
  auto dem = terrain::read_dem(path);
  ASSERT_TRUE(dem.ok());
  const terrain::DemHeader& h = source->header();
  terrain::BlockCache cache(cache_of(16 << 20));
  for (Algorithm algorithm : kAlgorithms)
    for (double max_distance : {2500.0, 6000.0, std::numeric_limits<double>::infinity()}) {
      const ViewshedQuery q = query(at_cell(h, 201.3, 170.6), algorithm, max_distance);
      auto plan = plan_viewshed(*source, q);
      ASSERT_TRUE(plan.ok()) << plan.error().message;
      auto run = run_viewshed(*plan, *source, &cache);
      ASSERT_TRUE(run.ok()) << run.error().message;
      auto observer = geodesy::resolve_point(*dem, q.observer, "observer");
      ASSERT_TRUE(observer.ok());
      auto whole = compute_viewshed(*dem, *observer, q.options);
      ASSERT_TRUE(whole.ok());
      EXPECT_EQ(run->window, whole->frame.window);
      EXPECT_TRUE(same_grid(run->result.ohf, whole->ohf)) << algorithm_name(algorithm) << " " << max_distance;
      EXPECT_EQ(run->observer_in_source().col, observer->col);
      EXPECT_EQ(run->observer.elevation, observer->elevation);
      EXPECT_EQ(run->result.stats.dem_cells, 465u * 457u);
      // The plan knew the window before reading: the run's lies inside what it read.
      EXPECT_GE(plan->cost.cells, run->window.cell_count());
      EXPECT_LE(run->window.col0 - plan->read.read.col0, 3);
    }
}

TEST(Plan, FillingVoidsInTheRunsOwnCellsEqualsFillingACopy) {
  const std::string path = testing::bundled_dem("everest_summit_voids_srtm3_300x300.tif");
  auto source = open(path);
  ASSERT_TRUE(source);
  auto dem = terrain::read_dem(path);
  ASSERT_TRUE(dem.ok());
  ViewshedQuery q = query(at_cell(source->header(), 209, 12, 2.0), Algorithm::kRadial, 8000.0);
  q.options.nodata = NodataPolicy::kFill;
  q.options.nodata_fill_height = 5000.0;
  auto plan = plan_viewshed(*source, q);
  ASSERT_TRUE(plan.ok());
  auto run = run_viewshed(*plan, *source, nullptr);
  ASSERT_TRUE(run.ok()) << run.error().message;
  auto observer = geodesy::resolve_point(*dem, q.observer, "observer");
  ASSERT_TRUE(observer.ok());
  auto whole = compute_viewshed(*dem, *observer, q.options);
  ASSERT_TRUE(whole.ok());
  EXPECT_TRUE(same_grid(run->result.ohf, whole->ohf));
  EXPECT_TRUE(same_grid(run->result.terrain, whole->terrain));
}

// Cuts the bundled Zion DEM into n x n tiles: the mosaic must answer every
// query as the file does, for observers inside tiles, on their borders and corners.
class TiledEqualsUntiled : public ::testing::TestWithParam<int> {};

TEST_P(TiledEqualsUntiled, ViewshedsCullingAndLinesOfSight) {
  const int n = GetParam();
  const std::string path = testing::bundled_dem("zion_canyon_srtm3_465x457.tif");
  auto dem = terrain::read_dem(path);
  ASSERT_TRUE(dem.ok());
  TempDir dir;
  ASSERT_EQ(testing::write_tiles(*dem, n, n, dir.path().string()).size(), static_cast<std::size_t>(n * n));
  auto merged = open(path);
  auto tiled = open(dir.path().string());
  ASSERT_TRUE(merged && tiled);
  const terrain::DemHeader& h = merged->header();
  terrain::BlockCache cache(cache_of(8 << 20));
  const int tw = 465 / n, th = 457 / n;
  // Inside a tile, on a vertical border, between two cells across it, on a corner.
  const std::vector<std::pair<double, double>> cells{
      {tw * 0.5, th * 0.4}, {tw, th * 0.5}, {tw - 0.5, th + 0.25}, {tw, th}};
  for (const auto& [col, row] : cells) {
    const geodesy::PointSpec eye = at_cell(h, col, row);
    for (Algorithm algorithm : kAlgorithms)
      for (double reach : {3000.0, std::numeric_limits<double>::infinity()}) {
        const ViewshedQuery q = query(eye, algorithm, reach);
        auto pa = plan_viewshed(*merged, q);
        auto pb = plan_viewshed(*tiled, q);
        ASSERT_TRUE(pa.ok() && pb.ok());
        EXPECT_EQ(pa->read.read, pb->read.read);
        auto a = run_viewshed(*pa, *merged, nullptr);
        auto b = run_viewshed(*pb, *tiled, &cache);
        ASSERT_TRUE(a.ok() && b.ok()) << (a.ok() ? b.error().message : a.error().message);
        EXPECT_EQ(a->window, b->window);
        EXPECT_TRUE(same_grid(a->result.ohf, b->result.ohf))
            << n << "x" << n << " " << algorithm_name(algorithm) << " at " << col << "," << row;
      }
    // Culling: boxes all around, some across tile borders.
    CullQuery cq;
    cq.observer = eye;
    cq.options.viewshed.threads = 2;
    cq.options.conservative = true;
    for (int i = 0; i < 40; ++i) {
      const double bc = 20 + (i * 37) % 420, br = 15 + (i * 53) % 425;
      visibility::BoxSpec b;
      b.x_min = h.georef.transform.x_at(bc);
      b.x_max = h.georef.transform.x_at(bc + 3);
      b.y_max = h.georef.transform.y_at(br);
      b.y_min = h.georef.transform.y_at(br + 2);
      b.z_min = 1000;
      b.z_max = 1200 + 400 * i;  // low ones hide in canyons, high ones clear every wall
      cq.boxes.push_back(b);
    }
    auto ca = plan_cull_boxes(*merged, cq);
    auto cb = plan_cull_boxes(*tiled, cq);
    ASSERT_TRUE(ca.ok() && cb.ok());
    auto ra = run_cull_boxes(*ca, *merged, nullptr);
    auto rb = run_cull_boxes(*cb, *tiled, &cache);
    ASSERT_TRUE(ra.ok() && rb.ok()) << (ra.ok() ? rb.error().message : ra.error().message);
    EXPECT_EQ(ra->result.window, rb->result.window);
    // Some boxes seen, some hidden: the comparison below means something.
    EXPECT_GT(ra->result.visible_count, 0u);
    EXPECT_LT(ra->result.visible_count, cq.boxes.size());
    ASSERT_EQ(ra->result.boxes.size(), rb->result.boxes.size());
    for (std::size_t i = 0; i < ra->result.boxes.size(); ++i) {
      EXPECT_EQ(ra->result.boxes[i].state, rb->result.boxes[i].state) << i;
      EXPECT_EQ(ra->result.boxes[i].ohf_min, rb->result.boxes[i].ohf_min) << i;
    }
    // Lines of sight from the eye to far cells.
    for (const auto& [tc, tr] : std::vector<std::pair<double, double>>{{460, 450}, {3, 440}, {tw + 1.0, 2}}) {
      LineQuery lq;
      lq.from = eye;
      lq.to = at_cell(h, tc, tr, 1.0);
      auto la = plan_line(*merged, lq);
      auto lb = plan_line(*tiled, lq);
      ASSERT_TRUE(la.ok() && lb.ok());
      auto xa = run_line(*la, *merged, nullptr);
      auto xb = run_line(*lb, *tiled, &cache);
      ASSERT_TRUE(xa.ok() && xb.ok());
      EXPECT_EQ(xa->result.visible, xb->result.visible);
      EXPECT_EQ(xa->result.distance, xb->result.distance);
      EXPECT_EQ(xa->result.clearance, xb->result.clearance);
      EXPECT_EQ(xa->result.profile.size(), xb->result.profile.size());
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Cuts, TiledEqualsUntiled, ::testing::Values(2, 3, 4),
                         [](const ::testing::TestParamInfo<int>& cut) {
                           return std::to_string(cut.param) + "x" + std::to_string(cut.param) + "Tiles";
                         });

// The viewsheds of a mosaic and of a raster are equal bit for bit.
void expect_same_viewsheds(const terrain::ElevationSource& a, const terrain::ElevationSource& b,
                           const geodesy::PointSpec& eye, double reach) {
  for (Algorithm algorithm : kAlgorithms) {
    auto pa = plan_viewshed(a, query(eye, algorithm, reach));
    auto pb = plan_viewshed(b, query(eye, algorithm, reach));
    ASSERT_TRUE(pa.ok() && pb.ok());
    auto ra = run_viewshed(*pa, a, nullptr);
    auto rb = run_viewshed(*pb, b, nullptr);
    ASSERT_TRUE(ra.ok() && rb.ok()) << (ra.ok() ? rb.error().message : ra.error().message);
    EXPECT_EQ(ra->window, rb->window);
    EXPECT_EQ(ra->georef.transform, rb->georef.transform);
    EXPECT_TRUE(same_grid(ra->result.ohf, rb->result.ohf)) << algorithm_name(algorithm);
  }
}

TEST(Plan, TilesCutByGdalTranslateAnswerAsTheFile) {
  if (testing::run_command("command -v gdal_translate").exit_code != 0) GTEST_SKIP() << "gdal_translate not installed";
  const std::string path = testing::bundled_dem("zion_canyon_srtm3_465x457.tif");
  TempDir dir;
  for (const auto& [c0, r0, w, h] : std::vector<std::array<int, 4>>{
           {0, 0, 232, 228}, {232, 0, 233, 228}, {0, 228, 232, 229}, {232, 228, 233, 229}}) {
    const std::string out = dir.file("t_" + std::to_string(c0) + "_" + std::to_string(r0) + ".tif");
    const auto r = testing::run_command("gdal_translate -q -srcwin " + std::to_string(c0) + " " + std::to_string(r0) +
                                        " " + std::to_string(w) + " " + std::to_string(h) + " " + path + " " + out);
    ASSERT_EQ(r.exit_code, 0) << r.output;
  }
  auto merged = open(path);
  auto tiled = open(dir.path().string());
  ASSERT_TRUE(merged && tiled);
  EXPECT_EQ(tiled->header().georef.transform, merged->header().georef.transform);
  for (const auto& [col, row] : std::vector<std::pair<double, double>>{{232, 228}, {100.3, 300.6}})
    expect_same_viewsheds(*merged, *tiled, at_cell(merged->header(), col, row), 5000.0);
}

TEST(Plan, AFolderOfHgtTilesAnswersAsTheMergedRaster) {
  TempDir dir, merged_dir;
  for (int lat : {46, 47})
    for (int lon : {-122, -121}) testing::write_hgt(dir.path().string(), lat, lon, 1201);
  auto tiles = open(dir.path().string());
  ASSERT_TRUE(tiles);
  // The merged raster, as one GeoTIFF: the mosaic's cells with its georeference.
  auto all = tiles->read({0, 0, tiles->width(), tiles->height()}, nullptr);
  ASSERT_TRUE(all.ok());
  const std::string merged_path = merged_dir.file("merged.tif");
  ASSERT_TRUE(terrain::write_geotiff(merged_path, all->elevation, all->georef, all->nodata).ok());
  auto merged = open(merged_path);
  ASSERT_TRUE(merged);
  // On the corner the four tiles share, and inside one of them.
  for (const auto& [col, row] : std::vector<std::pair<double, double>>{{1200, 1200}, {600.4, 1800.7}})
    expect_same_viewsheds(*merged, *tiles, at_cell(merged->header(), col, row), 4000.0);
}

TEST(Plan, ALineOnAWindowEqualsTheLineOnTheWholeRaster) {
  const std::string path = testing::bundled_dem("rainier_summit_srtm3_400x400.tif");
  auto source = open(path);
  auto dem = terrain::read_dem(path);
  ASSERT_TRUE(source && dem.ok());
  const terrain::DemHeader& h = source->header();
  for (const auto& [c0, r0, c1, r1] :
       std::vector<std::array<double, 4>>{{199, 177, 20, 380}, {10.5, 10.5, 390.2, 33.7}, {250, 100, 251, 300}}) {
    LineQuery q;
    q.from = at_cell(h, c0, r0, 2.0);
    q.to = at_cell(h, c1, r1, 2.0);
    auto plan = plan_line(*source, q);
    ASSERT_TRUE(plan.ok());
    EXPECT_LT(plan->read.read.cell_count(), 400u * 400u + 1);
    auto run = run_line(*plan, *source, nullptr);
    ASSERT_TRUE(run.ok()) << run.error().message;
    auto from = geodesy::resolve_point(*dem, q.from, "from");
    auto to = geodesy::resolve_point(*dem, q.to, "to");
    auto whole = line_of_sight(*dem, *from, *to, q.options);
    ASSERT_TRUE(whole.ok());
    EXPECT_EQ(run->result.visible, whole->visible);
    EXPECT_DOUBLE_EQ(run->result.distance, whole->distance);
    EXPECT_NEAR(run->result.clearance, whole->clearance, 1e-9);
    ASSERT_EQ(run->result.profile.size(), whole->profile.size());
    for (std::size_t i = 0; i < whole->profile.size(); i += 17) {
      EXPECT_NEAR(run->result.profile[i].col, whole->profile[i].col, 1e-9);
      EXPECT_NEAR(run->result.profile[i].x, whole->profile[i].x, 1e-9);
      const double a = run->result.profile[i].terrain, b = whole->profile[i].terrain;
      if (std::isnan(b))
        EXPECT_TRUE(std::isnan(a)) << i;  // a void
      else
        EXPECT_NEAR(a, b, 1e-9) << i;
    }
  }
}

TEST(Plan, NamesItsBlocksAndCostBeforeReadingAPixel) {
  const std::string path = testing::bundled_dem("zion_canyon_srtm3_465x457.tif");
  auto dem = terrain::read_dem(path);
  ASSERT_TRUE(dem.ok());
  TempDir dir;
  const auto tiles = testing::write_tiles(*dem, 4, 4, dir.path().string());
  auto source = open(dir.path().string());
  ASSERT_TRUE(source);
  const ViewshedQuery q = query(at_cell(source->header(), 230, 228), Algorithm::kRadial, 2000.0);
  // Every file gone: planning still works, from the headers alone.
  for (const auto& t : tiles) std::filesystem::rename(t, t + ".away");
  auto plan = plan_viewshed(*source, q);
  ASSERT_TRUE(plan.ok()) << plan.error().message;
  EXPECT_EQ(plan->read.blocks, source->blocks_in(plan->read.read));
  EXPECT_EQ(plan->cost.blocks, plan->read.blocks.size());
  EXPECT_GT(plan->cost.blocks, 1u);
  EXPECT_LT(plan->cost.blocks, source->block_count());  // 2 km of a 465-cell-wide mosaic
  EXPECT_EQ(plan->cost.read_cells, plan->read.read.cell_count());
  EXPECT_GE(plan->cost.bytes, plan->cost.read_cells * 4 + plan->cost.cells * 8);
  EXPECT_GT(plan->cost.seconds, 0.0);
  for (const auto& t : tiles) std::filesystem::rename(t + ".away", t);
  // Cold: every named block is decoded; warm: every one is a hit.
  terrain::BlockCache cache(cache_of(8 << 20));
  auto cold = run_viewshed(*plan, *source, &cache);
  ASSERT_TRUE(cold.ok()) << cold.error().message;
  EXPECT_EQ(cold->read.cache.misses, plan->cost.blocks);
  EXPECT_EQ(cold->read.cache.bytes_decoded, plan->cost.block_bytes);
  auto warm = run_viewshed(*plan, *source, &cache);
  ASSERT_TRUE(warm.ok());
  EXPECT_EQ(warm->read.cache.hits, plan->cost.blocks);
  EXPECT_EQ(warm->read.cells_decoded, 0u);
  EXPECT_TRUE(same_grid(cold->result.ohf, warm->result.ohf));
}

TEST(Plan, AnEyeOnAVoidIsNamedAtItsCellOfTheSource) {
  auto source = open(testing::bundled_dem("everest_summit_voids_srtm3_300x300.tif"));
  ASSERT_TRUE(source);
  // The summit's cell (209, 14) is an SRTM void; a 1 km read window starts far from (0, 0).
  auto plan = plan_viewshed(*source, query(at_cell(source->header(), 209, 14, 2.0), Algorithm::kRadial, 1000.0));
  ASSERT_TRUE(plan.ok());
  ASSERT_GT(plan->read.read.col0, 100);
  auto run = run_viewshed(*plan, *source, nullptr);
  ASSERT_FALSE(run.ok());
  EXPECT_EQ(run.error().code, ErrorCode::kDataError);
  EXPECT_NE(run.error().message.find("(col 209.00, row 14.00)"), std::string::npos) << run.error().message;
}

TEST(Plan, AWorkspaceKeepsItsBufferAcrossRunsAndChangesNoAnswer) {
  auto source = open(testing::bundled_dem("zion_canyon_srtm3_465x457.tif"));
  ASSERT_TRUE(source);
  terrain::BlockCache cache(cache_of(8 << 20));
  Workspace workspace;
  const terrain::DemHeader& h = source->header();
  const float *buffer = nullptr, *ohf = nullptr, *terrain = nullptr;
  for (double reach : {6000.0, 3000.0, 6000.0}) {  // a smaller window fits the kept buffers
    auto plan = plan_viewshed(*source, query(at_cell(h, 201.3, 170.6), Algorithm::kRadial, reach));
    ASSERT_TRUE(plan.ok());
    auto with = run_viewshed(*plan, *source, &cache, nullptr, nullptr, nullptr, &workspace);
    auto without = run_viewshed(*plan, *source, &cache);
    ASSERT_TRUE(with.ok() && without.ok());
    EXPECT_TRUE(same_grid(with->result.ohf, without->result.ohf)) << reach;
    EXPECT_TRUE(same_grid(with->result.terrain, without->result.terrain)) << reach;
    ASSERT_GE(workspace.cells.capacity(), plan->read.read.cell_count());
    if (buffer) {
      EXPECT_EQ(workspace.cells.data(), buffer) << "the read buffer was reallocated";
      EXPECT_EQ(with->result.ohf.data(), ohf) << "the OHF was reallocated";
      EXPECT_EQ(with->result.terrain.data(), terrain) << "the terrain raster was reallocated";
    }
    buffer = workspace.cells.data();
    ohf = with->result.ohf.data();
    terrain = with->result.terrain.data();
    workspace.recycle(std::move(with->result));
    EXPECT_EQ(workspace.ohf.data(), ohf);
    EXPECT_EQ(workspace.terrain.data(), terrain);
  }
}

// A run over the whole DEM takes its read buffer over as its terrain; once
// recycled, the terrain buffer it displaced becomes the next read buffer,
// so two buffers alternate and no run maps a new one (a daemon's whole-DEM
// viewsheds: 48 MB populated per call otherwise).
TEST(Plan, WholeDemRunsAlternateTwoBuffers) {
  auto source = open(testing::bundled_dem("zion_canyon_srtm3_465x457.tif"));
  ASSERT_TRUE(source);
  terrain::BlockCache cache(cache_of(8 << 20));
  Workspace workspace;
  const terrain::DemHeader& h = source->header();
  auto plan = plan_viewshed(*source, query(at_cell(h, 201.3, 170.6), Algorithm::kRadial, 1.0e6));
  ASSERT_TRUE(plan.ok());
  ASSERT_EQ(plan->read.read.cell_count(), static_cast<std::uint64_t>(h.width) * h.height);
  std::vector<const float*> terrain;  // each run's terrain raster (its read buffer, taken over)
  for (int run = 0; run < 5; ++run) {
    auto with = run_viewshed(*plan, *source, &cache, nullptr, nullptr, nullptr, &workspace);
    ASSERT_TRUE(with.ok());
    EXPECT_TRUE(workspace.cells.empty()) << "the run took its read buffer over";
    terrain.push_back(with->result.terrain.data());
    workspace.recycle(std::move(with->result));
    EXPECT_EQ(workspace.terrain.data(), terrain.back());
    // From the second run on, the displaced terrain is the next read buffer.
    if (run > 0) {
      EXPECT_EQ(workspace.cells.data(), terrain[run - 1]) << "run " << run;
    }
    // What the workspace holds: the OHF, the terrain and the read buffer,
    // each 465 x 457 floats (no mask: an OHF run). The first run fills the
    // workspace's terrain raster with the sweep's east and west lines (its
    // own terrain is its read buffer), which then becomes the next read buffer.
    EXPECT_EQ(workspace.kept_bytes(), 3u * 465u * 457u * sizeof(float)) << "run " << run;
  }
  EXPECT_EQ(terrain[2], terrain[0]);
  EXPECT_EQ(terrain[3], terrain[1]);
  EXPECT_EQ(terrain[4], terrain[0]);
  EXPECT_NE(terrain[0], terrain[1]);
}

// A mask_only run (the daemon's visible rasters) fills the workspace's kept
// mask instead of allocating one, gives the mask of an ordinary run, and
// leaves the kept OHF where it was.
TEST(Plan, AWorkspaceKeepsTheMaskOfAMaskOnlyRun) {
  auto source = open(testing::bundled_dem("zion_canyon_srtm3_465x457.tif"));
  ASSERT_TRUE(source);
  terrain::BlockCache cache(cache_of(8 << 20));
  Workspace workspace;
  const terrain::DemHeader& h = source->header();
  const std::uint8_t* mask = nullptr;
  for (double reach : {6000.0, 3000.0, 6000.0}) {
    ViewshedQuery q = query(at_cell(h, 201.3, 170.6), Algorithm::kRadial, reach);
    auto ordinary = plan_viewshed(*source, q);
    q.options.mask_only = true;
    auto plan = plan_viewshed(*source, q);
    ASSERT_TRUE(plan.ok() && ordinary.ok());
    auto with = run_viewshed(*plan, *source, &cache, nullptr, nullptr, nullptr, &workspace);
    auto without = run_viewshed(*ordinary, *source, &cache);
    ASSERT_TRUE(with.ok() && without.ok());
    ASSERT_TRUE(with->result.mask.has_value());
    EXPECT_TRUE(with->result.ohf.empty());
    const auto want = visibility_mask(without->result, 0.0);
    ASSERT_EQ(with->result.mask->size(), want.size());
    EXPECT_TRUE(std::equal(want.values().begin(), want.values().end(), with->result.mask->values().begin())) << reach;
    EXPECT_TRUE(mask == nullptr || with->result.mask->data() == mask) << "the mask was reallocated";
    mask = with->result.mask->data();
    workspace.recycle(std::move(with->result));
    EXPECT_EQ(workspace.mask.data(), mask);
  }
}

TEST(Plan, ACullingRunHandsItsRastersBackToTheWorkspace) {
  auto source = open(testing::bundled_dem("zion_canyon_srtm3_465x457.tif"));
  ASSERT_TRUE(source);
  const terrain::DemHeader& h = source->header();
  CullQuery cq;
  cq.observer = at_cell(h, 201.3, 170.6);
  for (int i = 0; i < 12; ++i) {
    const double bc = 150 + (i * 37) % 120, br = 120 + (i * 53) % 110;
    visibility::BoxSpec b;
    b.x_min = h.georef.transform.x_at(bc);
    b.x_max = h.georef.transform.x_at(bc + 3);
    b.y_max = h.georef.transform.y_at(br);
    b.y_min = h.georef.transform.y_at(br + 2);
    b.z_min = 1000;
    b.z_max = 1300 + 150 * i;
    cq.boxes.push_back(b);
  }
  auto plan = plan_cull_boxes(*source, cq);
  ASSERT_TRUE(plan.ok());
  Workspace workspace;
  const float* ohf = nullptr;
  for (int pass = 0; pass < 2; ++pass) {
    auto with = run_cull_boxes(*plan, *source, nullptr, nullptr, nullptr, nullptr, &workspace);
    auto without = run_cull_boxes(*plan, *source, nullptr);
    ASSERT_TRUE(with.ok() && without.ok());
    ASSERT_EQ(with->result.boxes.size(), without->result.boxes.size());
    for (std::size_t i = 0; i < with->result.boxes.size(); ++i) {
      EXPECT_EQ(with->result.boxes[i].state, without->result.boxes[i].state) << i;
      EXPECT_EQ(with->result.boxes[i].ohf_min, without->result.boxes[i].ohf_min) << i;
    }
    // The OHF came back, the same storage on the second pass.
    EXPECT_EQ(workspace.ohf.size(), with->result.window.cell_count());
    if (ohf) {
      EXPECT_EQ(workspace.ohf.data(), ohf);
    }
    ohf = workspace.ohf.data();
  }
}

// The sweep's rays scale as 1 / ray_spacing: the plan counts them before
// anything is allocated, and refuses a spacing no sweep could run.
TEST(Plan, TheSweepsRaysAreCostedFromRaySpacingAndBounded) {
  auto source = open(testing::bundled_dem("zion_canyon_srtm3_465x457.tif"));
  ASSERT_TRUE(source);
  const terrain::DemHeader& h = source->header();
  ViewshedQuery q = query(at_cell(h, 201.3, 170.6), Algorithm::kRadial, 6000.0);
  auto normal = plan_viewshed(*source, q);
  ASSERT_TRUE(normal.ok());
  const std::uint64_t reach = std::max(normal->output.width(), normal->output.height());
  EXPECT_EQ(normal->cost.sweep_rays, 4 * (2 * reach + 1));  // spacing 1: one ray a cell at the far line
  EXPECT_LT(normal->cost.sweep_bytes, normal->cost.bytes);
  q.options.radial.ray_spacing = 0.01;
  auto fine = plan_viewshed(*source, q);
  ASSERT_TRUE(fine.ok());
  EXPECT_EQ(fine->cost.sweep_rays, 4 * (2 * 100 * reach + 1));
  EXPECT_GT(fine->cost.sweep_bytes, 99 * normal->cost.sweep_bytes);
  EXPECT_EQ(fine->cost.bytes - fine->cost.sweep_bytes, normal->cost.bytes - normal->cost.sweep_bytes);
  EXPECT_GT(fine->cost.seconds, 50 * normal->cost.seconds);
  // In the documented range (0, 4], but 10^8 rays a sector: refused at planning, naming the field.
  q.options.radial.ray_spacing = 1e-6;
  auto tiny = plan_viewshed(*source, q);
  ASSERT_FALSE(tiny.ok());
  EXPECT_EQ(tiny.error().code, ErrorCode::kResourceExhausted);
  EXPECT_EQ(tiny.error().field, "ray_spacing");
  EXPECT_NE(tiny.error().message.find("rays a sector"), std::string::npos) << tiny.error().message;
  // Culling plans its OHF the same way.
  CullQuery cq;
  cq.observer = at_cell(h, 201.3, 170.6);
  visibility::BoxSpec b;
  b.x_min = h.georef.transform.x_at(400);
  b.x_max = h.georef.transform.x_at(402);
  b.y_max = h.georef.transform.y_at(400);
  b.y_min = h.georef.transform.y_at(402);
  b.z_max = 3000;
  cq.boxes.push_back(b);
  cq.options.viewshed.radial.ray_spacing = 1e-6;
  auto cull = plan_cull_boxes(*source, cq);
  ASSERT_FALSE(cull.ok());
  EXPECT_EQ(cull.error().field, "ray_spacing");
}

TEST(Plan, RejectsBadQueriesAtPlanningNamingTheField) {
  auto source = open(testing::bundled_dem("zion_canyon_srtm3_465x457.tif"));
  ASSERT_TRUE(source);
  const terrain::DemHeader& h = source->header();
  ViewshedQuery q = query(at_cell(h, 100, 100), Algorithm::kRadial, 1000.0);
  q.options.radial.ray_spacing = 0.0;
  auto bad = plan_viewshed(*source, q);
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().field, "ray_spacing");
  ViewshedQuery outside = query(at_cell(h, -40, 100), Algorithm::kRadial, 1000.0);
  auto off = plan_viewshed(*source, outside);
  ASSERT_FALSE(off.ok());
  EXPECT_EQ(off.error().code, ErrorCode::kOutOfRange);
  CullQuery none;
  none.observer = at_cell(h, 100, 100);
  auto empty = plan_cull_boxes(*source, none);
  ASSERT_FALSE(empty.ok());
  EXPECT_EQ(empty.error().field, "boxes");
}

}  // namespace
}  // namespace horizon::visibility
