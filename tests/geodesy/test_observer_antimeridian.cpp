// Regression: a geographic DEM across the antimeridian (found by the stress
// check "antimeridian"): an observer given as WGS84 lon -179.95 was reported
// outside a DEM spanning x 179.9..180.1, although it is the point x = 180.05.
#include <gtest/gtest.h>

#include "horizon/geodesy/observer.hpp"
#include "test_support.hpp"

namespace horizon::geodesy {
namespace {

terrain::Dem across_antimeridian() {
  terrain::Dem dem = testing::make_dem(
      40, 40, [](int c, int r) { return 100.0 + c + r; }, 1.0, 4326);
  dem.georef.transform = {179.9, 0.005, -16.9, -0.005};  // lon 179.9 .. 180.1, lat -16.9 .. -17.1
  return dem;
}

TEST(ResolvePointAntimeridian, NegativeLongitudeWrapsOntoTheDem) {
  const terrain::Dem dem = across_antimeridian();
  PointSpec wgs;
  wgs.frame = PointFrame::kWgs84;
  wgs.x = -179.95;
  wgs.y = -16.95;
  auto p = resolve_point(dem, wgs, "observer");
  ASSERT_TRUE(p.ok()) << p.error().message;
  EXPECT_NEAR(p->x, 180.05, 1e-12);
  EXPECT_NEAR(p->col, 29.5, 1e-9);  // (180.05 - 179.9) / 0.005 - 0.5
  EXPECT_NEAR(p->row, 9.5, 1e-9);
  // The same point in the dataset's own coordinates, either way round.
  PointSpec native = wgs;
  native.frame = PointFrame::kDatasetCrs;
  auto q = resolve_point(dem, native, "observer");
  ASSERT_TRUE(q.ok()) << q.error().message;
  EXPECT_EQ(q->col, p->col);
  native.x = 180.05;
  EXPECT_EQ(resolve_point(dem, native, "observer")->col, p->col);
}

TEST(ResolvePointAntimeridian, RejectsPointsOffTheDemEvenAfterWrapping) {
  const terrain::Dem dem = across_antimeridian();
  PointSpec wgs;
  wgs.frame = PointFrame::kWgs84;
  wgs.x = -179.0;  // = 181.0, past the DEM's east edge
  wgs.y = -16.95;
  auto p = resolve_point(dem, wgs, "observer");
  ASSERT_FALSE(p.ok());
  EXPECT_EQ(p.error().code, ErrorCode::kOutOfRange);
}

TEST(ResolvePointAntimeridian, ProjectedDemsDoNotWrap) {
  terrain::Dem dem = testing::make_dem(
      40, 40, [](int, int) { return 0.0; }, 10.0, 32633);
  PointSpec p;
  p.x = 500000.0 + 200.0 - 360.0;  // 360 units west: no wrapping in metres
  p.y = 5000000.0 - 200.0;
  EXPECT_EQ(resolve_point(dem, p, "observer").error().code, ErrorCode::kOutOfRange);
}

}  // namespace
}  // namespace horizon::geodesy
