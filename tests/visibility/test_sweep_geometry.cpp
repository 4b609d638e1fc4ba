// The radial sweep's geometry (core/src/visibility/sweep_geometry.hpp), which
// the CPU sweep and its GL form both take their sectors, rays and per-line
// tables from: every window cell but the eye's has exactly one owning
// sector, a cell's two rays bracket it, the ray table runs over [-1, 1], and
// the tables the GL form uploads (radial_sweep_gl_disk.hpp) are these, bit
// for bit, with as many rays as the CPU sweep marches.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <vector>

#include "horizon/visibility/radial_sweep.hpp"
#include "radial_sweep_gl_disk.hpp"
#include "sweep_geometry.hpp"

namespace horizon::visibility::sweep {
namespace {

// A frame over a 40 x 30 DEM: the window [5, 37) x [3, 27), the eye at
// (col, row), 30 m x 20 m cells, curvature on.
ViewFrame frame_at(double col, double row) {
  ViewFrame f;
  f.observer_col = col;
  f.observer_row = row;
  f.eye = 812.5;
  f.metres_per_col = 30.0;
  f.metres_per_row = 20.0;
  f.curvature = 0.85714 / (2.0 * 6371000.0);
  f.max_distance = INFINITY;
  f.window = {5, 3, 37, 27};
  f.dem_width = 40;
  f.dem_height = 30;
  return f;
}

// Eyes off-centre, on a cell centre, on grid lines, at the window's edges.
const std::vector<std::pair<double, double>> kEyes = {{20.3, 14.6}, {20.0, 14.0}, {5.0, 3.0}, {36.0, 26.0},
                                                      {11.5, 20.0}, {30.0, 7.25}, {5.4, 26.9}};

bool owns(const SectorLines& s, int col, int row) {
  const int u = s.axis.rows ? row : col, v = (s.axis.rows ? col : row) - s.v0;
  const int n = (u - s.line0) * s.axis.dir;
  if (n < 0 || n >= s.lines) return false;
  const CellSpan span = wedge(s.eye_v, s.step(n), s.include_diagonal);
  return v >= span.lo && v <= span.hi;
}

TEST(SweepGeometry, EveryWindowCellButTheEyesHasOneOwningSector) {
  for (const auto& [ec, er] : kEyes) {
    const ViewFrame f = frame_at(ec, er);
    std::vector<SectorLines> sectors;
    for (const SectorAxis axis : kSectorOrder) sectors.push_back(sector_lines(f, axis));
    for (int row = f.window.row0; row < f.window.row1; ++row)
      for (int col = f.window.col0; col < f.window.col1; ++col) {
        int owners = 0;
        for (const SectorLines& s : sectors) owners += owns(s, col, row);
        const bool eye_cell = col == ec && row == er;
        EXPECT_EQ(owners, eye_cell ? 0 : 1) << "cell " << col << "," << row << ", eye " << ec << "," << er;
      }
  }
}

TEST(SweepGeometry, TheFirstLineLiesPastTheEyeAndTheLastOnTheWindowEdge) {
  const ViewFrame f = frame_at(20.3, 14.6);
  const SectorLines north = sector_lines(f, kSectorOrder[0]), south = sector_lines(f, kSectorOrder[1]);
  const SectorLines east = sector_lines(f, kSectorOrder[2]), west = sector_lines(f, kSectorOrder[3]);
  EXPECT_EQ(north.line0, 14);
  EXPECT_DOUBLE_EQ(north.k0, 14.6 - 14);
  EXPECT_EQ(north.lines, 14 - 3 + 1);
  EXPECT_EQ(south.line0, 15);
  EXPECT_DOUBLE_EQ(south.k0, 15 - 14.6);
  EXPECT_EQ(south.lines, 27 - 15);
  EXPECT_EQ(east.line0, 21);
  EXPECT_EQ(east.lines, 37 - 21);
  EXPECT_EQ(west.line0, 20);
  EXPECT_EQ(west.lines, 20 - 5 + 1);
  // v counted from the window's first v line; metres swap with the axis.
  EXPECT_DOUBLE_EQ(north.eye_v, 20.3 - 5);
  EXPECT_DOUBLE_EQ(east.eye_v, 14.6 - 3);
  EXPECT_EQ(north.metres_u, 20.0);
  EXPECT_EQ(east.metres_u, 30.0);
  EXPECT_TRUE(north.include_diagonal);
  EXPECT_FALSE(east.include_diagonal);
}

TEST(SweepGeometry, TheRayTableRunsOverMinusOneToOneSymmetrically) {
  const double curvature = 0.85714 / (2.0 * 6371000.0);
  for (const int half : {1, 2, 7, 64}) {
    const RayTable t = ray_table(half, 20.0, 30.0, curvature);
    ASSERT_EQ(t.count(), 2 * half + 1);
    ASSERT_EQ(t.slope.size(), static_cast<std::size_t>(t.count()));
    EXPECT_EQ(t.slope.front(), -1.0f);
    EXPECT_EQ(t.slope.back(), 1.0f);
    EXPECT_EQ(t.slope[half], 0.0f);
    EXPECT_EQ(t.inv_slope[half], 0.0f);
    for (int i = 0; i < t.count(); ++i) {
      EXPECT_EQ(t.slope[i], -t.slope[2 * half - i]);
      EXPECT_EQ(t.curv_k[i], t.curv_k[2 * half - i]);
      if (i != half) {
        EXPECT_NEAR(t.inv_slope[i] * t.slope[i], 1.0f, 1e-6f);
      }
      const double m = t.slope[i];
      EXPECT_NEAR(t.curv_k[i], curvature * (400.0 + m * m * 900.0), 1e-6 * curvature * 1300.0);
    }
  }
  EXPECT_EQ(ray_half(10.5, 1.0), 11);
  EXPECT_EQ(ray_half(10.5, 1.0, 4), 12);  // a multiple of the quantum
  EXPECT_EQ(ray_half(0.2, 1.0), 1);       // never fewer than three rays
}

TEST(SweepGeometry, ACellsTwoRaysBracketIt) {
  for (const auto& [ec, er] : kEyes) {
    const ViewFrame f = frame_at(ec, er);
    for (const SectorAxis axis : kSectorOrder) {
      const SectorLines s = sector_lines(f, axis);
      if (s.lines <= 0) continue;
      const int half = ray_half(s.step(s.lines - 1), 1.0);
      const RayTable t = ray_table(half, s.metres_u, s.metres_v, f.curvature);
      for (int n = 0; n < s.lines; ++n) {
        const double k = s.step(n);
        const CellSpan span = wedge(s.eye_v, k, s.include_diagonal);
        for (int j = span.lo; j <= span.hi; ++j) {
          const double rho = ray_coordinate(j, s.eye_v, 1.0 / k, half);
          const int r = lower_ray(rho, half);
          ASSERT_GE(r, -half);
          ASSERT_LT(r, half);
          const double dv = j - s.eye_v;
          EXPECT_LE(t.slope[r + half] * k, dv + 1e-5 * k) << "cell " << j << " at step " << k;
          EXPECT_GE(t.slope[r + 1 + half] * k, dv - 1e-5 * k) << "cell " << j << " at step " << k;
          EXPECT_GE(rho - r, -1e-12);
          EXPECT_LE(rho - r, 1.0 + 1e-12);
        }
      }
    }
  }
}

bool same_bits(float a, float b) {
  return std::memcmp(&a, &b, sizeof a) == 0;
}

// The GL form's upload is the shared geometry, and it has the CPU sweep's rays.
TEST(SweepGeometry, TheGlFormUploadsTheSharedTables) {
  for (const auto& [ec, er] : kEyes) {
    const ViewFrame f = frame_at(ec, er);
    for (const double spacing : {1.0, 0.5, 2.0}) {
      const gl::DiskPlan disk = gl::plan_disk(f, spacing);
      int rows = 0;
      ASSERT_EQ(disk.gpu_sectors.size(), disk.sectors.size());
      for (std::size_t i = 0; i < disk.sectors.size(); ++i) {
        const gl::DiskSector& d = disk.sectors[i];
        const gl::GpuSector& g = disk.gpu_sectors[i];
        const SectorLines& s = d.lines;
        ASSERT_GT(s.lines, 0);
        EXPECT_EQ(d.base, rows);
        EXPECT_EQ(d.ray_half, ray_half(s.step(s.lines - 1), spacing));
        rows += 2 * d.ray_half + 1;
        const RayTable t = ray_table(d.ray_half, s.metres_u, s.metres_v, f.curvature);
        for (int r = 0; r < t.count(); ++r) {
          const std::size_t row = static_cast<std::size_t>(d.base + r);
          EXPECT_TRUE(same_bits(disk.table[row], t.slope[r]));
          EXPECT_TRUE(same_bits(disk.table[disk.rows + row], t.inv_slope[r]));
          EXPECT_TRUE(same_bits(disk.table[2 * disk.rows + row], t.curv_k[r]));
        }
        const std::vector<float> inv_step = inv_steps(s.k0, s.lines);
        EXPECT_EQ(disk.doubles[g.d_at], s.eye_v);
        for (int n = 0; n < s.lines; ++n) {
          const std::size_t at = static_cast<std::size_t>(g.steps_at + 6 * n);
          EXPECT_TRUE(same_bits(disk.table[at], static_cast<float>(s.step(n))));
          EXPECT_TRUE(same_bits(disk.table[at + 3], inv_step[n]));
          const CellSpan span = owned_cells(f, s, n);
          EXPECT_EQ(disk.table[at + 4], span.lo);
          EXPECT_EQ(disk.table[at + 5], span.hi);
          EXPECT_EQ(disk.doubles[g.d_at + 1 + n], 1.0 / s.step(n));
        }
        const std::vector<float> inv_dv = inv_dvs(s.eye_v, d.v_count);
        for (int v = 0; v < d.v_count; ++v) EXPECT_TRUE(same_bits(disk.table[g.dv_at + v], inv_dv[v]));
        EXPECT_EQ(g.line0, s.line0 - s.u0);
        EXPECT_EQ(g.k0, static_cast<float>(s.k0));
        EXPECT_EQ(g.eye_v, static_cast<float>(s.eye_v));
      }
      EXPECT_EQ(disk.rows, rows);
      // The CPU sweep (no thinning) marches the same number of rays.
      const terrain::Grid<float> z(f.dem_width, f.dem_height, 100.0f);
      terrain::Grid<float> ohf;
      WorkStats stats;
      RadialOptions radial;
      radial.ray_spacing = spacing;
      radial.thinning_levels = 0;
      ASSERT_TRUE(radial_ohf(z, f, radial, 1, nullptr, ohf, stats).ok());
      EXPECT_EQ(stats.rays, static_cast<std::uint64_t>(disk.rows)) << "eye " << ec << "," << er;
    }
  }
}

}  // namespace
}  // namespace horizon::visibility::sweep
