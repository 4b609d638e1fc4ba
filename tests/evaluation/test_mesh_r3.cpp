// The TIN cull against R3 on the source DEM (evaluation/mesh_r3.hpp, and
// its columns of `horizon bench --mesh`): a wall across flat ground hides
// exactly the cells behind it, counted by hand, from either side, from its
// top, in a projected and in a geographic DEM; count_cells on a grid filled
// by hand; and the bench's R3 columns on the wall DEM, camera by camera.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "horizon/evaluation/mesh_bench.hpp"
#include "horizon/evaluation/mesh_r3.hpp"
#include "horizon/mesh/tin_from_dem.hpp"
#include "horizon/mesh/tin_raster.hpp"
#include "horizon/terrain/dem_reader.hpp"
#include "horizon/terrain/geotiff_writer.hpp"
#include "horizon/visibility/viewshed.hpp"
#include "test_support.hpp"

namespace horizon::evaluation {
namespace {

constexpr int kWidth = 24, kHeight = 16, kWall = 9;
constexpr double kWallHeight = 50.0;

// Flat ground at 0 m with a wall 50 m high along column kWall. From an eye
// 2 m above the ground on one side, every sight line to a cell on the other
// side crosses the wall's grid line (50 m) and is stopped; every cell on the
// eye's side and the wall itself are seen (the ground is flat, and the wall's
// face rises faster than any sight line to it). From the wall's top (52 m)
// everything is seen.
terrain::Dem wall_dem(bool geographic) {
  terrain::Dem dem = testing::make_dem(kWidth, kHeight, [](int c, int) { return c == kWall ? kWallHeight : 0.0; });
  if (geographic) {
    dem.georef.transform = {-121.8, 0.0005, 46.9, -0.0005};
    dem.georef.epsg = 4326;
  }
  return dem;
}

// Hidden cells, by hand, for an eye on the ground of column `col` (or on the wall).
int hand_hidden(int col) {
  if (col < kWall) return (kWidth - kWall - 1) * kHeight;  // the columns east of the wall
  if (col > kWall) return kWall * kHeight;                 // the columns west of it
  return 0;
}

class WallDem : public ::testing::TestWithParam<bool> {};

TEST_P(WallDem, R3HidesExactlyTheCellsBehindTheWall) {
  const terrain::Dem dem = wall_dem(GetParam());
  const terrain::GeoTransform& g = dem.georef.transform;
  struct Eye {
    int col, row;
  };
  for (Eye e : std::vector<Eye>{{3, 7}, {0, 0}, {8, 15}, {20, 5}, {10, 0}, {23, 15}, {kWall, 8}, {kWall, 0}}) {
    const double ground = e.col == kWall ? kWallHeight : 0.0;
    auto seen = r3_ground_viewshed(dem, {g.x_at(e.col), g.y_at(e.row), ground + 2.0}, 2);
    ASSERT_TRUE(seen.ok()) << seen.error().message;
    ASSERT_EQ(seen->width(), kWidth);
    ASSERT_EQ(seen->height(), kHeight);
    int hidden = 0;
    for (int r = 0; r < kHeight; ++r)
      for (int c = 0; c < kWidth; ++c) {
        const bool behind = (e.col < kWall && c > kWall) || (e.col > kWall && c < kWall);
        EXPECT_EQ(seen->at(c, r), behind ? visibility::kHidden : visibility::kVisible)
            << "eye " << e.col << ',' << e.row << " cell " << c << ',' << r;
        hidden += seen->at(c, r) == visibility::kHidden ? 1 : 0;
      }
    EXPECT_EQ(hidden, hand_hidden(e.col)) << "eye " << e.col << ',' << e.row;
  }
}

TEST(MeshR3, RejectsAnEyeOffTheDem) {
  const terrain::Dem dem = wall_dem(false);
  const terrain::GeoTransform& g = dem.georef.transform;
  auto seen = r3_ground_viewshed(dem, {g.x_at(-5), g.y_at(3), 10.0}, 1);
  ASSERT_FALSE(seen.ok());
  EXPECT_EQ(seen.error().code, ErrorCode::kOutOfRange);
}

TEST(MeshR3, CountCellsByHand) {
  // 3 x 2 cells: triangles 0, 1, 2 and one cell with none; R3 hides two cells
  // and has no answer for one; triangles 1 and 2 culled.
  terrain::Grid<std::uint32_t> triangle(3, 2);
  const std::uint32_t t[2][3] = {{0, 0, 1}, {2, mesh::kNoTriangle, 1}};
  terrain::Grid<std::uint8_t> r3(3, 2);
  const std::uint8_t v[2][3] = {{visibility::kVisible, visibility::kHidden, visibility::kVisible},
                                {visibility::kHidden, visibility::kHidden, visibility::kNoAnswer}};
  for (int r = 0; r < 2; ++r)
    for (int c = 0; c < 3; ++c) triangle.at(c, r) = t[r][c], r3.at(c, r) = v[r][c];
  const R3CellCounts n = count_cells(triangle, r3, {0, 1, 1});
  // Counted: (0,0) visible, (1,0) hidden, (2,0) visible culled, (0,1) hidden
  // culled; (1,1) has no triangle, (2,1) no answer.
  EXPECT_EQ(n.cells, 4u);
  EXPECT_EQ(n.r3_hidden, 2u);
  EXPECT_EQ(n.culled, 2u);
  EXPECT_EQ(n.culled_r3_visible, 1u);
}

// The bench's R3 columns on the wall DEM: with cameras 2 m above the
// ground, the hand count of each camera's side; 1 km above it, every
// sight line clears the wall (no camera is more than 15 columns from the
// first cell past the wall, so a sight line meets the wall's line at
// least 1000 m / 15 = 67 m up) and nothing is hidden. The TIN's cameras
// are found as the bench finds them.
TEST_P(WallDem, TheBenchCountsWhatR3HidesCameraByCamera) {
  const testing::TempDir dir;
  const terrain::Dem dem = wall_dem(GetParam());
  const std::string path = dir.file("wall.tif");
  ASSERT_TRUE(terrain::write_geotiff(path, dem.elevation, dem.georef, std::nullopt).ok());
  MeshBenchConfig config;
  config.dems = {path};
  config.vertices = 1000;  // more than the cells: greedy insertion stops when the TIN is exact
  config.shapes = {{8, 2}};
  config.seeds = 8, config.max_groups = 20;
  config.cameras = 12, config.cull_repeats = 1, config.exact_cameras = 12;
  config.threads = 2;
  config.high_eye = 0;  // every camera low: the hand count is for eyes `height` above the ground

  auto read = terrain::read_dem(path);
  ASSERT_TRUE(read.ok()) << read.error().message;
  auto tin = mesh::tin_from_dem(*read, {config.vertices, 0.0});
  ASSERT_TRUE(tin.ok()) << tin.error().message;
  std::uint64_t hidden = 0;
  int sides[3] = {0, 0, 0};
  std::vector<double> z;
  for (const mesh::TinVertex& p : tin->tin.vertices) z.push_back(p.z);
  for (const MeshBenchCamera& camera : mesh_bench_cameras(z, config.cameras, config.height, config.high_eye)) {
    const std::uint32_t v = camera.vertex;
    const double col = read->georef.transform.col_at(tin->tin.vertices[v].x);
    const int c = static_cast<int>(std::lround(col));
    ASSERT_NEAR(col, c, 1e-6);  // vertices are cell centres
    hidden += static_cast<std::uint64_t>(hand_hidden(c));
    ++sides[c < kWall ? 0 : c > kWall ? 2 : 1];
  }
  EXPECT_GT(sides[0], 0);  // both sides have cameras: a camera on the wrong side would show
  EXPECT_GT(sides[2], 0);

  for (double height : {2.0, 1000.0}) {
    SCOPED_TRACE(height);
    config.height = height;
    auto report = run_mesh_bench(config);
    ASSERT_TRUE(report.ok()) << report.error().message;
    ASSERT_EQ(report->rows.size(), 2u);  // approximate, conservative
    for (const MeshBenchRow& row : report->rows) {
      SCOPED_TRACE(row.mode);
      // The TIN's corners are the DEM's: every cell is under a triangle.
      EXPECT_EQ(row.r3_cells, static_cast<std::uint64_t>(config.exact_cameras) * kWidth * kHeight);
      EXPECT_EQ(row.r3_hidden, height == 2.0 ? hidden : 0u);
      EXPECT_LE(row.r3_culled_visible, row.r3_culled);
      EXPECT_LE(row.r3_culled_visible, row.r3_cells - row.r3_hidden);
      if (row.culled_checked == 0) {
        EXPECT_EQ(row.r3_culled, 0u);  // no triangle culled, no cell under one
      }
    }
    // The outputs carry the new columns.
    EXPECT_NE(report->csv().find("r3_cells,r3_hidden,r3_culled,r3_culled_visible\n"), std::string::npos);
    EXPECT_NE(report->markdown().find("| R3 hidden | culled cells | culled but R3-visible |"), std::string::npos);
  }
}

std::string frame_name(const ::testing::TestParamInfo<bool>& p) {
  return p.param ? "Geographic" : "Projected";
}
INSTANTIATE_TEST_SUITE_P(MeshR3, WallDem, ::testing::Values(false, true), frame_name);

// The cameras come in turn from the valleys, the slopes, the ridges and
// high above: each from its band of the vertices sorted by height.
TEST(MeshBenchCameras, EachKindStandsInItsBand) {
  std::vector<double> z(1000);
  for (std::size_t v = 0; v < z.size(); ++v) z[v] = static_cast<double>((v * 7919) % 1000);  // a shuffle of 0..999
  const auto cameras = mesh_bench_cameras(z, 400, 2.0, 300.0);
  ASSERT_EQ(cameras.size(), 400u);
  int high_below_median = 0;
  for (std::size_t c = 0; c < cameras.size(); ++c) {
    const MeshBenchCamera& cam = cameras[c];
    const double h = z[cam.vertex];
    ASSERT_EQ(static_cast<std::size_t>(cam.kind), c % 4);
    switch (cam.kind) {
      case CameraKind::kValley:
        EXPECT_LT(h, 100.0);
        break;
      case CameraKind::kSlope:
        EXPECT_GE(h, 300.0);
        EXPECT_LT(h, 700.0);
        break;
      case CameraKind::kRidge:
        EXPECT_GE(h, 900.0);
        break;
      case CameraKind::kHigh:
        high_below_median += h < 500.0 ? 1 : 0;
        break;
    }
    EXPECT_EQ(cam.height, cam.kind == CameraKind::kHigh ? 302.0 : 2.0);
  }
  EXPECT_GT(high_below_median, 20);  // the high cameras stand anywhere
  EXPECT_LT(high_below_median, 80);
  // Fixed seed: the same draw every time.
  EXPECT_EQ(mesh_bench_cameras(z, 400, 2.0, 300.0)[37].vertex, cameras[37].vertex);
}

}  // namespace
}  // namespace horizon::evaluation
