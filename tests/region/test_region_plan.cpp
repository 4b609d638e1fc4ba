// From-region visibility over a terrain source (region_plan.hpp): the
// window read is the rectangle bounding the region and its items, its cost
// known from the header, and the verdicts on it are those the whole DEM
// gives.
#include <gtest/gtest.h>

#include <random>

#include "horizon/region/region_plan.hpp"
#include "horizon/terrain/dem_reader.hpp"
#include "test_support.hpp"

namespace horizon {
namespace {

using region::Verdict;

constexpr const char* kEcuador = "ecuador_andes_utm17s_10m_383x415.tif";

struct Fixture {
  std::shared_ptr<const terrain::ElevationSource> source;
  terrain::Dem dem;
};

Fixture open_ecuador() {
  Fixture f;
  auto source = terrain::ElevationSource::open(testing::bundled_dem(kEcuador));
  EXPECT_TRUE(source.ok()) << source.error().message;
  f.source = *source;
  auto dem = terrain::read_dem(testing::bundled_dem(kEcuador));
  EXPECT_TRUE(dem.ok()) << dem.error().message;
  f.dem = std::move(*dem);
  return f;
}

// A 60 m square 2..20 m above the ground around grid cell (col, row).
region::RegionSpec region_at(const terrain::Dem& dem, double col, double row) {
  const auto& t = dem.georef.transform;
  region::RegionSpec r;
  r.x_min = t.x_at(col) - 30;
  r.x_max = t.x_at(col) + 30;
  r.y_min = t.y_at(row) - 30;
  r.y_max = t.y_at(row) + 30;
  r.z_min = 2;
  r.z_max = 20;
  return r;
}

// Boxes standing on the ground in grid columns [c0, c1) x rows [r0, r1).
std::vector<visibility::BoxSpec> boxes_in(const terrain::Dem& dem, int count, double c0, double c1, double r0,
                                          double r1, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  const auto& t = dem.georef.transform;
  std::vector<visibility::BoxSpec> out;
  for (int i = 0; i < count; ++i) {
    const double col = c0 + u(rng) * (c1 - c0), row = r0 + u(rng) * (r1 - r0);
    const double ground = dem.elevation.at(static_cast<int>(col), static_cast<int>(row));
    visibility::BoxSpec b;
    b.x_min = t.x_at(col);
    b.x_max = b.x_min + 15;
    b.y_max = t.y_at(row);
    b.y_min = b.y_max - 15;
    b.z_min = ground;
    b.z_max = ground + 3 + 20 * u(rng);
    out.push_back(b);
  }
  return out;
}

TEST(RegionPlan, TheWindowBoundsTheRegionAndItsBoxesAndTheVerdictsAreTheWholeDems) {
  Fixture f = open_ecuador();
  ASSERT_TRUE(f.source);
  region::RegionQuery q;
  q.region = region_at(f.dem, 150, 200);
  q.boxes = boxes_in(f.dem, 120, 120, 260, 140, 300, 3);  // 1.5 cells wide: columns 120..262, rows 138..300
  q.options.threads = 1;
  auto plan = region::plan_region(*f.source, q);
  ASSERT_TRUE(plan.ok()) << plan.error().message;
  // Not the whole 383 x 415 raster: the boxes' and region's columns and rows, a cell more each way.
  EXPECT_GE(plan->window.col0, 115);
  EXPECT_LE(plan->window.col0, 121);
  EXPECT_GE(plan->window.col1, 260);
  EXPECT_LE(plan->window.col1, 265);
  EXPECT_GE(plan->window.row0, 134);
  EXPECT_LE(plan->window.row1, 306);
  EXPECT_EQ(plan->cells, plan->window.cell_count());
  EXPECT_GE(plan->bytes, plan->cells * 5);  // elevations and more

  terrain::BlockCache cache({.budget_bytes = 64ull << 20, .io_threads = 1});
  auto run = region::run_region(*plan, *f.source, &cache);
  ASSERT_TRUE(run.ok()) << run.error().message;
  EXPECT_EQ(run->window, plan->window);
  EXPECT_EQ(run->read.window, plan->window);

  auto whole = region::classify_boxes(f.dem, q.region, q.boxes, q.options);
  ASSERT_TRUE(whole.ok()) << whole.error().message;
  ASSERT_EQ(run->verdicts.size(), q.boxes.size());
  int decided = 0;
  for (std::size_t i = 0; i < q.boxes.size(); ++i) {
    EXPECT_EQ(run->verdicts[i], whole->verdicts[i]) << "box " << i;
    decided += run->verdicts[i] != Verdict::kUndetermined;
  }
  EXPECT_GT(decided, 30);  // the comparison means something
  EXPECT_EQ(run->stats.items, q.boxes.size());
}

TEST(RegionPlan, CellsWithinReachAreTheWholeDemsCodes) {
  Fixture f = open_ecuador();
  ASSERT_TRUE(f.source);
  region::RegionQuery q;
  q.region = region_at(f.dem, 190, 210);
  q.cells = true;
  q.options.max_distance = 800;  // 80 cells of 10 m
  q.options.target_height = 2;
  q.options.threads = 1;
  auto plan = region::plan_region(*f.source, q);
  ASSERT_TRUE(plan.ok()) << plan.error().message;
  // The footprint (60 m: 6 cells and those bracketing it) grown by 81 cells
  // and one more each way.
  EXPECT_LE(plan->window.width(), 9 + 2 * 82);
  EXPECT_GE(plan->window.width(), 2 * 81);
  auto run = region::run_region(*plan, *f.source, nullptr);
  ASSERT_TRUE(run.ok()) << run.error().message;

  auto whole = region::classify_cells(f.dem, q.region, q.options);
  ASSERT_TRUE(whole.ok()) << whole.error().message;
  const terrain::Window& w = run->window;
  int answered = 0;
  for (int r = 0; r < f.dem.height(); ++r)
    for (int c = 0; c < f.dem.width(); ++c) {
      const bool in_whole =
          c >= whole->window.col0 && c < whole->window.col1 && r >= whole->window.row0 && r < whole->window.row1;
      const bool in_run = c >= w.col0 && c < w.col1 && r >= w.row0 && r < w.row1;
      const std::uint8_t want =
          in_whole ? whole->codes.at(c - whole->window.col0, r - whole->window.row0) : region::kNoAnswer;
      if (want != region::kNoAnswer) {
        ASSERT_TRUE(in_run) << "cell " << c << "," << r << " has an answer outside the window read";
        ++answered;
      }
      if (in_run) {
        ASSERT_EQ(run->codes.at(c - w.col0, r - w.row0), want) << "cell " << c << "," << r;
      }
    }
  EXPECT_GT(answered, 15000);  // about pi 80^2 cells
}

TEST(RegionPlan, ErrorsNameTheRegionTheBoxesAndTheOption) {
  Fixture f = open_ecuador();
  ASSERT_TRUE(f.source);
  region::RegionQuery q;
  q.region = region_at(f.dem, 150, 200);
  auto empty = region::plan_region(*f.source, q);  // no boxes, no cells
  ASSERT_FALSE(empty.ok());
  EXPECT_EQ(empty.error().code, ErrorCode::kInvalidArgument);
  EXPECT_EQ(empty.error().field, "boxes");

  q.boxes = boxes_in(f.dem, 3, 100, 120, 100, 120, 1);
  q.boxes[2].x_min += 1e6;
  q.boxes[2].x_max += 1e6;
  auto off = region::plan_region(*f.source, q);
  ASSERT_FALSE(off.ok());
  EXPECT_EQ(off.error().code, ErrorCode::kOutOfRange);
  EXPECT_EQ(off.error().field, "boxes[2]");

  q.boxes.pop_back();
  q.region.x_min -= 1e6;
  q.region.x_max -= 1e6;
  auto far = region::plan_region(*f.source, q);
  ASSERT_FALSE(far.ok());
  EXPECT_EQ(far.error().code, ErrorCode::kOutOfRange);
  EXPECT_EQ(far.error().field, "region");
  EXPECT_NE(far.error().message.find("region"), std::string::npos) << far.error().message;

  q.region = region_at(f.dem, 150, 200);
  q.options.face_resolution = 4;
  auto coarse = region::plan_region(*f.source, q);
  ASSERT_FALSE(coarse.ok());
  EXPECT_EQ(coarse.error().field, "face_resolution");

  // Unbounded cells read the whole raster, and say so in the plan.
  q.options = {};
  q.cells = true;
  q.boxes.clear();
  auto all = region::plan_region(*f.source, q);
  ASSERT_TRUE(all.ok()) << all.error().message;
  EXPECT_EQ(all->cells, static_cast<std::uint64_t>(f.dem.width()) * static_cast<std::uint64_t>(f.dem.height()));
}

}  // namespace
}  // namespace horizon
