// The east and west sectors' transposed lines (core/src/visibility/
// column_lines.hpp): the copy holds every cell of its extent, bit for bit
// (voids included), whichever copy runs (the 8 x 8 blocks and their scalar
// edges, on one thread or several, into a buffer reused or grown); its
// extent covers what those sectors read; and the sweep gives the same bits
// reading it as reading the elevation in place, on the bundled DEMs at
// every kernel form, whole and within a max distance, voids transparent or
// filled, rays one cell apart or spread wider than a run, the buffer fresh
// or left larger by an earlier run.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "column_lines.hpp"
#include "horizon/terrain/dem_reader.hpp"
#include "horizon/visibility/radial_sweep.hpp"
#include "horizon/visibility/viewshed.hpp"
#include "observer_picks.hpp"
#include "simd.hpp"
#include "test_support.hpp"
#include "vector_forms.hpp"

namespace horizon::visibility::sweep {
namespace {

template <class T>
bool same_bits(const T& a, const T& b) {
  return std::memcmp(&a, &b, sizeof(T)) == 0;
}

// A 61 x 47 view of a grid with 9 more floats a row, random heights and voids.
struct StridedTerrain {
  static constexpr int kWidth = 61, kHeight = 47, kStride = 70;
  std::vector<float> cells = std::vector<float>(std::size_t{kStride} * kHeight);
  terrain::HeightView view;

  StridedTerrain() {
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> height(-420.0f, 8848.0f), unit(0.0f, 1.0f);
    for (float& v : cells) v = unit(rng) < 0.05f ? std::numeric_limits<float>::quiet_NaN() : height(rng);
    view = terrain::HeightView(cells.data(), kWidth, kHeight, kStride);
  }
};

void expect_transposed(const terrain::HeightView& z, const terrain::Window& extent, const ColumnLines& lines) {
  ASSERT_EQ(lines.pitch, extent.height());
  EXPECT_EQ(lines.extent, extent);
  for (int c = extent.col0; c < extent.col1; ++c)
    for (int r = extent.row0; r < extent.row1; ++r) {
      const float copied = lines.lines[(c - extent.col0) * lines.pitch + (r - extent.row0)];
      ASSERT_TRUE(same_bits(copied, z.raw(c, r))) << "column " << c << ", row " << r;
    }
}

void check_copies() {
  const StridedTerrain t;
  // Whole, inside, one line wide or tall, sizes that leave partial 8 x 8 blocks.
  const std::vector<terrain::Window> extents = {{0, 0, 61, 47}, {3, 5, 40, 29},  {8, 8, 16, 16},
                                                {0, 0, 1, 47},  {60, 0, 61, 47}, {0, 46, 61, 47},
                                                {17, 3, 18, 4}, {1, 2, 8, 9},    {5, 0, 61, 46}};
  for (const unsigned threads : {1u, 3u})
    for (const terrain::Window& e : extents) {
      SCOPED_TRACE(::testing::Message() << threads << " threads, columns " << e.col0 << "-" << e.col1 << ", rows "
                                        << e.row0 << "-" << e.row1);
      terrain::Grid<float> buffer;
      expect_transposed(t.view, e, transpose_columns(t.view, e, threads, buffer));
      EXPECT_EQ(buffer.width(), e.height());
      EXPECT_EQ(buffer.height(), e.width());
    }
}

// `check` with the scalar copy, then with each vector form this CPU has.
void with_every_copy(void (*check)()) {
  {
    SCOPED_TRACE("scalar copy");
    simd::isa_limit() = simd::Isa::kScalar;
    check();
    simd::isa_limit() = simd::Isa::kAvx512;
  }
  for_each_vector_form(check);
}

TEST(ColumnLines, TheCopyHoldsEveryCellOfItsExtentTransposed) {
  with_every_copy(check_copies);
}

TEST(ColumnLines, ABufferLargeEnoughIsReusedAndASmallOneGrown) {
  const StridedTerrain t;
  terrain::Grid<float> buffer(100, 100);
  const float* kept = buffer.data();
  const terrain::Window small{3, 5, 40, 29};
  expect_transposed(t.view, small, transpose_columns(t.view, small, 2, buffer));
  EXPECT_EQ(buffer.data(), kept) << "no new storage for a copy that fits";
  terrain::Grid<float> tiny(2, 2);
  const terrain::Window whole{0, 0, 61, 47};
  expect_transposed(t.view, whole, transpose_columns(t.view, whole, 2, tiny));
  EXPECT_GE(tiny.capacity(), std::size_t{61} * 47);
}

ViewFrame frame_at(double col, double row, terrain::Window window) {
  ViewFrame f;
  f.observer_col = col;
  f.observer_row = row;
  f.window = window;
  return f;
}

TEST(ColumnLines, TheExtentIsTheWindowAndTheEyesColumnWithOneCellMoreInsideTheGrid) {
  const StridedTerrain t;  // 61 x 47
  EXPECT_EQ(column_lines_extent(t.view, frame_at(20.5, 20.5, {10, 12, 30, 33})), (terrain::Window{9, 11, 31, 34}));
  EXPECT_EQ(column_lines_extent(t.view, frame_at(0.0, 0.0, {0, 0, 61, 47})), (terrain::Window{0, 0, 61, 47}));
  EXPECT_EQ(column_lines_extent(t.view, frame_at(60.9, 46.2, {55, 40, 61, 47})), (terrain::Window{54, 39, 61, 47}));
  // A one-cell window: a bracket of two cells each way.
  EXPECT_EQ(column_lines_extent(t.view, frame_at(30.0, 20.0, {30, 20, 31, 21})), (terrain::Window{29, 19, 32, 22}));
}

// A wedge copies, of each column k cells from the eye, the rows within
// k + 2 of the eye's (all the east and west sectors read) and leaves the
// north and south sectors' cells beyond its margin as the buffer held them.
void check_wedge_copies() {
  const StridedTerrain t;  // 61 x 47
  constexpr float kPoison = 9.0e9f;
  struct Case {
    double col, row;
    terrain::Window extent;
  };
  const std::vector<Case> cases = {{30.5, 23.5, {0, 0, 61, 47}}, {0.2, 40.7, {0, 0, 61, 47}},
                                   {60.9, 0.0, {0, 0, 61, 47}},  {20.0, 20.0, {9, 11, 31, 34}},
                                   {45.3, 3.6, {40, 0, 61, 12}}, {12.0, 30.0, {11, 29, 14, 32}}};
  for (const unsigned threads : {1u, 3u})
    for (const Case& c : cases) {
      SCOPED_TRACE(::testing::Message() << threads << " threads, eye (" << c.col << ", " << c.row << "), columns "
                                        << c.extent.col0 << "-" << c.extent.col1 << ", rows " << c.extent.row0 << "-"
                                        << c.extent.row1);
      const terrain::Window& e = c.extent;
      terrain::Grid<float> buffer(e.height(), e.width(), kPoison);
      const ColumnWedge wedge{c.col, c.row};
      const ColumnLines lines = transpose_columns(t.view, e, threads, buffer, &wedge);
      std::size_t skipped = 0;
      for (int col = e.col0; col < e.col1; ++col)
        for (int row = e.row0; row < e.row1; ++row) {
          const float copied = lines.lines[(col - e.col0) * lines.pitch + (row - e.row0)];
          const double k = std::abs(col - c.col), dy = std::abs(row - c.row);
          if (dy <= k + 2.0) {
            ASSERT_TRUE(same_bits(copied, t.view.raw(col, row))) << "column " << col << ", row " << row;
          } else if (dy > k + 12.0 + ColumnWedge::kMargin) {  // beyond a span of eight columns, the margin, rounding
            ASSERT_EQ(copied, kPoison) << "column " << col << ", row " << row << " was copied";
          }
          skipped += copied == kPoison;
        }
      if (e.height() > 2 * (12 + ColumnWedge::kMargin)) {
        EXPECT_GT(skipped, 0u) << "the wedge copied everything";
      }
    }
}

TEST(ColumnLines, AWedgeCopiesTheRowsTheEastAndWestSectorsRead) {
  with_every_copy(check_wedge_copies);
}

// The fast sweep's OHF and mask with the east and west lines copied equal
// those read in place, bit for bit. The buffer is poisoned before each
// run (a height that would hide the terrain behind it), so a read of a
// cell the copy skipped changes the answer.
class ColumnLinesSweep : public ::testing::TestWithParam<const char*> {};

void compare_sweeps(const terrain::Dem& dem, const geodesy::GridPoint& eye, const ViewshedOptions& o,
                    terrain::Grid<float>& buffer, const std::string& what) {
  SCOPED_TRACE(what);
  const terrain::HeightView z = elevation_view(dem.elevation, o);
  auto frame = make_view_frame(dem, eye, o);
  ASSERT_TRUE(frame.ok()) << frame.error().message;
  const terrain::Window extent = column_lines_extent(z, *frame);
  const auto poison = [&] {
    if (buffer.capacity() < extent.cell_count()) buffer = terrain::Grid<float>(extent.height(), extent.width());
    buffer.reshape(extent.height(), extent.width());
    std::fill(buffer.data(), buffer.data() + buffer.size(), 9.0e9f);
  };
  terrain::Grid<float> in_place, copied;
  WorkStats stats_in_place, stats_copied;
  ASSERT_TRUE(radial_ohf(z, *frame, o.radial, 2, nullptr, in_place, stats_in_place).ok());
  poison();
  ASSERT_TRUE(radial_ohf(z, *frame, o.radial, 2, nullptr, copied, stats_copied, RadialBound::kNone, &buffer).ok());
  ASSERT_FALSE(buffer.empty()) << "the sweep copied its east and west lines";
  ASSERT_EQ(in_place.size(), copied.size());
  std::size_t differ = 0;
  for (std::size_t i = 0; i < in_place.size(); ++i) differ += !same_bits(in_place.data()[i], copied.data()[i]);
  EXPECT_EQ(differ, 0u) << "OHF cells differ";
  EXPECT_EQ(stats_copied.cells_evaluated, stats_in_place.cells_evaluated);
  EXPECT_EQ(stats_copied.terrain_samples, stats_in_place.terrain_samples);

  terrain::Grid<std::uint8_t> mask_in_place, mask_copied;
  AnswerCounts counts_in_place, counts_copied;
  ASSERT_TRUE(radial_mask(z, *frame, o.radial, 1.5, 2, nullptr, mask_in_place, counts_in_place, stats_in_place).ok());
  poison();
  ASSERT_TRUE(
      radial_mask(z, *frame, o.radial, 1.5, 2, nullptr, mask_copied, counts_copied, stats_copied, &buffer).ok());
  ASSERT_EQ(mask_in_place.size(), mask_copied.size());
  EXPECT_TRUE(std::equal(mask_in_place.values().begin(), mask_in_place.values().end(), mask_copied.values().begin()))
      << "mask codes differ";
  EXPECT_EQ(counts_copied.visible, counts_in_place.visible);
  EXPECT_EQ(counts_copied.hidden, counts_in_place.hidden);
  EXPECT_EQ(counts_copied.nodata, counts_in_place.nodata);
  EXPECT_EQ(counts_copied.out_of_range, counts_in_place.out_of_range);
}

TEST_P(ColumnLinesSweep, TheSweepGivesTheSameBitsFromTheCopy) {
  auto dem = terrain::read_dem(testing::bundled_dem(GetParam()));
  ASSERT_TRUE(dem.ok()) << dem.error().message;
  const double cell = std::abs(dem->georef.transform.pixel_width);
  // Filled once by the widest run and reused, larger than later runs need.
  terrain::Grid<float> buffer;
  for (const auto& pick : accuracy::pick_observers(*dem)) {
    auto eye = accuracy::pick_eye(*dem, pick, 2.0);
    ASSERT_TRUE(eye.ok()) << eye.error().message;
    const std::string at =
        std::string(pick.kind) + " (" + std::to_string(pick.col) + "," + std::to_string(pick.row) + ")";
    ViewshedOptions whole;
    compare_sweeps(*dem, *eye, whole, buffer, at + ", whole DEM");
    ViewshedOptions near = whole;
    near.max_distance = 37.3 * cell;  // a window off the grid's corner
    compare_sweeps(*dem, *eye, near, buffer, at + ", max distance");
    ViewshedOptions filled = whole;
    filled.nodata = NodataPolicy::kFill;
    filled.nodata_fill_height = 1234.5;
    compare_sweeps(*dem, *eye, filled, buffer, at + ", voids filled");
    ViewshedOptions sparse = whole;
    sparse.radial.ray_spacing = 2.5;  // groups of rays wider than a run
    compare_sweeps(*dem, *eye, sparse, buffer, at + ", rays 2.5 cells apart");
  }
}

TEST_P(ColumnLinesSweep, EveryKernelFormGivesTheSameBitsFromTheCopy) {
  auto dem = terrain::read_dem(testing::bundled_dem(GetParam()));
  ASSERT_TRUE(dem.ok()) << dem.error().message;
  auto picks = accuracy::pick_observers(*dem);
  ASSERT_FALSE(picks.empty());
  auto eye = accuracy::pick_eye(*dem, picks.front(), 2.0);
  ASSERT_TRUE(eye.ok()) << eye.error().message;
  const auto check = [&] {
    terrain::Grid<float> buffer;
    compare_sweeps(*dem, *eye, ViewshedOptions{}, buffer, "whole DEM");
  };
  simd::isa_limit() = simd::Isa::kScalar;
  check();
  simd::isa_limit() = simd::Isa::kAvx512;
  for_each_vector_form(check);
}

INSTANTIATE_TEST_SUITE_P(DataDem, ColumnLinesSweep,
                         ::testing::Values("everest_summit_voids_srtm3_300x300.tif", "olinda_coast_utm25s_111x111.tif",
                                           "zion_canyon_srtm3_465x457.tif"),
                         [](const ::testing::TestParamInfo<const char*>& test) {
                           return testing::dem_name(test.param);
                         });

}  // namespace
}  // namespace horizon::visibility::sweep
