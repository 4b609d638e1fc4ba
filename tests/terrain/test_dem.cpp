// Tests for terrain/dem.cpp (elevation_stats, sample_bilinear) and the small
// value types beside them (GeoTransform, Window): tiny literal grids with
// hand-computed answers.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "horizon/terrain/dem.hpp"

namespace horizon::terrain {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

// 3x2 grid:  row 0: 0 10 20
//            row 1: 30 40 50
Grid<float> small_grid() {
  Grid<float> g(3, 2);
  const float v[] = {0, 10, 20, 30, 40, 50};
  for (int i = 0; i < 6; ++i) g.data()[i] = v[i];
  return g;
}

TEST(ElevationStats, CountsValidAndNodataCells) {
  Grid<float> g = small_grid();
  g.at(1, 1) = kNaN;
  g.at(2, 0) = -5.5f;
  const ElevationStats s = elevation_stats(g);
  EXPECT_EQ(s.valid_cells, 5u);
  EXPECT_EQ(s.nodata_cells, 1u);
  EXPECT_DOUBLE_EQ(s.min, -5.5);
  EXPECT_DOUBLE_EQ(s.max, 50.0);
}

TEST(ElevationStats, AllNodataGivesZeroRange) {
  Grid<float> g(2, 2, kNaN);
  const ElevationStats s = elevation_stats(g);
  EXPECT_EQ(s.valid_cells, 0u);
  EXPECT_EQ(s.nodata_cells, 4u);
  EXPECT_EQ(s.min, 0.0);
  EXPECT_EQ(s.max, 0.0);
}

TEST(ElevationStats, EmptyGrid) {
  const ElevationStats s = elevation_stats(Grid<float>());
  EXPECT_EQ(s.valid_cells + s.nodata_cells, 0u);
}

TEST(SampleBilinear, CellCentresReturnSamples) {
  const Grid<float> g = small_grid();
  for (int r = 0; r < 2; ++r)
    for (int c = 0; c < 3; ++c) EXPECT_DOUBLE_EQ(sample_bilinear(g, c, r), g.at(c, r)) << c << "," << r;
}

TEST(SampleBilinear, InterpolatesBetweenCentres) {
  const Grid<float> g = small_grid();
  EXPECT_DOUBLE_EQ(sample_bilinear(g, 0.5, 0.0), 5.0);
  EXPECT_DOUBLE_EQ(sample_bilinear(g, 0.0, 0.5), 15.0);
  // (0.5, 0.5): mean of 0, 10, 30, 40.
  EXPECT_DOUBLE_EQ(sample_bilinear(g, 0.5, 0.5), 20.0);
  // (1.25, 0.75): row 0 -> 12.5, row 1 -> 42.5, blend 0.75 -> 35.
  EXPECT_DOUBLE_EQ(sample_bilinear(g, 1.25, 0.75), 35.0);
}

TEST(SampleBilinear, OuterHalfCellMarginIsClamped) {
  const Grid<float> g = small_grid();
  EXPECT_DOUBLE_EQ(sample_bilinear(g, -0.5, -0.5), 0.0);
  EXPECT_DOUBLE_EQ(sample_bilinear(g, 2.5, 1.5), 50.0);
  EXPECT_DOUBLE_EQ(sample_bilinear(g, -0.25, 0.5), 15.0);
  EXPECT_DOUBLE_EQ(sample_bilinear(g, 2.4, 0.0), 20.0);
}

TEST(SampleBilinear, OutsideTheExtentIsNaN) {
  const Grid<float> g = small_grid();
  EXPECT_TRUE(std::isnan(sample_bilinear(g, -0.51, 0.0)));
  EXPECT_TRUE(std::isnan(sample_bilinear(g, 0.0, 1.51)));
  EXPECT_TRUE(std::isnan(sample_bilinear(g, std::nan(""), 0.0)));
  EXPECT_TRUE(std::isnan(sample_bilinear(Grid<float>(), 0.0, 0.0)));
}

TEST(SampleBilinear, VoidSamplesPoisonOnlyWhenBlended) {
  Grid<float> g = small_grid();
  g.at(1, 0) = kNaN;
  EXPECT_TRUE(std::isnan(sample_bilinear(g, 0.5, 0.0)));
  EXPECT_TRUE(std::isnan(sample_bilinear(g, 0.5, 0.5)));
  EXPECT_TRUE(std::isnan(sample_bilinear(g, 1.0, 0.0)));
  // Zero-weight neighbours are not blended: a centre or an edge between two
  // valid centres next to the void stays valid.
  EXPECT_DOUBLE_EQ(sample_bilinear(g, 0.0, 0.0), 0.0);
  EXPECT_DOUBLE_EQ(sample_bilinear(g, 0.0, 0.5), 15.0);
  EXPECT_DOUBLE_EQ(sample_bilinear(g, 1.5, 1.0), 45.0);
}

TEST(SampleBilinear, SingleCellGrid) {
  Grid<float> g(1, 1, 7.0f);
  EXPECT_DOUBLE_EQ(sample_bilinear(g, 0.3, -0.4), 7.0);
}

TEST(GeoTransform, CentresAndInverse) {
  const GeoTransform t{1000.0, 10.0, 2000.0, -5.0};
  EXPECT_DOUBLE_EQ(t.x_at(0), 1005.0);
  EXPECT_DOUBLE_EQ(t.y_at(0), 1997.5);
  EXPECT_DOUBLE_EQ(t.x_at(3), 1035.0);
  EXPECT_DOUBLE_EQ(t.col_at(1035.0), 3.0);
  EXPECT_DOUBLE_EQ(t.row_at(1987.5), 2.0);
  EXPECT_DOUBLE_EQ(t.col_at(1000.0), -0.5);  // outer corner
  const GeoTransform s = t.shifted(2, 4);
  EXPECT_DOUBLE_EQ(s.origin_x, 1020.0);
  EXPECT_DOUBLE_EQ(s.origin_y, 1980.0);
  EXPECT_DOUBLE_EQ(s.x_at(0), t.x_at(2));
}

TEST(Window, ContainsAndCount) {
  const Window w{2, 3, 5, 4};
  EXPECT_EQ(w.width(), 3);
  EXPECT_EQ(w.height(), 1);
  EXPECT_EQ(w.cell_count(), 3u);
  EXPECT_TRUE(w.contains(2, 3));
  EXPECT_TRUE(w.contains(4, 3));
  EXPECT_FALSE(w.contains(5, 3));
  EXPECT_FALSE(w.contains(3, 4));
  EXPECT_FALSE(w.contains(3, 2));  // y checked against rows, not columns
  EXPECT_TRUE((Window{1, 1, 1, 5}.empty()));
  EXPECT_EQ((Window{4, 1, 1, 5}.cell_count()), 0u);
}

}  // namespace
}  // namespace horizon::terrain
