// Tests for mesh/tin_raster.cpp (cell_triangles): a two-triangle TIN whose
// cells are listed by hand, cells outside a partial TIN, a triangle hanging
// off the grid, and, on TINs built from DEMs, every cell given exactly one
// triangle: one that holds its centre, the last that does by brute force.
#include <gtest/gtest.h>

#include <vector>

#include "horizon/mesh/tin_from_dem.hpp"
#include "horizon/mesh/tin_raster.hpp"
#include "test_support.hpp"

namespace horizon::mesh {
namespace {

// A 4 x 3 grid's corner centres, (0,0) (3,0) (3,2) (0,2) in grid terms,
// as CRS points of `dem`.
std::vector<TinVertex> corners(const terrain::Dem& dem) {
  const terrain::GeoTransform& g = dem.georef.transform;
  return {{g.x_at(0), g.y_at(0), 0}, {g.x_at(3), g.y_at(0), 0}, {g.x_at(3), g.y_at(2), 0}, {g.x_at(0), g.y_at(2), 0}};
}

TEST(TinRaster, TwoTrianglesSplitTheGridAlongTheirDiagonal) {
  const terrain::Dem dem = testing::make_dem(4, 3, [](int, int) { return 0.0; });
  // Triangle 0 holds the cells above the diagonal (0,0)-(3,2), row <= 2 col / 3;
  // triangle 1 the rest; the diagonal's cells, (0,0) and (3,2), are in both and
  // go to the later one.
  const auto grid = cell_triangles(dem.georef.transform, 4, 3, corners(dem), {{0, 1, 2}, {0, 2, 3}});
  const std::uint32_t expected[3][4] = {{1, 0, 0, 0}, {1, 1, 0, 0}, {1, 1, 1, 1}};
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) EXPECT_EQ(grid.at(c, r), expected[r][c]) << c << ',' << r;
}

TEST(TinRaster, CellsOutsideThePartialTinHaveNoTriangle) {
  const terrain::Dem dem = testing::make_dem(4, 3, [](int, int) { return 0.0; });
  // Only triangle (0,0) (3,0) (3,2): the five cells above the diagonal and its
  // two ends.
  const auto grid = cell_triangles(dem.georef.transform, 4, 3, corners(dem), {{0, 1, 2}});
  int inside = 0;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) {
      const bool above = 3 * r <= 2 * c;
      EXPECT_EQ(grid.at(c, r), above ? 0u : kNoTriangle) << c << ',' << r;
      inside += above ? 1 : 0;
    }
  EXPECT_EQ(inside, 7);
}

TEST(TinRaster, ATriangleOffTheGridIsClipped) {
  const terrain::Dem dem = testing::make_dem(5, 5, [](int, int) { return 0.0; });
  const terrain::GeoTransform& g = dem.georef.transform;
  // A right triangle from cell (2,2) out to (1e6, 2) and (2, 1e6): the cells
  // with col >= 2 and row >= 2, the rest none.
  const std::vector<TinVertex> v = {
      {g.x_at(2), g.y_at(2), 0}, {g.x_at(1e6), g.y_at(2), 0}, {g.x_at(2), g.y_at(1e6), 0}};
  const auto grid = cell_triangles(g, 5, 5, v, {{0, 1, 2}});
  for (int r = 0; r < 5; ++r)
    for (int c = 0; c < 5; ++c) EXPECT_EQ(grid.at(c, r), c >= 2 && r >= 2 ? 0u : kNoTriangle) << c << ',' << r;
  // Wholly off the grid: nothing.
  const std::vector<TinVertex> far = {
      {g.x_at(-50), g.y_at(-50), 0}, {g.x_at(-40), g.y_at(-50), 0}, {g.x_at(-50), g.y_at(-40), 0}};
  const auto none = cell_triangles(g, 5, 5, far, {{0, 1, 2}});
  for (int r = 0; r < 5; ++r)
    for (int c = 0; c < 5; ++c) EXPECT_EQ(none.at(c, r), kNoTriangle);
}

// Whether triangle t holds cell (col, row)'s centre, by the sign of the
// three edge functions in grid coordinates (either winding).
bool holds(const terrain::GeoTransform& g, const std::vector<TinVertex>& v, const TinTriangle& t, int col, int row) {
  double sides[3];
  for (int e = 0; e < 3; ++e) {
    const TinVertex& p = v[t[e]];
    const TinVertex& q = v[t[(e + 1) % 3]];
    const double px = g.col_at(p.x), py = g.row_at(p.y), qx = g.col_at(q.x), qy = g.row_at(q.y);
    sides[e] = (qx - px) * (row - py) - (qy - py) * (col - px);
  }
  const double eps = 1e-9;
  return (sides[0] >= -eps && sides[1] >= -eps && sides[2] >= -eps) ||
         (sides[0] <= eps && sides[1] <= eps && sides[2] <= eps);
}

TEST(TinRaster, AFullTinGivesEveryCellExactlyOneTriangleThatHoldsIt) {
  for (unsigned seed : {3u, 11u}) {
    const terrain::Dem dem = testing::make_random_terrain(37, 29, seed);
    for (std::uint32_t budget : {4u, 60u, 400u}) {
      auto built = tin_from_dem(dem, {budget, 0.0});
      ASSERT_TRUE(built.ok()) << built.error().message;
      const Tin& tin = built->tin;
      const terrain::GeoTransform& g = dem.georef.transform;
      const auto grid = cell_triangles(g, dem.width(), dem.height(), tin.vertices, tin.triangles);
      std::vector<std::uint64_t> per_triangle(tin.triangles.size());
      for (int r = 0; r < dem.height(); ++r)
        for (int c = 0; c < dem.width(); ++c) {
          // The corners are the DEM's corner cells: the TIN covers the grid.
          const std::uint32_t t = grid.at(c, r);
          ASSERT_NE(t, kNoTriangle) << "seed " << seed << " budget " << budget << " cell " << c << ',' << r;
          ASSERT_LT(t, tin.triangles.size());
          ++per_triangle[t];
          // Brute force: the last triangle that holds the centre.
          std::uint32_t last = kNoTriangle;
          for (std::size_t i = 0; i < tin.triangles.size(); ++i)
            if (holds(g, tin.vertices, tin.triangles[i], c, r)) last = static_cast<std::uint32_t>(i);
          EXPECT_EQ(t, last) << "seed " << seed << " budget " << budget << " cell " << c << ',' << r;
        }
      std::uint64_t total = 0;
      for (std::uint64_t n : per_triangle) total += n;
      EXPECT_EQ(total, static_cast<std::uint64_t>(dem.width()) * static_cast<std::uint64_t>(dem.height()));
    }
  }
}

}  // namespace
}  // namespace horizon::mesh
