// Tests for geodesy/observer.cpp: resolving viewpoints given in the dataset
// CRS or WGS84, above ground or absolute, and every refusal in the order the
// header promises.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include "horizon/geodesy/crs.hpp"
#include "horizon/geodesy/observer.hpp"
#include "horizon/terrain/dem_reader.hpp"
#include "test_support.hpp"

namespace horizon::geodesy {
namespace {

// 6 x 5 cells of 10 m, UTM 33N, corner (500000, 5000000), h = 10 c + 100 r.
terrain::Dem plane() {
  return testing::make_dem(6, 5, [](int c, int r) { return 10.0 * c + 100.0 * r; });
}

PointSpec at(double x, double y, double height = 2.0, HeightMode mode = HeightMode::kAboveGround) {
  PointSpec s;
  s.x = x;
  s.y = y;
  s.height = height;
  s.height_mode = mode;
  return s;
}

TEST(ResolvePoint, CellCentreAboveGround) {
  // Centre of cell (2, 3): x = 500000 + 2.5 * 10, y = 5000000 - 3.5 * 10.
  auto p = resolve_point(plane(), at(500025.0, 4999965.0, 1.75), "observer");
  ASSERT_TRUE(p.ok()) << p.error().message;
  EXPECT_DOUBLE_EQ(p->col, 2.0);
  EXPECT_DOUBLE_EQ(p->row, 3.0);
  EXPECT_DOUBLE_EQ(p->x, 500025.0);
  EXPECT_DOUBLE_EQ(p->ground, 320.0);
  EXPECT_DOUBLE_EQ(p->elevation, 321.75);
}

TEST(ResolvePoint, BetweenCentresIsBilinear) {
  // (col 2.5, row 1.25): 10 * 2.5 + 100 * 1.25 = 150 on this plane.
  auto p = resolve_point(plane(), at(500030.0, 4999982.5, 0.0), "observer");
  ASSERT_TRUE(p.ok()) << p.error().message;
  EXPECT_DOUBLE_EQ(p->col, 2.5);
  EXPECT_DOUBLE_EQ(p->row, 1.25);
  EXPECT_DOUBLE_EQ(p->ground, 150.0);
}

TEST(ResolvePoint, CellGroundIsTheValueOfTheCellThePointIsIn) {
  // (col 2.4, row 1.3) lies in cell (2, 1): its value is 120, where the
  // bilinear surface has 10 * 2.4 + 100 * 1.3 = 154.
  PointSpec s = at(500029.0, 4999982.0, 2.0);
  s.ground = GroundSample::kCell;
  auto p = resolve_point(plane(), s, "observer");
  ASSERT_TRUE(p.ok()) << p.error().message;
  EXPECT_DOUBLE_EQ(p->col, 2.4);
  EXPECT_DOUBLE_EQ(p->row, 1.3);
  EXPECT_DOUBLE_EQ(p->ground, 120.0);
  EXPECT_DOUBLE_EQ(p->elevation, 122.0);
  s.ground = GroundSample::kBilinear;
  EXPECT_NEAR(resolve_point(plane(), s, "observer")->ground, 154.0, 1e-9);
}

TEST(ResolvePoint, CellGroundOnEdgesTakesTheEdgeCell) {
  // A cell owns its west and north edges; the raster's outer edges belong to its edge cells.
  PointSpec s = at(500030.0, 4999985.0, 0.0);  // (col 2.5, row 1.0): the edge between cells 2 and 3
  s.ground = GroundSample::kCell;
  EXPECT_DOUBLE_EQ(resolve_point(plane(), s, "observer")->ground, 130.0);
  s.x = 500060.0;  // col 5.5, the east edge
  s.y = 4999950.0;  // row 4.5, the south edge
  EXPECT_DOUBLE_EQ(resolve_point(plane(), s, "observer")->ground, 450.0);
  s.x = 500000.0;  // col -0.5, row -0.5: the north-west corner
  s.y = 5000000.0;
  EXPECT_DOUBLE_EQ(resolve_point(plane(), s, "observer")->ground, 0.0);
}

TEST(ResolvePoint, CellGroundReadsOnlyItsOwnCell) {
  // A void diagonal to the point's cell spoils the bilinear ground, not the cell's.
  terrain::Dem dem = plane();
  dem.elevation.at(3, 2) = std::numeric_limits<float>::quiet_NaN();
  PointSpec s = at(500029.0, 4999982.0, 2.0);  // (col 2.4, row 1.3), in cell (2, 1)
  auto bilinear = resolve_point(dem, s, "observer");
  ASSERT_FALSE(bilinear.ok());
  EXPECT_EQ(bilinear.error().code, ErrorCode::kDataError);
  s.ground = GroundSample::kCell;
  auto cell = resolve_point(dem, s, "observer");
  ASSERT_TRUE(cell.ok()) << cell.error().message;
  EXPECT_DOUBLE_EQ(cell->ground, 120.0);
  // Its own cell void: refused as any void under an eye.
  dem.elevation.at(2, 1) = std::numeric_limits<float>::quiet_NaN();
  auto on_void = resolve_point(dem, s, "observer");
  ASSERT_FALSE(on_void.ok());
  EXPECT_EQ(on_void.error().code, ErrorCode::kDataError);
  EXPECT_EQ(on_void.error().field, "observer");
}

TEST(ResolvePoint, AbsoluteHeight) {
  auto p = resolve_point(plane(), at(500025.0, 4999965.0, 1000.0, HeightMode::kAbsolute), "target");
  ASSERT_TRUE(p.ok());
  EXPECT_DOUBLE_EQ(p->ground, 320.0);
  EXPECT_DOUBLE_EQ(p->elevation, 1000.0);
}

TEST(ResolvePoint, OuterEdgesAreInside) {
  // The outer corner of the raster: grid (-0.5, -0.5) and (5.5, 4.5).
  auto nw = resolve_point(plane(), at(500000.0, 5000000.0), "observer");
  ASSERT_TRUE(nw.ok()) << nw.error().message;
  EXPECT_DOUBLE_EQ(nw->col, -0.5);
  EXPECT_DOUBLE_EQ(nw->ground, 0.0);
  auto se = resolve_point(plane(), at(500060.0, 4999950.0), "observer");
  ASSERT_TRUE(se.ok()) << se.error().message;
  EXPECT_DOUBLE_EQ(se->ground, 450.0);
}

TEST(ResolvePoint, Wgs84Input) {
  const terrain::Dem dem = plane();
  const Crs utm = Crs::from_epsg(32633).value();
  const LonLat ll = utm.to_lonlat({500025.0, 4999965.0}).value();
  PointSpec s = at(ll.lon, ll.lat);
  s.frame = PointFrame::kWgs84;
  auto p = resolve_point(dem, s, "observer");
  ASSERT_TRUE(p.ok()) << p.error().message;
  EXPECT_NEAR(p->col, 2.0, 1e-6);
  EXPECT_NEAR(p->row, 3.0, 1e-6);
  EXPECT_NEAR(p->x, 500025.0, 1e-5);
  EXPECT_NEAR(p->elevation, 322.0, 1e-4);
}

TEST(ResolvePoint, Wgs84OnRealGeographicDem) {
  auto dem = terrain::read_dem(testing::bundled_dem("rainier_summit_srtm3_400x400.tif"));
  ASSERT_TRUE(dem.ok()) << dem.error().message;
  PointSpec s = at(dem->georef.transform.x_at(199), dem->georef.transform.y_at(177), 1.5);
  s.frame = PointFrame::kWgs84;
  auto p = resolve_point(dem.value(), s, "observer");
  ASSERT_TRUE(p.ok()) << p.error().message;
  EXPECT_NEAR(p->col, 199.0, 1e-9);
  EXPECT_NEAR(p->row, 177.0, 1e-9);
  EXPECT_DOUBLE_EQ(p->ground, 4371.0);  // the summit cell
  EXPECT_DOUBLE_EQ(p->elevation, 4372.5);
}

TEST(ResolvePoint, Wgs84CellCentreThroughADatumShiftIsOnTheCentre) {
  // Swiss LV95 (CH1903+, a translation from WGS 84): a cell centre taken to
  // WGS 84 and back comes home ~1 mm off (PROJ's 2D datum shifts drop the
  // height they give a point), a ten-thousandth of these 10 m cells. It
  // still lands on the centre, so the void east of it does not leak into
  // the ground under it.
  terrain::Dem dem = testing::make_dem(
      6, 5, [](int c, int r) { return 10.0 * c + 100.0 * r; }, 10.0, 2056);
  dem.georef.transform.origin_x = 2600000.0;
  dem.georef.transform.origin_y = 1200000.0;
  dem.elevation.at(3, 3) = std::numeric_limits<float>::quiet_NaN();
  const Crs lv95 = Crs::from_epsg(2056).value();
  const XY centre{dem.georef.transform.x_at(2), dem.georef.transform.y_at(3)};
  const LonLat ll = lv95.to_lonlat(centre).value();
  const XY back = lv95.from_lonlat(ll).value();
  ASSERT_GT(std::hypot(back.x - centre.x, back.y - centre.y), 1e-5) << "the round trip is exact here: no test";
  PointSpec s = at(ll.lon, ll.lat);
  s.frame = PointFrame::kWgs84;
  auto p = resolve_point(dem, s, "observer");
  ASSERT_TRUE(p.ok()) << p.error().message;
  EXPECT_EQ(p->col, 2.0);
  EXPECT_EQ(p->row, 3.0);
  EXPECT_DOUBLE_EQ(p->ground, 320.0);
}

TEST(ResolvePoint, RejectsNonFiniteFieldsByName) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  auto x = resolve_point(plane(), at(nan, 4999965.0), "observer");
  ASSERT_FALSE(x.ok());
  EXPECT_EQ(x.error().code, ErrorCode::kInvalidArgument);
  EXPECT_EQ(x.error().field, "observer.x");
  auto y = resolve_point(plane(), at(500025.0, inf), "target");
  ASSERT_FALSE(y.ok());
  EXPECT_EQ(y.error().field, "target.y");
  auto h = resolve_point(plane(), at(500025.0, 4999965.0, nan), "observer");
  ASSERT_FALSE(h.ok());
  EXPECT_EQ(h.error().field, "observer.height");
  PointSpec s = at(nan, 45.0);
  s.frame = PointFrame::kWgs84;
  EXPECT_EQ(resolve_point(plane(), s, "observer").error().field, "observer.lon");
}

TEST(ResolvePoint, RejectsWgs84WithoutCrs) {
  terrain::Dem dem = plane();
  dem.georef.epsg = 0;
  PointSpec s = at(15.0, 45.0);
  s.frame = PointFrame::kWgs84;
  auto p = resolve_point(dem, s, "observer");
  ASSERT_FALSE(p.ok());
  EXPECT_EQ(p.error().code, ErrorCode::kInvalidArgument);
  EXPECT_NE(p.error().message.find("no CRS"), std::string::npos) << p.error().message;
}

TEST(ResolvePoint, RejectsBadLatitude) {
  PointSpec s = at(15.0, 95.0);
  s.frame = PointFrame::kWgs84;
  auto p = resolve_point(plane(), s, "observer");
  ASSERT_FALSE(p.ok());
  EXPECT_EQ(p.error().field, "observer.lat");
}

TEST(ResolvePoint, RejectsOutsideWithCoordinates) {
  auto p = resolve_point(plane(), at(500061.0, 4999965.0), "observer");
  ASSERT_FALSE(p.ok());
  EXPECT_EQ(p.error().code, ErrorCode::kOutOfRange);
  EXPECT_NE(p.error().message.find("500061"), std::string::npos) << p.error().message;
  EXPECT_NE(p.error().message.find("4999965"), std::string::npos);
  EXPECT_NE(p.error().message.find("outside"), std::string::npos);
  EXPECT_EQ(resolve_point(plane(), at(500025.0, 5000000.01), "observer").error().code, ErrorCode::kOutOfRange);
  PointSpec far = at(-70.0, 40.0);
  far.frame = PointFrame::kWgs84;
  EXPECT_EQ(resolve_point(plane(), far, "observer").error().code, ErrorCode::kOutOfRange);
}

TEST(ResolvePoint, RejectsHeightAboveGroundOnVoid) {
  terrain::Dem dem = plane();
  dem.elevation.at(2, 3) = std::numeric_limits<float>::quiet_NaN();
  auto p = resolve_point(dem, at(500025.0, 4999965.0), "observer");
  ASSERT_FALSE(p.ok());
  EXPECT_EQ(p.error().code, ErrorCode::kDataError);
  EXPECT_EQ(p.error().message.rfind("observer is on a no-data cell", 0), 0u) << p.error().message;
  // An absolute altitude does not need the ground.
  auto abs = resolve_point(dem, at(500025.0, 4999965.0, 500.0, HeightMode::kAbsolute), "observer");
  ASSERT_TRUE(abs.ok()) << abs.error().message;
  EXPECT_TRUE(std::isnan(abs->ground));
  EXPECT_DOUBLE_EQ(abs->elevation, 500.0);
}

TEST(ResolvePoint, RejectsEverestSummitVoid) {
  auto dem = terrain::read_dem(testing::bundled_dem("everest_summit_voids_srtm3_300x300.tif"));
  ASSERT_TRUE(dem.ok()) << dem.error().message;
  PointSpec s = at(86.925278, 27.988056, 2.0);  // the summit, an unfilled SRTM void
  s.frame = PointFrame::kWgs84;
  auto p = resolve_point(dem.value(), s, "observer");
  ASSERT_FALSE(p.ok());
  EXPECT_EQ(p.error().code, ErrorCode::kDataError);
}

}  // namespace
}  // namespace horizon::geodesy
