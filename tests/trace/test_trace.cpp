// The silhouette-partitioning trace (horizon/trace/trace.hpp): against its
// brute-force reference bit for bit, against hand-computed scenes, against
// R3 along each pixel's plane, and the properties every frame must have.
#include "horizon/trace/trace.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "horizon/geodesy/crs.hpp"
#include "horizon/visibility/line_of_sight.hpp"
#include "test_support.hpp"
#include "trace_test_util.hpp"
#include "visibility/simd.hpp"

namespace horizon::trace {
namespace {

using testing::camera_at;
using testing::spec_of;

void expect_same_image(const TraceImage& got, const TraceImage& want, const std::string& what) {
  ASSERT_EQ(got.width, want.width);
  ASSERT_EQ(got.height, want.height);
  std::size_t different = 0;
  for (std::size_t i = 0; i < got.distance.size(); ++i) {
    const bool same =
        got.line[i] == want.line[i] && got.axis[i] == want.axis[i] &&
        (got.distance[i] == want.distance[i] || (std::isinf(got.distance[i]) && std::isinf(want.distance[i])));
    if (!same && different++ < 5)
      ADD_FAILURE() << what << ": pixel " << i % got.width << "," << i / got.width << " line " << got.line[i]
                    << " axis " << int(got.axis[i]) << " d " << got.distance[i] << " vs reference line " << want.line[i]
                    << " axis " << int(want.axis[i]) << " d " << want.distance[i];
  }
  EXPECT_EQ(different, 0u) << what;
}

TraceResult traced(const terrain::Dem& dem, const Camera& camera, const TraceOptions& options) {
  auto r = trace_frame(terrain::HeightView(dem.elevation), camera, options);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().message);
  return std::move(*r);
}

// ---- hand-computed scenes ---------------------------------------------------

TEST(Trace, AFlatPlaneIsHitWhereEachRayMeetsIt) {
  // Ground at 100 m, eye 10 m above it, looking north: a ray falling s per
  // metre meets the plane 10 / -s metres out; above the horizon is sky.
  const terrain::Dem dem = horizon::testing::make_dem(
      200, 400, [](int, int) { return 100.0; }, 10.0);
  TraceOptions options;
  options.curvature_coefficient = 0.0;
  const Camera camera = camera_at(dem, 100.0, 390.0, 10.0, spec_of(0.0, 0.0, 60.0, 64, 64));
  const TraceResult r = traced(dem, camera, options);
  int ground = 0;
  for (int j = 0; j < 64; ++j)
    for (int x = 0; x < 64; ++x) {
      const double s = camera.slope(x, j);
      const Hit h = r.hit(x, j);
      const double reach = 10.0 / -s;  // where the plane is met, if inside the DEM
      const double along = reach * std::cos(camera.azimuth[static_cast<std::size_t>(x)]) / 10.0;
      if (s >= 0 || along > 389.0) {
        EXPECT_TRUE(h.sky) << x << "," << j;
        continue;
      }
      ASSERT_FALSE(h.sky) << x << "," << j << " slope " << s;
      ++ground;
      EXPECT_NEAR(h.distance, reach, 1e-4 * reach) << x << "," << j;
      EXPECT_NEAR(h.elevation, 100.0, 1e-3);
      EXPECT_EQ(r.image.axis[static_cast<std::size_t>(j * 64 + x)], LineAxis::kRows);
    }
  EXPECT_GT(ground, 64 * 20);
}

TEST(Trace, AWallHidesTheGroundBehindItUpToItsTop) {
  // Flat ground at 0 with a 50 m wall on row 300; the eye 20 m up on row 380
  // looks north. Rays below the wall top's slope stop at row 300 (or
  // nearer, on the ground); those above it go on to the ground behind or
  // the sky. 10 m cells, no curvature.
  const terrain::Dem dem = horizon::testing::make_dem(
      120, 400, [](int, int r) { return r == 300 ? 50.0 : 0.0; }, 10.0);
  TraceOptions options;
  options.curvature_coefficient = 0.0;
  const Camera camera = camera_at(dem, 60.0, 380.0, 20.0, spec_of(0.0, 0.0, 40.0, 48, 96));
  const TraceResult r = traced(dem, camera, options);
  int on_wall = 0, beyond = 0;
  for (int j = 0; j < 96; ++j)
    for (int x = 0; x < 48; ++x) {
      const double s = camera.slope(x, j);
      const double cos_phi = std::cos(camera.azimuth[static_cast<std::size_t>(x)]);
      const double wall_d = 800.0 / cos_phi;  // 80 rows of 10 m ahead, along the column's azimuth
      const double top = 30.0 / wall_d;       // the wall top's slope
      const double ground_d = 20.0 / -s;      // where the ray would meet the ground
      const auto at = static_cast<std::size_t>(j * 48 + x);
      if (s < 0 && ground_d < wall_d - 10.0 / cos_phi) continue;  // lands in front, hit elsewhere
      if (s <= top && !(s < 0 && ground_d < wall_d)) {
        EXPECT_EQ(r.image.line[at], 300) << x << "," << j;
        ++on_wall;
      } else if (s > top) {
        EXPECT_TRUE(r.image.line[at] < 300) << x << "," << j << " line " << r.image.line[at];
        ++beyond;
      }
    }
  EXPECT_GT(on_wall, 100);
  EXPECT_GT(beyond, 100);
}

TEST(Trace, ColumnCrossingsCatchARidgeTheRowsAloneMiss) {
  // A 60 m ridge along column line 100 only; the eye looks north-east, so
  // its rays cross the ridge steeply between rows: the row crossings on
  // either side take a sliver of its height, the column crossing all of it.
  const terrain::Dem dem = horizon::testing::make_dem(
      200, 200, [](int c, int) { return c == 100 ? 60.0 : 0.0; }, 10.0);
  TraceOptions options;
  options.curvature_coefficient = 0.0;
  const Camera camera = camera_at(dem, 70.0, 180.0, 5.0, spec_of(35.0, 0.0, 18.0, 32, 64));
  const TraceResult rows = traced(dem, camera, options);
  options.column_crossings = true;
  const TraceResult exact = traced(dem, camera, options);
  // The ground distance of a hit's crossing, from its line.
  auto crossing_distance = [&](const TraceImage& image, int x, std::size_t i) {
    const double az = camera.azimuth[static_cast<std::size_t>(x)];
    return image.axis[i] == LineAxis::kRows ? std::abs(camera.eye.row - image.line[i]) * 10.0 / std::abs(std::cos(az))
                                            : std::abs(image.line[i] - camera.eye.col) * 10.0 / std::abs(std::sin(az));
  };
  int caught = 0;
  for (std::size_t i = 0; i < rows.image.distance.size(); ++i) {
    if (rows.image.line[i] < 0) continue;
    const int x = static_cast<int>(i % 32);
    // More crossings can only bring the hit crossing nearer; the hit point
    // lies on the chord before its crossing.
    EXPECT_LE(exact.image.distance[i], crossing_distance(rows.image, x, i) + 1e-3) << i;
    EXPECT_LE(crossing_distance(exact.image, x, i), crossing_distance(rows.image, x, i) + 1e-3) << i;
    if (exact.image.axis[i] == LineAxis::kColumns && exact.image.line[i] == 100 &&
        crossing_distance(exact.image, x, i) < crossing_distance(rows.image, x, i) - 1.0)
      ++caught;
  }
  EXPECT_GT(caught, 20);
}

// ---- the reference, bit for bit -----------------------------------------

struct Shot {
  double col, row, above, yaw, pitch, hfov;
  int width, height;
  Projection projection;
};

void check_against_reference() {
  terrain::Dem dem = horizon::testing::make_random_terrain(211, 173, 5, 400.0, 30.0);
  for (int r = 20; r < 30; ++r)
    for (int c = 150; c < 170; ++c) dem.elevation.at(c, r) = std::numeric_limits<float>::quiet_NaN();
  const Shot shots[] = {
      {105.2, 86.7, 30.0, 0.0, 0.0, 60.0, 67, 41, Projection::kPerspective},
      {105.2, 86.7, 30.0, 45.0, -10.0, 60.0, 64, 40, Projection::kPerspective},    // on a quadrant boundary
      {10.5, 160.0, 5.0, 37.0, 3.0, 150.0, 97, 33, Projection::kPerspective},      // three sub-frusta
      {200.0, 10.0, 200.0, 225.0, -30.0, 90.0, 50, 50, Projection::kPerspective},  // high, looking down
      {0.0, 0.0, 2.0, 135.0, 0.0, 20.0, 33, 65, Projection::kPerspective},         // on a corner cell
      {105.0, 86.0, 15.0, 0.0, 0.0, 360.0, 181, 37, Projection::kCylindrical},     // on a cell centre, all round
      {60.3, 120.9, 50.0, 271.0, 20.0, 200.0, 101, 29, Projection::kCylindrical},
  };
  for (bool columns : {false, true}) {
    for (const Shot& s : shots) {
      const Camera camera =
          camera_at(dem, s.col, s.row, s.above, spec_of(s.yaw, s.pitch, s.hfov, s.width, s.height, s.projection));
      TraceOptions options;
      options.column_crossings = columns;
      options.near = 5.0;
      const TraceResult r = traced(dem, camera, options);
      const TraceImage ref = trace_reference(terrain::HeightView(dem.elevation), camera, options);
      expect_same_image(r.image, ref,
                        std::string(columns ? "rows+columns" : "rows") + " yaw " + std::to_string(s.yaw) + " hfov " +
                            std::to_string(s.hfov));
      EXPECT_GT(r.stats.pixels - r.stats.sky_pixels, 0u);
    }
  }
}

// Geographic DEMs have cells wider than tall (or the reverse): sub-frusta
// are cut in grid terms, and the trace still walks the reference's crossings.
TEST(TraceEqualsReference, OnCellsWiderThanTall) {
  const terrain::Dem dem = horizon::testing::make_random_terrain(150, 190, 12, 500.0, 30.0);
  for (bool columns : {false, true})
    for (double yaw : {20.0, 40.0, 50.0, 130.0, 300.0}) {
      geodesy::GridPoint eye;
      eye.col = 74.6;
      eye.row = 95.2;
      eye.elevation = terrain::sample_bilinear(dem.elevation, eye.col, eye.row) + 40.0;
      auto camera = make_camera(spec_of(yaw, -4.0, 100.0, 70, 30), eye, 63.0, 92.0);
      ASSERT_TRUE(camera.ok());
      TraceOptions options;
      options.column_crossings = columns;
      auto r = trace_frame(terrain::HeightView(dem.elevation), *camera, options);
      ASSERT_TRUE(r.ok());
      expect_same_image(r->image, trace_reference(terrain::HeightView(dem.elevation), *camera, options),
                        "63 x 92 m cells, yaw " + std::to_string(yaw));
    }
}

// Under every kernel form the CPU runs, scalar included.
TEST(TraceEqualsReference, OnRandomTerrainWithEveryKindOfCameraInEveryForm) {
  namespace simd = visibility::sweep::simd;
  struct Restore {
    ~Restore() { simd::isa_limit() = simd::Isa::kAvx512; }
  } restore;
  for (const simd::Isa isa : {simd::Isa::kScalar, simd::Isa::kAvx2, simd::Isa::kAvx512}) {
    if (simd::cpu_isa() < isa) continue;
    simd::isa_limit() = isa;
    SCOPED_TRACE("kernels capped at form " + std::to_string(static_cast<int>(isa)));
    check_against_reference();
    if (HasFatalFailure()) return;
  }
}

// ---- properties ---------------------------------------------------------

TEST(Trace, LookingHigherInAColumnNeverSeesNearer) {
  const terrain::Dem dem = horizon::testing::make_random_terrain(256, 256, 21, 500.0, 30.0);
  for (bool columns : {false, true}) {
    TraceOptions options;
    options.column_crossings = columns;
    const Camera camera = camera_at(dem, 128.4, 127.9, 20.0, spec_of(300.0, -5.0, 170.0, 128, 96));
    const TraceResult r = traced(dem, camera, options);
    for (int x = 0; x < 128; ++x)
      for (int j = 1; j < 96; ++j)  // j - 1 is the pixel above j
        EXPECT_GE(r.image.distance[static_cast<std::size_t>((j - 1) * 128 + x)],
                  r.image.distance[static_cast<std::size_t>(j * 128 + x)])
            << x << "," << j;
  }
}

TEST(Trace, HitsRespectTheNearPlaneMaxDistanceAndVoids) {
  terrain::Dem dem = horizon::testing::make_random_terrain(150, 150, 3, 300.0, 30.0);
  // A tall void block: never terrain, so rays pass through it.
  for (int r = 40; r < 60; ++r)
    for (int c = 60; c < 90; ++c) dem.elevation.at(c, r) = std::numeric_limits<float>::quiet_NaN();
  TraceOptions options;
  options.near = 100.0;
  options.max_distance = 1500.0;
  options.column_crossings = true;
  const Camera camera = camera_at(dem, 75.0, 120.0, 10.0, spec_of(0.0, -10.0, 90.0, 96, 96));
  const TraceResult r = traced(dem, camera, options);
  int hits = 0;
  for (int j = 0; j < 96; ++j)
    for (int x = 0; x < 96; ++x) {
      const Hit h = r.hit(x, j);
      if (h.sky) continue;
      ++hits;
      EXPECT_LE(h.distance, 1500.0 + 1e-3);
      EXPECT_GE(h.distance, camera.near_distance(x, 100.0) - 30.0);  // the chord may start before the first crossing
      // The hit crossing never touches a void cell.
      const auto at = static_cast<std::size_t>(j * 96 + x);
      const int line = r.image.line[at];
      if (r.image.axis[at] == LineAxis::kRows) {
        const int c = static_cast<int>(std::floor(h.col));
        EXPECT_FALSE(line >= 40 && line < 60 && c >= 59 && c < 90) << x << "," << j;
      }
    }
  EXPECT_GT(hits, 1000);
}

TEST(Trace, EveryExactHitIsWhereR3FirstBlocksThePixelsRay) {
  // With column crossings the trace meets exactly R3's crossings along the
  // pixel's plane: a target just short of the hit on the ray is visible
  // under R3 (line_of_sight), one just past the hit crossing is not.
  const terrain::Dem dem = horizon::testing::make_random_terrain(180, 180, 9, 400.0, 30.0);
  TraceOptions options;
  options.column_crossings = true;
  options.near = 0.0;
  const Camera camera = camera_at(dem, 90.3, 90.6, 15.0, spec_of(123.0, -8.0, 100.0, 80, 60));
  const TraceResult r = traced(dem, camera, options);
  visibility::LosOptions los;
  los.curvature_coefficient = options.curvature_coefficient;
  int checked = 0;
  for (int j = 0; j < 60; ++j)
    for (int x = 0; x < 80; ++x) {
      const Hit h = r.hit(x, j);
      if (h.sky || h.distance < 60.0) continue;
      const double s = camera.slope(x, j), az = camera.azimuth[static_cast<std::size_t>(x)];
      auto point_at = [&](double d) {
        geodesy::GridPoint p;
        p.col = camera.eye.col + d * std::sin(az) / 30.0;
        p.row = camera.eye.row - d * std::cos(az) / 30.0;
        p.elevation = camera.eye.elevation + s * d + r.curvature * d * d;
        return p;
      };
      // Just short of the hit: nothing in between reaches the ray.
      auto before = visibility::line_of_sight(dem, camera.eye, point_at(h.distance - 1.0), los);
      ASSERT_TRUE(before.ok());
      EXPECT_GT(before->clearance, -1e-3) << x << "," << j;
      // Past the hit crossing (at most a cell beyond the hit point): blocked.
      auto past = visibility::line_of_sight(dem, camera.eye, point_at(h.distance + 45.0), los);
      ASSERT_TRUE(past.ok());
      EXPECT_FALSE(past->visible && past->clearance > 1e-3) << x << "," << j;
      ++checked;
    }
  EXPECT_GT(checked, 400);
}

TEST(Trace, TheFrameCostIsFixedByTheCameraNotTheTerrain) {
  // The same camera over flat and rough terrain of one size: the same
  // crossings, texels and reads per pixel.
  const terrain::Dem flat = horizon::testing::make_dem(
      300, 300, [](int, int) { return 50.0; }, 30.0, 0);
  const terrain::Dem rough = horizon::testing::make_random_terrain(300, 300, 4, 800.0, 30.0);
  TraceOptions options;
  const Camera a = camera_at(flat, 150.0, 290.0, 20.0, spec_of(10.0, 0.0, 70.0, 64, 64));
  Camera b = a;
  b.eye.elevation = a.eye.elevation;  // same eye height above the same grid position
  const TraceResult ra = traced(flat, a, options), rb = traced(rough, b, options);
  EXPECT_EQ(ra.stats.crossings, rb.stats.crossings);
  EXPECT_EQ(ra.stats.tree_texels, rb.stats.tree_texels);
  EXPECT_EQ(ra.stats.reads_per_pixel, rb.stats.reads_per_pixel);
  // Rows 289 .. 0 ahead of row 290: ceil(log2(290) / 2) = 5 texels, then
  // two map entries.
  EXPECT_EQ(ra.stats.max_lines, 290);
  EXPECT_EQ(ra.stats.reads_per_pixel, 5 + 2);
  EXPECT_EQ(ra.stats.crossings, 64u * 290u);
}

TEST(Trace, RejectsBadOptionsNamingTheField) {
  const terrain::Dem dem = horizon::testing::make_random_terrain(50, 50, 1);
  const Camera camera = camera_at(dem, 25, 25, 10, spec_of(0, 0, 60, 8, 8));
  const terrain::HeightView view(dem.elevation);
  auto field_of = [&](TraceOptions o) {
    auto r = trace_frame(view, camera, o);
    return r.ok() ? std::string("ok") : r.error().field;
  };
  TraceOptions o;
  o.near = -1;
  EXPECT_EQ(field_of(o), "near");
  o = {};
  o.max_distance = 0.5;
  EXPECT_EQ(field_of(o), "max_distance");
  o = {};
  o.max_distance = std::nan("");
  EXPECT_EQ(field_of(o), "max_distance");
  o = {};
  o.curvature_coefficient = 3;
  EXPECT_EQ(field_of(o), "curvature_coefficient");
  o = {};
  o.nodata = visibility::NodataPolicy::kFill;
  o.nodata_fill_height = INFINITY;
  EXPECT_EQ(field_of(o), "nodata_fill_height");
  EXPECT_EQ(field_of({}), "ok");
}

TEST(Camera, RejectsBadFieldsNamingThem) {
  geodesy::GridPoint eye;
  auto field_of = [&](CameraSpec s) {
    auto c = make_camera(s, eye, 30, 30);
    return c.ok() ? std::string("ok") : c.error().field;
  };
  EXPECT_EQ(field_of(spec_of(NAN, 0, 60, 10, 10)), "yaw");
  EXPECT_EQ(field_of(spec_of(0, 85, 60, 10, 10)), "pitch");
  EXPECT_EQ(field_of(spec_of(0, 0, 171, 10, 10)), "hfov");
  EXPECT_EQ(field_of(spec_of(0, 0, 0, 10, 10)), "hfov");
  EXPECT_EQ(field_of(spec_of(0, 0, 360, 10, 10, Projection::kCylindrical)), "ok");
  EXPECT_EQ(field_of(spec_of(0, 0, 361, 10, 10, Projection::kCylindrical)), "hfov");
  EXPECT_EQ(field_of(spec_of(0, 0, 60, 0, 10)), "width");
  EXPECT_EQ(field_of(spec_of(0, 0, 60, 10, kMaxSide + 1)), "height");
  EXPECT_EQ(field_of(spec_of(-720, 0, 60, 10, 10)), "ok");
}

TEST(Camera, PitchShiftsThePrincipalPointAndKeepsColumnsVertical) {
  geodesy::GridPoint eye;
  auto level = make_camera(spec_of(30, 0, 90, 100, 80), eye, 10, 10);
  auto up = make_camera(spec_of(30, 20, 90, 100, 80), eye, 10, 10);
  ASSERT_TRUE(level.ok() && up.ok());
  // The centre column's azimuth is the yaw whatever the pitch.
  EXPECT_NEAR(up->azimuth[50] * 180.0 / M_PI, 30.0 + std::atan(0.5 / 50.0) * 180.0 / M_PI, 1e-9);
  EXPECT_EQ(up->azimuth, level->azimuth);
  // The pixel just above the centre row looks ~20 degrees up.
  EXPECT_NEAR(std::atan(up->slope(50, 39)) * 180.0 / M_PI, 20.0, 1.0);
  EXPECT_NEAR(level->slope(50, 39), 0.5 / level->focal_col[50], 1e-12);
}

}  // namespace
}  // namespace horizon::trace
