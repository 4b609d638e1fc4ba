#include "horizon/terrain/height_view.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace horizon::terrain {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

// 4 x 3, value 10 r + c, a void at (2, 1).
Grid<float> sample_grid() {
  Grid<float> g(4, 3);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) g.at(c, r) = float(10 * r + c);
  g.at(2, 1) = kNaN;
  return g;
}

TEST(HeightView, AGridReadsAsItselfWithTransparentVoids) {
  const Grid<float> g = sample_grid();
  const HeightView v = g;
  EXPECT_EQ(v.width(), 4);
  EXPECT_EQ(v.height(), 3);
  EXPECT_EQ(v.stride(), 4);
  EXPECT_EQ(v.window(), (Window{0, 0, 4, 3}));
  EXPECT_FALSE(v.fills_voids());
  EXPECT_EQ(v.at(3, 2), 23.0f);
  EXPECT_TRUE(std::isnan(v.at(2, 1)));
  EXPECT_TRUE(v.is_void(2, 1));
}

TEST(HeightView, AFillHeightIsWhatAVoidReads) {
  const Grid<float> g = sample_grid();
  const HeightView v = HeightView(g).with_void_fill(-5.0f);
  EXPECT_TRUE(v.fills_voids());
  EXPECT_EQ(v.at(2, 1), -5.0f);
  EXPECT_TRUE(v.is_void(2, 1));  // the stored value is still the void
  EXPECT_TRUE(std::isnan(v.row(1)[2]));
  EXPECT_EQ(v.fill(v.row(1)[2]), -5.0f);
  EXPECT_EQ(v.at(1, 1), 11.0f);         // other cells untouched
  EXPECT_TRUE(std::isnan(g.at(2, 1)));  // and the grid is never written
}

TEST(HeightView, ASubViewAddressesTheSameCellsAndKnowsWhereItLies) {
  const Grid<float> g = sample_grid();
  const HeightView v = HeightView(g).with_void_fill(7.0f).sub({1, 1, 4, 3});
  EXPECT_EQ(v.width(), 3);
  EXPECT_EQ(v.height(), 2);
  EXPECT_EQ(v.stride(), 4);
  EXPECT_EQ(v.window(), (Window{1, 1, 4, 3}));
  EXPECT_EQ(v.at(0, 0), 11.0f);
  EXPECT_EQ(v.at(1, 0), 7.0f);  // the void, filled
  EXPECT_EQ(v.at(2, 1), 23.0f);
  const HeightView w = v.sub({1, 1, 3, 2});  // windows compose
  EXPECT_EQ(w.window(), (Window{2, 2, 4, 3}));
  EXPECT_EQ(w.at(0, 0), 22.0f);
}

TEST(HeightView, CopyCellsAppliesThePolicy) {
  const Grid<float> g = sample_grid();
  const Grid<float> kept = copy_cells(HeightView(g).sub({1, 0, 3, 2}).with_void_fill(0.5f));
  ASSERT_EQ(kept.width(), 2);
  ASSERT_EQ(kept.height(), 2);
  EXPECT_EQ(kept.at(0, 0), 1.0f);
  EXPECT_EQ(kept.at(1, 0), 2.0f);
  EXPECT_EQ(kept.at(0, 1), 11.0f);
  EXPECT_EQ(kept.at(1, 1), 0.5f);
  const Grid<float> transparent = copy_cells(HeightView(g));
  EXPECT_TRUE(std::isnan(transparent.at(2, 1)));
}

TEST(HeightView, CarriesTheGeoreferenceItWasGiven) {
  const Grid<float> g = sample_grid();
  Georeference geo;
  geo.transform = GeoTransform{100.0, 10.0, 500.0, -10.0};
  const HeightView v = HeightView(g).with_georef(&geo).sub({2, 1, 4, 3});
  ASSERT_EQ(v.georef(), &geo);
  EXPECT_EQ(v.window().col0, 2);
}

}  // namespace
}  // namespace horizon::terrain
