// Many observers: a hand-computed count over a wall, the count equal to the
// sum of the single-observer viewsheds on a real DEM whatever the thread
// count, memory that does not grow with the observers, and the errors.
#include <gtest/gtest.h>

#include <chrono>
#include <random>
#include <vector>

#include "horizon/terrain/dem_reader.hpp"
#include "horizon/visibility/many_observers.hpp"
#include "visibility_test_util.hpp"

namespace horizon::visibility {
namespace {

using testing::grid_dem;

ObserverSite site_at(const terrain::Dem& dem, double col, double row, double height, double max_distance = 0) {
  ObserverSite s;
  s.point.x = dem.georef.transform.x_at(col);
  s.point.y = dem.georef.transform.y_at(row);
  s.point.height = height;
  s.max_distance = max_distance;
  return s;
}

// Flat ground at 0, 40 x 21 cells of 10 m, a 50 m wall along column 20; A
// west of it at column 5, B east at column 35, both on row 10, 2 m up.
terrain::Dem walled() {
  return grid_dem(40, 21, [](int c, int) { return c == 20 ? 50.0 : 0.0; });
}

std::uint32_t count_at(const ManyObserversResult& r, int col, int row) {
  return r.count.at(col - r.window.col0, row - r.window.row0);
}

TEST(ManyObservers, EachSideOfAWallIsSeenOnceAndTheWallTwice) {
  const terrain::Dem dem = walled();
  const std::vector<ObserverSite> sites = {site_at(dem, 5, 10, 2), site_at(dem, 35, 10, 2)};
  ManyObserversOptions options{.viewshed = testing::flat_earth(Algorithm::kR3)};
  auto plan = plan_many_observers(dem, sites, options);
  ASSERT_TRUE(plan.ok()) << plan.error().message;
  EXPECT_EQ(plan->window, (terrain::Window{0, 0, 40, 21}));
  EXPECT_EQ(plan->work_cells, 2u * 40 * 21);
  auto res = compute_many_observers(dem, *plan);
  ASSERT_TRUE(res.ok()) << res.error().message;
  for (int r = 0; r < 21; ++r)
    for (int c = 0; c < 40; ++c) EXPECT_EQ(count_at(*res, c, r), c == 20 ? 2u : 1u) << c << "," << r;
  const auto any = seen_from_any(*res), all = seen_from_all(*res);
  EXPECT_EQ(any.at(3, 4), kVisible);
  EXPECT_EQ(all.at(3, 4), kHidden);
  EXPECT_EQ(all.at(20, 4), kVisible);
  EXPECT_EQ(res->observers[0].cells_answered, 40u * 21);
  EXPECT_EQ(res->observers[0].cells_visible, 20u * 21 + 21);  // its side and the wall
  EXPECT_EQ(res->observers[1].cells_visible, 19u * 21 + 21);
}

TEST(ManyObservers, AnObserversReachLimitsWhatItCounts) {
  const terrain::Dem dem = walled();
  // A sees 100 m only: columns 16..19 of row 10 are beyond it, and hidden from B.
  const std::vector<ObserverSite> sites = {site_at(dem, 5, 10, 2, 100), site_at(dem, 35, 10, 2)};
  auto plan = plan_many_observers(dem, sites, {.viewshed = testing::flat_earth(Algorithm::kR3)});
  ASSERT_TRUE(plan.ok()) << plan.error().message;
  auto res = compute_many_observers(dem, *plan);
  ASSERT_TRUE(res.ok()) << res.error().message;
  EXPECT_EQ(count_at(*res, 10, 10), 1u);
  for (int c = 16; c <= 19; ++c) {
    EXPECT_EQ(count_at(*res, c, 10), 0u) << c;
    EXPECT_EQ(seen_from_any(*res).at(c, 10), kHidden) << c;  // answered (by B), seen by none
  }
  EXPECT_EQ(count_at(*res, 20, 10), 1u);  // the wall, now B's alone
  const auto counts = observer_count(*res);
  EXPECT_EQ(counts.at(17, 10), 0u);
}

TEST(ManyObservers, CellsNoObserverAnswersHaveNoCount) {
  const terrain::Dem dem = walled();
  const std::vector<ObserverSite> sites = {site_at(dem, 5, 10, 2, 50)};
  auto plan = plan_many_observers(dem, sites, {.viewshed = testing::flat_earth(Algorithm::kR3)});
  ASSERT_TRUE(plan.ok()) << plan.error().message;
  auto res = compute_many_observers(dem, *plan);
  ASSERT_TRUE(res.ok()) << res.error().message;
  // The window is the one observer's; its corners are beyond 50 m.
  EXPECT_EQ(res->window.col0, 0);
  EXPECT_LE(res->window.col1, 11);
  const int corner_col = res->window.col1 - 1 - res->window.col0, corner_row = res->window.row0 - res->window.row0;
  EXPECT_EQ(observer_count(*res).at(corner_col, corner_row), kNoCount);
  EXPECT_EQ(seen_from_any(*res).at(corner_col, corner_row), kNoAnswer);
  EXPECT_EQ(seen_from_all(*res).at(corner_col, corner_row), kNoAnswer);
}

struct Ecuador {
  terrain::Dem dem;
  std::vector<ObserverSite> sites;
};

Ecuador ecuador_towers(int count) {
  auto dem = terrain::read_dem(testing::bundled_dem("ecuador_andes_utm17s_10m_383x415.tif"));
  EXPECT_TRUE(dem.ok()) << dem.error().message;
  Ecuador e{std::move(*dem), {}};
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> col(5, e.dem.width() - 5), row(5, e.dem.height() - 5), h(2, 30),
      reach(400, 2500);
  while (static_cast<int>(e.sites.size()) < count) {  // on ground, not over the crop's voids
    const ObserverSite s = site_at(e.dem, col(rng), row(rng), h(rng), reach(rng));
    if (geodesy::resolve_point(e.dem, s.point, "observer").ok()) e.sites.push_back(s);
  }
  return e;
}

TEST(ManyObservers, TheCountIsTheSumOfTheSingleViewshedsWhateverTheThreads) {
  const Ecuador e = ecuador_towers(12);
  ManyObserversOptions options;
  options.viewshed.target_height = 1.5;
  options.threads = 2;
  auto plan = plan_many_observers(e.dem, e.sites, options);
  ASSERT_TRUE(plan.ok()) << plan.error().message;
  auto two = compute_many_observers(e.dem, *plan);
  ASSERT_TRUE(two.ok()) << two.error().message;

  // The reference: each observer on its own, summed cell by cell.
  terrain::Grid<std::uint32_t> sum(e.dem.width(), e.dem.height(), 0u);
  terrain::Grid<std::uint8_t> answered(e.dem.width(), e.dem.height(), 0);
  for (std::size_t i = 0; i < e.sites.size(); ++i) {
    ViewshedOptions o = options.viewshed;
    o.max_distance = e.sites[i].max_distance;
    o.threads = 1;
    o.visibility_only = true;
    auto vs = compute_viewshed(e.dem, plan->points[i], o);
    ASSERT_TRUE(vs.ok()) << vs.error().message;
    const auto mask = visibility_mask(*vs, o.target_height);
    std::uint64_t seen = 0;
    for (int r = 0; r < mask.height(); ++r)
      for (int c = 0; c < mask.width(); ++c) {
        const int col = vs->frame.window.col0 + c, row = vs->frame.window.row0 + r;
        if (mask.at(c, r) != kNoAnswer) answered.at(col, row) = 1;
        if (mask.at(c, r) == kVisible) {
          ++sum.at(col, row);
          ++seen;
        }
      }
    EXPECT_EQ(two->observers[i].cells_visible, seen) << "observer " << i;
  }
  const terrain::Window& w = two->window;
  std::uint64_t total = 0;
  for (int row = 0; row < e.dem.height(); ++row)
    for (int col = 0; col < e.dem.width(); ++col) {
      const bool inside = col >= w.col0 && col < w.col1 && row >= w.row0 && row < w.row1;
      if (!inside) {
        ASSERT_EQ(sum.at(col, row), 0u);
        continue;
      }
      ASSERT_EQ(two->count.at(col - w.col0, row - w.row0), sum.at(col, row)) << col << "," << row;
      ASSERT_EQ(two->answered.at(col - w.col0, row - w.row0), answered.at(col, row)) << col << "," << row;
      total += sum.at(col, row);
    }
  EXPECT_GT(total, 10000u);

  options.threads = 1;
  auto plan1 = plan_many_observers(e.dem, e.sites, options);
  ASSERT_TRUE(plan1.ok());
  auto one = compute_many_observers(e.dem, *plan1);
  ASSERT_TRUE(one.ok()) << one.error().message;
  EXPECT_TRUE(std::equal(one->count.values().begin(), one->count.values().end(), two->count.values().begin()));
}

TEST(ManyObservers, MemoryDoesNotGrowWithTheObservers) {
  const Ecuador few = ecuador_towers(10), many = ecuador_towers(1000);
  ManyObserversOptions options;
  options.threads = 2;
  auto a = plan_many_observers(few.dem, few.sites, options);
  auto b = plan_many_observers(many.dem, many.sites, options);
  ASSERT_TRUE(a.ok()) << a.error().message;
  ASSERT_TRUE(b.ok()) << b.error().message;
  // A hundred times the observers and their work, not the memory.
  EXPECT_GT(b->work_cells, 50 * a->work_cells);
  EXPECT_LT(b->bytes, 2 * a->bytes);
  EXPECT_LT(b->bytes, b->cells * 5 + 2 * b->cells * 9 + 1000 * 64);
}

TEST(ManyObservers, ErrorsNameTheObserver) {
  const Ecuador e = ecuador_towers(3);
  auto none = plan_many_observers(e.dem, std::vector<ObserverSite>{}, {});
  ASSERT_FALSE(none.ok());
  EXPECT_EQ(none.error().field, "observers");

  std::vector<ObserverSite> sites = e.sites;
  sites[2].point.x += 1e6;
  auto off = plan_many_observers(e.dem, sites, {});
  ASSERT_FALSE(off.ok());
  EXPECT_EQ(off.error().code, ErrorCode::kOutOfRange);
  EXPECT_EQ(off.error().field, "observers[2]");

  sites = e.sites;
  sites[1].max_distance = -5;
  auto negative = plan_many_observers(e.dem, sites, {});
  ASSERT_FALSE(negative.ok());
  EXPECT_EQ(negative.error().field, "observers[1].max_distance");

  ManyObserversOptions bad;
  bad.viewshed.target_height = -1;
  auto option = plan_many_observers(e.dem, e.sites, bad);
  ASSERT_FALSE(option.ok());
  EXPECT_EQ(option.error().field, "target_height");

  // Found by fuzz_requests: a ray spacing so fine that a site's sweep would
  // need more rays than an int counts. The plan refuses it, as a single
  // viewshed's plan does, before any work.
  ManyObserversOptions fine;
  fine.viewshed.radial.ray_spacing = 1e-300;
  auto rays = plan_many_observers(e.dem, e.sites, fine);
  ASSERT_FALSE(rays.ok());
  EXPECT_EQ(rays.error().code, ErrorCode::kResourceExhausted);
  EXPECT_EQ(rays.error().field, "ray_spacing");

  // A passed deadline stops the run before the first observer.
  auto plan = plan_many_observers(e.dem, e.sites, {});
  ASSERT_TRUE(plan.ok());
  RunControl late;
  late.deadline = std::chrono::steady_clock::now() - std::chrono::seconds(1);
  auto stopped = compute_many_observers(e.dem, *plan, &late);
  ASSERT_FALSE(stopped.ok());
  EXPECT_EQ(stopped.error().code, ErrorCode::kDeadlineExceeded);
}

}  // namespace
}  // namespace horizon::visibility
