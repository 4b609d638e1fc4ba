// Tests for mesh/tin_from_dem.cpp (greedy insertion, measure_fit): planes
// and spikes with known answers, the budget and error bound as properties,
// the fit against a brute-force point location, voids, and a bundled DEM.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "horizon/mesh/local_frame.hpp"
#include "horizon/mesh/tin_from_dem.hpp"
#include "horizon/terrain/dem_reader.hpp"
#include "test_support.hpp"

namespace horizon::mesh {
namespace {

DemTin build(const terrain::Dem& dem, std::uint32_t max_vertices, double max_error = 0.0) {
  auto tin = tin_from_dem(dem, {max_vertices, max_error});
  EXPECT_TRUE(tin.ok()) << tin.error().message;
  return tin.ok() ? std::move(*tin) : DemTin{};
}

TEST(TinFromDem, APlaneNeedsOnlyItsCorners) {
  const terrain::Dem dem = testing::make_dem(20, 15, [](int c, int r) { return 2.0 * c + 3.0 * r; });
  DemTin t = build(dem, 1000);
  EXPECT_EQ(t.tin.vertices.size(), 4u);
  EXPECT_EQ(t.tin.triangles.size(), 2u);
  EXPECT_LT(t.fit.max_error, 1e-9);
  EXPECT_EQ(t.fit.cells, 300u);
  EXPECT_EQ(t.fit.outside, 0u);
  // The corners are the corner cells' centres, in the DEM's CRS.
  const auto& g = dem.georef.transform;
  EXPECT_EQ(t.tin.vertices[0], (TinVertex{g.x_at(0), g.y_at(0), 0.0}));
  EXPECT_EQ(t.tin.vertices[2], (TinVertex{g.x_at(19), g.y_at(14), 2.0 * 19 + 3.0 * 14}));
  EXPECT_TRUE(check_height_field(t.tin, "tin").ok());
  for (const TinTriangle& tri : t.tin.triangles) EXPECT_GT(signed_area(t.tin, tri), 0.0);  // as emitted
}

TEST(TinFromDem, ASpikeIsTheFirstPointAdded) {
  const terrain::Dem dem = testing::make_dem(16, 12, [](int c, int r) { return c == 7 && r == 5 ? 100.0 : 0.0; });
  DemTin t = build(dem, 5);
  ASSERT_EQ(t.tin.vertices.size(), 5u);
  EXPECT_EQ(t.tin.vertices[4].z, 100.0);
  EXPECT_EQ(t.tin.vertices[4].x, dem.georef.transform.x_at(7));
  EXPECT_EQ(t.tin.vertices[4].y, dem.georef.transform.y_at(5));
  // Without it the spike is missed by its full height; with it, its cone
  // over the flat cells around it needs more vertices, until none is off.
  EXPECT_EQ(build(dem, 4).fit.max_error, 100.0);
  const DemTin whole = build(dem, 1000);
  EXPECT_GT(whole.tin.vertices.size(), 5u);
  EXPECT_EQ(whole.fit.max_error, 0.0);
}

TEST(TinFromDem, KeepsToItsBudgetAndItsErrorBound) {
  const terrain::Dem dem = testing::make_random_terrain(64, 48, 7);
  double last_rmse = std::numeric_limits<double>::infinity();
  for (std::uint32_t budget : {20u, 100u, 400u}) {
    DemTin t = build(dem, budget);
    EXPECT_EQ(t.tin.vertices.size(), budget);
    EXPECT_EQ(t.fit.cells, 64u * 48u);
    EXPECT_LT(t.fit.rmse, last_rmse) << budget;
    last_rmse = t.fit.rmse;
    Tin copy = t.tin;
    EXPECT_TRUE(check_height_field(copy, "tin").ok());
  }
  for (double bound : {20.0, 5.0, 1.0}) {
    DemTin t = build(dem, 100'000, bound);
    EXPECT_LE(t.fit.max_error, bound);
    // The greedy order: the TIN one vertex smaller still missed by more.
    DemTin smaller = build(dem, static_cast<std::uint32_t>(t.tin.vertices.size() - 1));
    EXPECT_GT(smaller.fit.max_error, bound);
  }
}

// The fit by brute force: each cell centre located by testing every
// triangle (barycentric, in the CRS), the first that holds it used.
TinFit brute_fit(const Tin& tin, const terrain::Dem& dem) {
  TinFit fit;
  double squares = 0;
  const auto& g = dem.georef.transform;
  for (int r = 0; r < dem.height(); ++r)
    for (int c = 0; c < dem.width(); ++c) {
      const double h = dem.elevation.at(c, r), x = g.x_at(c), y = g.y_at(r);
      if (std::isnan(h)) continue;
      bool found = false;
      for (const TinTriangle& t : tin.triangles) {
        const TinVertex &a = tin.vertices[t[0]], &b = tin.vertices[t[1]], &v = tin.vertices[t[2]];
        const double d = (b.x - a.x) * (v.y - a.y) - (v.x - a.x) * (b.y - a.y);
        const double wb = ((x - a.x) * (v.y - a.y) - (v.x - a.x) * (y - a.y)) / d;
        const double wc = ((b.x - a.x) * (y - a.y) - (x - a.x) * (b.y - a.y)) / d;
        const double wa = 1 - wb - wc;
        if (wa < -1e-9 || wb < -1e-9 || wc < -1e-9) continue;
        const double e = std::fabs(h - (wa * a.z + wb * b.z + wc * v.z));
        fit.max_error = std::max(fit.max_error, e);
        squares += e * e;
        ++fit.cells;
        found = true;
        break;
      }
      fit.outside += !found;
    }
  fit.rmse = std::sqrt(squares / static_cast<double>(fit.cells));
  return fit;
}

TEST(TinFromDem, MeasuresItsFitAsABruteForceLocationDoes) {
  const terrain::Dem dem = testing::make_dem(50, 40, [](int c, int r) { return 40 * std::sin(c * 0.2) * std::cos(r * 0.15); });
  for (std::uint32_t budget : {4u, 30u, 150u}) {
    DemTin t = build(dem, budget);
    const TinFit brute = brute_fit(t.tin, dem);
    EXPECT_EQ(t.fit.cells, brute.cells);
    EXPECT_EQ(t.fit.outside, brute.outside);
    EXPECT_NEAR(t.fit.max_error, brute.max_error, 1e-6);
    EXPECT_NEAR(t.fit.rmse, brute.rmse, 1e-6);
  }
}

TEST(TinFromDem, NeverPutsAVertexOnAVoidAndStartsFromTheValidCellsNearestTheCorners) {
  constexpr double kVoid = std::numeric_limits<double>::quiet_NaN();
  const terrain::Dem dem = testing::make_dem(30, 20, [&](int c, int r) {
    if (c + r < 3) return kVoid;                         // the north-west corner
    if (c >= 12 && c < 18 && r >= 8 && r < 12) return kVoid;  // a hole
    return 10.0 * std::sin(c * 0.4) + r;
  });
  DemTin t = build(dem, 200);
  const auto& g = dem.georef.transform;
  for (const TinVertex& v : t.tin.vertices) {
    const int c = static_cast<int>(std::lround(g.col_at(v.x))), r = static_cast<int>(std::lround(g.row_at(v.y)));
    EXPECT_FALSE(std::isnan(dem.elevation.at(c, r))) << c << ", " << r;
  }
  // The nearest valid cell to (0, 0) in Chebyshev rings, the first in row
  // order: ring 2 holds (2, 0), void, then (2, 1).
  EXPECT_EQ(t.tin.vertices[0].x, g.x_at(2));
  EXPECT_EQ(t.tin.vertices[0].y, g.y_at(1));
  const TinFit brute = brute_fit(t.tin, dem);
  EXPECT_EQ(t.fit.cells + t.fit.outside, 30u * 20u - 6u - 24u);
  EXPECT_EQ(t.fit.outside, brute.outside);
  EXPECT_GT(t.fit.outside, 0u);  // the cut corner's valid cells beyond the hull
}

TEST(TinFromDem, IsDeterministic) {
  const terrain::Dem dem = testing::make_random_terrain(80, 60, 3);
  const DemTin a = build(dem, 300), b = build(dem, 300);
  EXPECT_EQ(a.tin.vertices, b.tin.vertices);
  EXPECT_EQ(a.tin.triangles, b.tin.triangles);
}

TEST(TinFromDem, RefusesOptionsOutOfRangeAndATooSmallDem) {
  const terrain::Dem dem = testing::make_dem(10, 10, [](int, int) { return 0.0; });
  auto few = tin_from_dem(dem, {3, 0.0});
  ASSERT_FALSE(few.ok());
  EXPECT_EQ(few.error().code, ErrorCode::kInvalidArgument);
  EXPECT_EQ(few.error().field, "max_vertices");
  auto many = tin_from_dem(dem, {20'000'000, 0.0});
  ASSERT_FALSE(many.ok());
  EXPECT_EQ(many.error().code, ErrorCode::kResourceExhausted);
  for (double bad : {-1.0, std::numeric_limits<double>::quiet_NaN()}) {
    auto r = tin_from_dem(dem, {100, bad});
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error().field, "max_error");
  }
  auto thin = tin_from_dem(testing::make_dem(1, 5, [](int, int) { return 0.0; }), {100, 0.0});
  ASSERT_FALSE(thin.ok());
  EXPECT_EQ(thin.error().code, ErrorCode::kDataError);
  EXPECT_NE(thin.error().message.find("at least 2 x 2 cells, not 1 x 5"), std::string::npos);
  auto line = tin_from_dem(testing::make_dem(5, 5, [](int c, int r) {
                             return c == r ? 1.0 : std::numeric_limits<double>::quiet_NaN();
                           }),
                           {100, 0.0});
  ASSERT_FALSE(line.ok());
  EXPECT_NE(line.error().message.find("lie on one line"), std::string::npos);
}

TEST(TinFromDem, FitsABundledDemBetterWithEachBudget) {
  auto dem = terrain::read_dem(testing::bundled_dem("everest_summit_voids_srtm3_300x300.tif"));
  ASSERT_TRUE(dem.ok()) << dem.error().message;
  const DemTin coarse = build(*dem, 500), fine = build(*dem, 4000);
  EXPECT_LT(fine.fit.rmse, coarse.fit.rmse);
  EXPECT_LT(fine.fit.max_error, coarse.fit.max_error);
  Tin copy = fine.tin;
  EXPECT_TRUE(check_height_field(copy, "everest").ok());
  const DemTin bounded = build(*dem, 1'000'000, 25.0);
  EXPECT_LE(bounded.fit.max_error, 25.0);
  EXPECT_LT(bounded.tin.vertices.size(), 90'000u);  // far fewer vertices than cells
}

TEST(LocalFrame, GeographicDemsGetMetresAndProjectedOnesStayAsTheyAre) {
  auto rainier = terrain::read_dem(testing::bundled_dem("rainier_summit_srtm3_400x400.tif"));
  ASSERT_TRUE(rainier.ok()) << rainier.error().message;
  auto frame = LocalFrame::for_dem(*rainier);
  ASSERT_TRUE(frame.ok()) << frame.error().message;
  EXPECT_TRUE(frame->geographic());
  // 1/1200 degree of latitude is about 92.6 m; of longitude at 46.83 N, 63.5 m.
  const TinVertex a = frame->to_local({-121.76, 46.83, 4000});
  const TinVertex b = frame->to_local({-121.76, 46.83 + 1.0 / 1200, 4000});
  const TinVertex c = frame->to_local({-121.76 + 1.0 / 1200, 46.83, 4000});
  EXPECT_NEAR(std::hypot(b.x - a.x, b.y - a.y), 92.6, 0.2);
  EXPECT_NEAR(std::hypot(c.x - a.x, c.y - a.y), 63.5, 0.2);
  EXPECT_NEAR(b.y - a.y, 92.6, 0.2);  // north is +y
  EXPECT_NEAR(c.x - a.x, 63.5, 0.2);  // east is +x
  EXPECT_EQ(a.z, 4000.0);
  const TinVertex back = frame->to_crs(b);
  EXPECT_NEAR(back.x, -121.76, 1e-10);
  EXPECT_NEAR(back.y, 46.83 + 1.0 / 1200, 1e-10);

  auto andes = terrain::read_dem(testing::bundled_dem("ecuador_andes_utm17s_10m_383x415.tif"));
  ASSERT_TRUE(andes.ok());
  auto utm = LocalFrame::for_dem(*andes);
  ASSERT_TRUE(utm.ok());
  EXPECT_FALSE(utm->geographic());
  EXPECT_EQ(utm->to_local({700000.5, 9550000.25, 2000}), (TinVertex{700000.5, 9550000.25, 2000}));
}

}  // namespace
}  // namespace horizon::mesh
