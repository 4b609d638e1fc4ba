// What a frame gives (horizon/trace/products.hpp) and how a trace is
// planned and run on a source (horizon/trace/trace_plan.hpp), with height
// edits (horizon/terrain/height_edit.hpp).
#include "horizon/trace/products.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "horizon/terrain/geotiff_writer.hpp"
#include "horizon/terrain/height_edit.hpp"
#include "horizon/terrain/source.hpp"
#include "horizon/trace/trace_plan.hpp"
#include "test_support.hpp"
#include "trace_test_util.hpp"

namespace horizon::trace {
namespace {

using testing::camera_at;
using testing::spec_of;

TraceResult traced(const terrain::Dem& dem, const Camera& camera, const TraceOptions& options = {}) {
  auto r = trace_frame(terrain::HeightView(dem.elevation), camera, options);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().message);
  return std::move(*r);
}

// Flat ground at 0 with a 40 m wall across rows 196..197 (two cells thick),
// 10 m cells; the eye 10 m up at row 290 looks north over it.
terrain::Dem walled() {
  return horizon::testing::make_dem(
      120, 300, [](int, int r) { return r == 196 || r == 197 ? 40.0 : 0.0; }, 10.0);
}

TEST(TraceBoxes, OpenBoxesAreSeenWholeAndBoxesBehindAWallNotAtAll) {
  const terrain::Dem dem = walled();
  TraceOptions options;
  options.curvature_coefficient = 0.0;
  const Camera camera = camera_at(dem, 60.0, 290.0, 10.0, spec_of(0.0, 0.0, 40.0, 200, 100));
  const TraceResult frame = traced(dem, camera, options);
  const ViewBox boxes[] = {
      {55, 65, 240, 245, 1, 8},    // in the open, ~500 m ahead: all seen
      {55, 65, 150, 155, 0, 20},   // behind the wall, lower than its shadow: none seen
      {55, 65, 150, 155, 0, 200},  // behind the wall, towering over it: part seen
      {55, 65, 305, 310, 0, 20},   // behind the camera: not in the frame
  };
  auto views = box_views(frame, boxes, options);
  ASSERT_TRUE(views.ok());
  const std::vector<BoxView>& v = *views;
  ASSERT_EQ(v.size(), 4u);
  EXPECT_GT(v[0].pixels, 100u);
  EXPECT_EQ(v[0].visible, v[0].pixels);
  EXPECT_GT(v[1].pixels, 10u);
  EXPECT_EQ(v[1].visible, 0u);
  EXPECT_GT(v[2].visible, 0u);
  EXPECT_LT(v[2].visible, v[2].pixels);
  // The seen share is the part above the wall's shadow line: from the eye
  // (10 m) over the wall top (40 m, 930 m ahead) the shadow climbs 30/930 m
  // a metre, so at the box (~1375 m ahead) it stands ~54 m up, and pixels,
  // even in slope, see ~ (200 - 54) / 200 of the box's face.
  EXPECT_NEAR(v[2].fraction(), (200.0 - (10.0 + 30.0 / 930.0 * 1375.0)) / 200.0, 0.08);
  EXPECT_EQ(v[3].pixels, 0u);
  // The bound a plan checks before any work covers what was tested.
  const std::uint64_t bound = box_pixel_bound(camera, boxes);
  EXPECT_GE(bound, v[0].pixels + v[1].pixels + v[2].pixels);
  EXPECT_LE(bound, 4u * 200u * 100u);
}

TEST(TraceBoxes, ACancelledCallStopsBetweenBoxes) {
  const terrain::Dem dem = walled();
  const Camera camera = camera_at(dem, 60.0, 290.0, 10.0, spec_of(0.0, 0.0, 40.0, 64, 32));
  const TraceResult frame = traced(dem, camera);
  const std::vector<ViewBox> boxes(100, ViewBox{55, 65, 240, 245, 1, 8});
  CancelToken cancel;
  cancel.cancel();
  RunControl control;
  control.cancel = &cancel;
  auto v = box_views(frame, boxes, {}, &control);
  ASSERT_FALSE(v.ok());
  EXPECT_EQ(v.error().code, ErrorCode::kCancelled);
}

TEST(TraceBoxes, APanoramaSeesABoxAcrossItsSeam) {
  // A 360 degree panorama looking north has its seam due south: a box due
  // south is seen at both ends of the frame, and counted once per pixel.
  const terrain::Dem dem = horizon::testing::make_dem(
      200, 200, [](int, int) { return 0.0; }, 10.0);
  const Camera camera = camera_at(dem, 100.0, 100.0, 5.0, spec_of(0.0, 0.0, 360.0, 360, 90, Projection::kCylindrical));
  TraceOptions options;
  options.curvature_coefficient = 0.0;
  const TraceResult frame = traced(dem, camera, options);
  const ViewBox south[] = {{95, 105, 140, 150, 0, 30}};
  const BoxView v = (*box_views(frame, south, options))[0];
  EXPECT_GT(v.pixels, 50u);
  EXPECT_EQ(v.visible, v.pixels);
}

TEST(TraceProducts, DepthHitsAndFootprintAgreeWithTheHits) {
  const terrain::Dem dem = horizon::testing::make_random_terrain(160, 160, 3, 300.0, 30.0);
  const Camera camera = camera_at(dem, 80.0, 150.0, 40.0, spec_of(5.0, -5.0, 70.0, 64, 48));
  const TraceResult frame = traced(dem, camera);
  const terrain::Grid<float> depth = depth_image(frame);
  const HitImages hits = hit_images(frame, 1000, 2000);
  const terrain::Grid<std::uint8_t> seen = footprint(frame, terrain::HeightView(dem.elevation));
  int ground = 0;
  double error2 = 0.0;
  for (int j = 0; j < 48; ++j)
    for (int x = 0; x < 64; ++x) {
      const Hit h = frame.hit(x, j);
      if (h.sky) {
        EXPECT_TRUE(std::isnan(depth.at(x, j)));
        EXPECT_TRUE(std::isnan(hits.col.at(x, j)));
        continue;
      }
      ++ground;
      EXPECT_FLOAT_EQ(depth.at(x, j), static_cast<float>(h.range));
      EXPECT_GE(h.range, h.distance);
      EXPECT_FLOAT_EQ(hits.col.at(x, j), static_cast<float>(h.col + 1000));
      EXPECT_FLOAT_EQ(hits.row.at(x, j), static_cast<float>(h.row + 2000));
      // The hit lies on the chord between two crossings, near the bilinear surface.
      const double e = h.elevation - terrain::sample_bilinear(dem.elevation, h.col, h.row);
      EXPECT_LT(std::abs(e), 30.0) << x << "," << j;
      error2 += e * e;
      EXPECT_EQ(seen.at(static_cast<int>(std::lround(h.col)), static_cast<int>(std::lround(h.row))), 1);
    }
  EXPECT_GT(ground, 1000);
  EXPECT_LT(std::sqrt(error2 / ground), 2.0);
  // Nothing behind the camera is seen.
  for (int r = 152; r < 160; ++r)
    for (int c = 0; c < 160; ++c) EXPECT_EQ(seen.at(c, r), 0) << c << "," << r;
}

TEST(TraceProducts, TheShadedViewIsSkyAboveTheHorizonAndTerrainBelow) {
  const terrain::Dem dem = horizon::testing::make_dem(
      100, 200, [](int, int) { return 0.0; }, 10.0);
  TraceOptions options;
  options.curvature_coefficient = 0.0;
  const Camera camera = camera_at(dem, 50.0, 195.0, 10.0, spec_of(0.0, 0.0, 40.0, 40, 40));
  const TraceResult frame = traced(dem, camera, options);
  const std::vector<std::uint8_t> rgb = shaded_view(frame, terrain::HeightView(dem.elevation));
  ASSERT_EQ(rgb.size(), 40u * 40u * 3u);
  auto pixel = [&](int x, int j) { return &rgb[3 * (static_cast<std::size_t>(j) * 40 + x)]; };
  // Top row: sky, bluer than red. Bottom row: near ground, greener than blue.
  EXPECT_GT(pixel(20, 0)[2], pixel(20, 0)[0]);
  EXPECT_GT(pixel(20, 39)[1], pixel(20, 39)[2]);
}

TEST(HeightEdits, ApplyInOrderToTheCellsReadAndAreCheckedFirst) {
  terrain::Dem dem = horizon::testing::make_dem(
      10, 10, [](int c, int r) { return c + 10.0 * r; }, 10.0);
  dem.elevation.at(2, 2) = std::numeric_limits<float>::quiet_NaN();  // source cell (7, 7)
  // The Dem is the window (5, 5)..(10, 10) of a 20 x 20 source.
  const terrain::HeightEdit edits[] = {
      {{4, 4, 7, 7}, {100.0f}, terrain::EditMode::kSet},                    // partly outside the window
      {{6, 6, 8, 8}, {1.0f, 2.0f, 3.0f, 4.0f}, terrain::EditMode::kRaise},  // per cell, over a void
  };
  ASSERT_TRUE(terrain::validate_edits(edits, 20, 20).ok());
  terrain::Dem before = dem;
  const std::uint64_t changed = terrain::apply_edits(dem, 5, 5, edits);
  EXPECT_EQ(changed, 4u + 4u);                                          // (5..6)^2 of the first, (6..7)^2 of the second
  EXPECT_EQ(dem.elevation.at(0, 0), 100.0f);                            // source cell (5, 5): set
  EXPECT_EQ(dem.elevation.at(1, 1), 101.0f);                            // (6, 6): set, then +1
  EXPECT_EQ(dem.elevation.at(2, 1), before.elevation.at(2, 1) + 2.0f);  // (7, 6): +2
  EXPECT_TRUE(std::isnan(dem.elevation.at(2, 2)));                      // (7, 7): a void stays a void
  EXPECT_EQ(dem.elevation.at(3, 3), before.elevation.at(3, 3));         // untouched

  auto field_of = [](std::vector<terrain::HeightEdit> e) {
    Status s = terrain::validate_edits(e, 20, 20);
    return s.ok() ? std::string("ok") : s.error().field;
  };
  EXPECT_EQ(field_of({{{15, 15, 25, 16}, {1.0f}, terrain::EditMode::kSet}}), "edits[0].cells");
  EXPECT_EQ(field_of({{{3, 3, 3, 5}, {1.0f}, terrain::EditMode::kSet}}), "edits[0].cells");
  EXPECT_EQ(field_of({{{0, 0, 1, 1}, {1.0f}, terrain::EditMode::kSet},
                      {{0, 0, 2, 2}, {1.0f, 2.0f}, terrain::EditMode::kSet}}),
            "edits[1].heights");
  EXPECT_EQ(field_of({{{0, 0, 1, 1}, {NAN}, terrain::EditMode::kSet}}), "edits[0].heights");
}

// A source on disk for the plan tests.
struct SourceFile {
  horizon::testing::TempDir dir;
  std::string path;
  std::shared_ptr<const terrain::ElevationSource> source;
  explicit SourceFile(const terrain::Dem& dem) : path(dir.file("dem.tif")) {
    EXPECT_TRUE(terrain::write_geotiff(path, dem.elevation, dem.georef, std::nullopt).ok());
    auto s = terrain::ElevationSource::open(path);
    EXPECT_TRUE(s.ok());
    source = *s;
  }
};

TraceQuery query_at(const terrain::Dem& dem, double col, double row, double height, const CameraSpec& spec) {
  TraceQuery q;
  q.camera = spec;
  q.camera.position.x = dem.georef.transform.x_at(col);
  q.camera.position.y = dem.georef.transform.y_at(row);
  q.camera.position.height = height;
  return q;
}

TEST(TracePlan, ReadsOnlyTheWedgeAndAnswersAsTheWholeDem) {
  const terrain::Dem dem = horizon::testing::make_random_terrain(300, 300, 8, 400.0, 30.0);
  terrain::Dem utm = dem;
  utm.georef.epsg = 32633;
  utm.georef.transform = {500000.0, 30.0, 5000000.0, -30.0};
  SourceFile file(utm);
  // Looking north-east with a 40 degree lens from the south-west quarter.
  TraceQuery q = query_at(utm, 100.0, 200.0, 30.0, spec_of(45.0, -2.0, 40.0, 96, 64));
  auto plan = plan_trace(*file.source, q);
  ASSERT_TRUE(plan.ok()) << plan.error().message;
  // The wedge NE of the eye: nothing west of col ~96 or south of row ~202.
  EXPECT_GE(plan->read.col0, 95);
  EXPECT_LE(plan->read.row1, 204);
  EXPECT_LT(plan->cost.read_cells, 300u * 300u / 2u);
  EXPECT_EQ(plan->cost.pixels, 96u * 64u);
  auto run = run_trace(*plan, *file.source, nullptr);
  ASSERT_TRUE(run.ok()) << run.error().message;
  EXPECT_EQ(run->window, plan->read);

  // The same frame traced over the whole DEM: the same crossings, the same
  // hits, up to float rounding of positions taken from another corner.
  auto whole = resolve_camera(utm, q.camera);
  ASSERT_TRUE(whole.ok());
  const TraceResult reference = traced(utm, *whole);
  int different = 0, hits = 0;
  for (std::size_t i = 0; i < reference.image.distance.size(); ++i) {
    const int x = static_cast<int>(i % 96), j = static_cast<int>(i / 96);
    const Hit a = run->frame.hit(x, j), b = reference.hit(x, j);
    hits += !b.sky;
    if (a.sky != b.sky || (!a.sky && (std::abs(a.col + run->window.col0 - b.col) > 1e-3 ||
                                      std::abs(a.row + run->window.row0 - b.row) > 1e-3)))
      ++different;
  }
  EXPECT_GT(hits, 3000);
  EXPECT_LE(different, hits / 200);
}

TEST(TracePlan, AHugeYawIsPlannedAsTheSameTurnOfTheCompass) {
  // Regression (fuzz_requests, 2026-12-06): a yaw of 1e20 degrees is finite,
  // but adding a quarter turn to it changes nothing, and the wedge's walk
  // over the compass points it spans never ended. A whole number of turns
  // added to a yaw reads the same wedge (to the rounding of the angle).
  terrain::Dem dem = horizon::testing::make_random_terrain(200, 200, 8, 400.0, 30.0);
  dem.georef.epsg = 32633;
  dem.georef.transform = {500000.0, 30.0, 5000000.0, -30.0};
  SourceFile file(dem);
  auto base = plan_trace(*file.source, query_at(dem, 100.0, 100.0, 30.0, spec_of(45.0, -2.0, 40.0, 96, 64)));
  ASSERT_TRUE(base.ok()) << base.error().message;
  auto turned = plan_trace(*file.source, query_at(dem, 100.0, 100.0, 30.0, spec_of(45.0 + 3600.0, -2.0, 40.0, 96, 64)));
  ASSERT_TRUE(turned.ok()) << turned.error().message;
  EXPECT_EQ(turned->read, base->read);
  auto huge = plan_trace(*file.source, query_at(dem, 100.0, 100.0, 30.0, spec_of(1e20, -2.0, 40.0, 96, 64)));
  ASSERT_TRUE(huge.ok()) << huge.error().message;
  EXPECT_GE(huge->read.col0, 0);
  EXPECT_LE(huge->read.col1, 200);
  EXPECT_GT(huge->cost.read_cells, 0u);
}

TEST(TracePlan, AnEditShowsInTheNextFrameWithNothingRebuilt) {
  const terrain::Dem dem = horizon::testing::make_dem(
      100, 300, [](int, int) { return 0.0; }, 10.0);
  SourceFile file(dem);
  TraceQuery q = query_at(dem, 50.0, 290.0, 10.0, spec_of(0.0, 0.0, 40.0, 48, 48));
  q.options.curvature_coefficient = 0.0;
  auto plain = run_trace(*plan_trace(*file.source, q), *file.source, nullptr);
  ASSERT_TRUE(plain.ok());
  // A 30 m berm across rows 200..201: the ground behind it disappears.
  q.edits.push_back({{0, 200, 100, 202}, {30.0f}, terrain::EditMode::kSet});
  auto plan = plan_trace(*file.source, q);
  ASSERT_TRUE(plan.ok());
  EXPECT_EQ(plan->cost.edit_cells, 200u);
  auto edited = run_trace(*plan, *file.source, nullptr);
  ASSERT_TRUE(edited.ok());
  EXPECT_EQ(edited->edited_cells, 200u);
  // The same work, and the berm now stops rays that went on before.
  EXPECT_EQ(edited->frame.stats.crossings, plain->frame.stats.crossings);
  int stopped = 0;
  for (std::size_t i = 0; i < plain->frame.image.line.size(); ++i) {
    const int before = plain->frame.image.line[i], after = edited->frame.image.line[i];
    if (before >= 0 && before < 200) {
      EXPECT_GE(after, 200) << i;  // rows are numbered north-down: ahead of the berm means < 200
      ++stopped;
    }
  }
  EXPECT_GT(stopped, 30);
  // The frame is what a DEM with the berm built in gives.
  terrain::Dem bermed = dem;
  for (int r = 200; r < 202; ++r)
    for (int c = 0; c < 100; ++c) bermed.elevation.at(c, r) = 30.0f;
  const TraceResult fresh = traced(bermed, camera_at(bermed, 50.0, 290.0, 10.0, q.camera), q.options);
  EXPECT_EQ(fresh.image.line, edited->frame.image.line);
}

TEST(TracePlan, RejectsBadQueriesNamingTheField) {
  const terrain::Dem dem = horizon::testing::make_dem(
      50, 50, [](int, int) { return 0.0; }, 10.0);
  SourceFile file(dem);
  auto field_of = [&](const TraceQuery& q) {
    auto p = plan_trace(*file.source, q);
    return p.ok() ? std::string("ok") : p.error().field;
  };
  const TraceQuery good = query_at(dem, 25, 25, 2, spec_of(0, 0, 60, 32, 32));
  EXPECT_EQ(field_of(good), "ok");
  TraceQuery q = good;
  q.camera.hfov = 180;
  EXPECT_EQ(field_of(q), "camera.hfov");
  q = good;
  q.camera.position.x = 0;  // far west of the DEM
  EXPECT_EQ(field_of(q), "camera.position");
  q = good;
  q.options.near = -1;
  EXPECT_EQ(field_of(q), "near");
  q = good;
  q.boxes.push_back({geodesy::PointFrame::kDatasetCrs, 500100, 4999700, 500200, 4999800, 10, 5});
  EXPECT_EQ(field_of(q), "boxes[0].z_max");
  q = good;
  q.edits.push_back({{40, 40, 60, 45}, {1.0f}, terrain::EditMode::kSet});
  EXPECT_EQ(field_of(q), "edits[0].cells");
  // Too many box-pixel tests: refused from the plan, before any work.
  q = good;
  q.camera.width = q.camera.height = 8192;
  q.camera.hfov = 170;
  for (int i = 0; i < 20; ++i)
    q.boxes.push_back({geodesy::PointFrame::kDatasetCrs, 500000, 4999500, 500500, 5000000, 0, 10});
  auto p = plan_trace(*file.source, q);
  ASSERT_FALSE(p.ok());
  EXPECT_EQ(p.error().code, ErrorCode::kResourceExhausted);
  EXPECT_EQ(p.error().field, "boxes");
}

}  // namespace
}  // namespace horizon::trace
