// Tests for terrain/preview.cpp: the colours of visible / hidden / void /
// beyond-reach cells, the legend beside the map, the true aspect of a
// geographic DEM, metric hillshading, ramps' endpoints, the observer marker,
// resampling, and refusals. The PNG is read back with OpenImageIO.
#include <gtest/gtest.h>

#include <OpenImageIO/imageio.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "horizon/terrain/preview.hpp"
#include "test_support.hpp"

namespace horizon::terrain {
namespace {

using testing::TempDir;

struct Image {
  int width = 0, height = 0, channels = 0;
  std::vector<std::uint8_t> rgb;
  Rgb8 at(int x, int y) const {
    const std::uint8_t* p = rgb.data() + (static_cast<std::size_t>(y) * width + x) * channels;
    return {p[0], p[1], p[2]};
  }
  // Pixels of exactly `c` in [x0, x1) x [y0, y1).
  int count(Rgb8 c, int x0, int y0, int x1, int y1) const {
    int n = 0;
    for (int y = y0; y < y1; ++y)
      for (int x = x0; x < x1; ++x) n += at(x, y) == c;
    return n;
  }
};

Image read_png(const std::string& path) {
  Image img;
  auto in = OIIO::ImageInput::open(path);
  if (!in) return img;
  img.width = in->spec().width;
  img.height = in->spec().height;
  img.channels = in->spec().nchannels;
  img.rgb.resize(static_cast<std::size_t>(img.width) * img.height * img.channels);
  if (!in->read_image(0, 0, 0, img.channels, OIIO::TypeDesc::UINT8, img.rgb.data())) img.width = 0;
  return img;
}

// The picture pixel showing cell (c, r)'s centre.
std::pair<int, int> pixel_of(const PreviewLayout& l, const PreviewOptions& o, double c, double r) {
  return {l.map_x + static_cast<int>(std::floor((c + 0.5) * o.metres_per_col / l.metres_per_pixel)),
          l.map_y + static_cast<int>(std::floor((r + 0.5) * o.metres_per_row / l.metres_per_pixel))};
}

std::string text(Rgb8 c) {
  return std::to_string(c[0]) + "," + std::to_string(c[1]) + "," + std::to_string(c[2]);
}

TEST(Preview, ColoursVisibleHiddenVoidBeyondAndObserver) {
  TempDir dir;
  const std::string path = dir.file("p.png");
  Grid<float> z(60, 40, 100.0f);  // flat: the legend's colours exactly
  for (int r = 28; r < 34; ++r)
    for (int c = 2; c < 8; ++c) z.at(c, r) = std::numeric_limits<float>::quiet_NaN();
  Grid<std::uint8_t> vis(60, 40, 1);
  for (int r = 0; r < 40; ++r)
    for (int c = 40; c < 60; ++c) vis.at(c, r) = 0;
  for (int r = 34; r < 40; ++r)
    for (int c = 15; c < 25; ++c) vis.at(c, r) = 255;  // beyond reach
  PreviewOptions options;
  options.observers.push_back({10.0, 10.0, 500.0});
  options.title = {"Viewshed over flat", "Observer here; eye 2 m above the ground"};
  PreviewLayout layout;
  ASSERT_TRUE(write_viewshed_preview(path, z, vis, options, &layout).ok());
  const Image img = read_png(path);
  ASSERT_EQ(img.width, layout.width);
  ASSERT_EQ(img.height, layout.height);
  ASSERT_EQ(img.channels, 3);
  // 60 x 40 one-metre cells enlarged to the 480-pixel minimum: 8 pixels a cell.
  EXPECT_EQ(layout.map_width, 480);
  EXPECT_EQ(layout.map_height, 320);
  EXPECT_DOUBLE_EQ(layout.metres_per_pixel, 0.125);
  auto at_cell = [&](double c, double r) {
    const auto [x, y] = pixel_of(layout, options, c, r);
    return img.at(x, y);
  };
  EXPECT_EQ(at_cell(30, 30), kPreviewVisible) << text(at_cell(30, 30));
  EXPECT_EQ(at_cell(50, 20), kPreviewHidden) << text(at_cell(50, 20));
  EXPECT_EQ(at_cell(20, 37), kPreviewBeyond) << text(at_cell(20, 37));
  // The void block is hatched: both greys, nothing else.
  const auto [vx0, vy0] = pixel_of(layout, options, 2.5, 28.5);
  const int dark = img.count(kPreviewVoidDark, vx0, vy0, vx0 + 24, vy0 + 24);
  const int light = img.count(kPreviewVoidLight, vx0, vy0, vx0 + 24, vy0 + 24);
  EXPECT_EQ(dark + light, 24 * 24);
  EXPECT_GT(dark, 100);
  EXPECT_GT(light, 200);
  // Observer: a white dot in a black disc; its 500 m reach lies off this small map.
  EXPECT_EQ(at_cell(10, 10), (Rgb8{255, 255, 255}));
  const auto [ox, oy] = pixel_of(layout, options, 10, 10);
  EXPECT_EQ(img.at(ox + 4, oy), (Rgb8{20, 20, 20}));
  EXPECT_FALSE(std::filesystem::exists(path + ".tmp"));
}

TEST(Preview, LegendBesideTheMapShowsEveryClassPresent) {
  TempDir dir;
  const std::string path = dir.file("legend.png");
  Grid<float> z(200, 100, 50.0f);
  z.at(5, 5) = std::numeric_limits<float>::quiet_NaN();
  Grid<std::uint8_t> codes(200, 100, 1);
  for (int r = 0; r < 100; ++r)
    for (int c = 100; c < 200; ++c) codes.at(c, r) = r < 50 ? 0 : 2;
  PreviewOptions options;
  options.metres_per_col = options.metres_per_row = 30.0;
  options.observers.push_back({50.0, 50.0, 1500.0});
  PreviewLayout layout;
  ASSERT_TRUE(write_viewshed_preview(path, z, codes, options, &layout).ok());
  const Image img = read_png(path);
  ASSERT_EQ(img.width, layout.width);
  // The legend panel is to the right of the map, at its top.
  EXPECT_GT(layout.legend_x, layout.map_x + layout.map_width);
  EXPECT_EQ(layout.legend_y, layout.map_y);
  const int x0 = layout.legend_x, x1 = layout.width, y0 = layout.legend_y, y1 = layout.legend_y + 200;
  // Each swatch is 30 x 16 pixels of its class's colour.
  EXPECT_GE(img.count(kPreviewVisible, x0, y0, x1, y1), 30 * 16);
  EXPECT_GE(img.count(kPreviewHidden, x0, y0, x1, y1), 30 * 16);
  EXPECT_GE(img.count(kPreviewUndetermined, x0, y0, x1, y1), 30 * 16);
  // The void's swatch is hatched like the map's voids.
  EXPECT_GE(img.count(kPreviewVoidDark, x0, y0, x1, y1), 100);
  // The scale bar and the north arrow are drawn in ink below the entries.
  EXPECT_GT(img.count({20, 20, 20}, x0, y0 + 150, x1, layout.legend_y + layout.legend_height), 200);
}

TEST(Preview, GeographicCellsAreDrawnAtTrueAspect) {
  // Cells half as wide as tall (a geographic DEM at 60 degrees of latitude):
  // a square grid is drawn twice as tall as wide, and the left half of its
  // columns covers the left half of the map.
  TempDir dir;
  const std::string path = dir.file("aspect.png");
  Grid<float> z(100, 100, 0.0f);
  Grid<std::uint8_t> codes(100, 100, 0);
  for (int r = 0; r < 100; ++r)
    for (int c = 0; c < 50; ++c) codes.at(c, r) = 1;
  PreviewOptions options;
  options.metres_per_col = 46.3;
  options.metres_per_row = 92.6;
  PreviewLayout layout;
  ASSERT_TRUE(write_viewshed_preview(path, z, codes, options, &layout).ok());
  const Image img = read_png(path);
  EXPECT_EQ(layout.map_height, 2 * layout.map_width);
  EXPECT_EQ(layout.map_height, 480);
  // Measured on the pixels: the blue half is map_width / 2 wide and the whole map tall.
  const int mid_row = layout.map_y + layout.map_height / 2;
  EXPECT_EQ(img.count(kPreviewVisible, layout.map_x, mid_row, layout.map_x + layout.map_width, mid_row + 1),
            layout.map_width / 2);
  EXPECT_EQ(
      img.count(kPreviewVisible, layout.map_x + 2, layout.map_y, layout.map_x + 3, layout.map_y + layout.map_height),
      layout.map_height);
  // The scale bar's metres follow the pixels: 92.6 * 100 m over 480 pixels.
  EXPECT_NEAR(layout.metres_per_pixel, 9260.0 / 480.0, 1e-9);
}

TEST(Preview, HillshadeUsesMetricCellSizes) {
  // A slope rising to the east by 1 m per cell: lit from the north-west it
  // faces towards the sun (brighter than flat); with 10x wider cells it is
  // gentler, hence closer to flat grey.
  TempDir dir;
  Grid<float> z(20, 20);
  for (int r = 0; r < 20; ++r)
    for (int c = 0; c < 20; ++c) z.at(c, r) = static_cast<float>(c);
  PreviewOptions steep;
  PreviewOptions gentle;
  gentle.metres_per_col = 10.0;
  PreviewLayout a_layout, b_layout;
  ASSERT_TRUE(write_viewshed_preview(dir.file("a.png"), z, {}, steep, &a_layout).ok());
  ASSERT_TRUE(write_viewshed_preview(dir.file("b.png"), z, {}, gentle, &b_layout).ok());
  const auto [ax, ay] = pixel_of(a_layout, steep, 10, 10);
  const auto [bx, by] = pixel_of(b_layout, gentle, 10, 10);
  const int a = read_png(dir.file("a.png")).at(ax, ay)[0];
  const int b = read_png(dir.file("b.png")).at(bx, by)[0];
  // n = (-1, 0, 1)/sqrt(2), sun = (-0.5, 0.5, 0.7071): shade = (0.5 + 0.7071)/1.4142 = 0.8536 -> 218.
  EXPECT_EQ(a, 218);
  // Gentle: n = (-0.1, 0, 1)/|.|: (0.05 + 0.7071)/1.005 = 0.7534 -> 192.
  EXPECT_EQ(b, 192);
}

TEST(Preview, DownsamplesLongSideAndEnlargesSmallMaps) {
  TempDir dir;
  Grid<float> z(3000, 10, 5.0f);
  PreviewOptions options;
  options.max_size = 1000;
  PreviewLayout layout;
  ASSERT_TRUE(write_viewshed_preview(dir.file("small.png"), z, {}, options, &layout).ok());
  EXPECT_EQ(layout.map_width, 1000);
  EXPECT_EQ(layout.map_height, 3);
  EXPECT_EQ(read_png(dir.file("small.png")).width, layout.width);
  Grid<float> tiny(12, 6, 5.0f);
  ASSERT_TRUE(write_viewshed_preview(dir.file("tiny.png"), tiny, {}, {}, &layout).ok());
  EXPECT_EQ(layout.map_width, 480);
  EXPECT_EQ(layout.map_height, 240);
}

// The bar's ends and the map's cells at the ramp's ends have the ramp's end colours.
TEST(Preview, RampsEndAtTheirColoursOnTheMapAndInTheLegend) {
  TempDir dir;
  struct Case {
    PreviewRamp ramp;
    float low_value, high_value;  // written at cells (1, 1) and (2, 1)
    double bar_low, bar_high;
  };
  for (const Case& k : {Case{PreviewRamp::kElevation, 1200.0f, 1800.0f, 1200.0, 1800.0},
                        Case{PreviewRamp::kHeightNeeded, 0.5f, 100.0f, 0.0, 100.0},
                        Case{PreviewRamp::kCount, 1.0f, 20.0f, 1.0, 20.0}}) {
    const std::string path = dir.file("ramp" + std::to_string(static_cast<int>(k.ramp)) + ".png");
    Grid<float> z(60, 60, 10.0f);
    Grid<float> values(60, 60);
    // Values spread between the ends (so that the 98th percentile of a
    // height-needed ramp rounds to its top), 0 on row 30, none on row 40.
    for (int r = 0; r < 60; ++r)
      for (int c = 0; c < 60; ++c)
        values.at(c, r) = k.low_value + (k.high_value - k.low_value) * static_cast<float>((r * 60 + c) % 97) / 96.0f;
    values.at(1, 1) = k.low_value;
    values.at(2, 1) = k.high_value;
    for (int c = 0; c < 60; ++c) {
      if (k.ramp != PreviewRamp::kElevation) values.at(c, 30) = 0.0f;
      values.at(c, 40) = std::numeric_limits<float>::quiet_NaN();
    }
    PreviewOptions options;
    PreviewLayout layout;
    ASSERT_TRUE(write_ramp_preview(path, z, values, {k.ramp, "Value", "units", ""}, options, &layout).ok());
    const Image img = read_png(path);
    ASSERT_EQ(img.width, layout.width);
    EXPECT_DOUBLE_EQ(layout.ramp_low, k.bar_low);
    EXPECT_DOUBLE_EQ(layout.ramp_high, k.bar_high);
    const int bar_x = layout.ramp_x + 10;
    EXPECT_EQ(img.at(bar_x, layout.ramp_bottom), preview_ramp_colour(k.ramp, 0.0));
    EXPECT_EQ(img.at(bar_x, layout.ramp_top), preview_ramp_colour(k.ramp, 1.0));
    auto at_cell = [&](double c, double r) {
      const auto [x, y] = pixel_of(layout, options, c, r);
      return img.at(x, y);
    };
    EXPECT_EQ(at_cell(2, 1), preview_ramp_colour(k.ramp, 1.0)) << text(at_cell(2, 1));
    if (k.ramp != PreviewRamp::kHeightNeeded) {
      EXPECT_EQ(at_cell(1, 1), preview_ramp_colour(k.ramp, 0.0)) << text(at_cell(1, 1));
    }
    // 0: the ground is visible (height needed), seen by none (count).
    if (k.ramp == PreviewRamp::kHeightNeeded) {
      EXPECT_EQ(at_cell(10, 30), kPreviewVisible);
    }
    if (k.ramp == PreviewRamp::kCount) {
      EXPECT_EQ(at_cell(10, 30), kPreviewHidden);
    }
    EXPECT_EQ(at_cell(10, 40), kPreviewBeyond);
  }
  // The ramps are monotonic in lightness (they read in grey and without hue).
  for (PreviewRamp ramp : {PreviewRamp::kElevation, PreviewRamp::kHeightNeeded, PreviewRamp::kCount}) {
    double last = ramp == PreviewRamp::kElevation ? -1.0 : 1e9;
    for (int i = 0; i <= 20; ++i) {
      const Rgb8 c = preview_ramp_colour(ramp, i / 20.0);
      const double luma = 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
      if (ramp == PreviewRamp::kElevation)
        EXPECT_GT(luma, last) << i;
      else
        EXPECT_LT(luma, last) << i;
      last = luma;
    }
  }
}

TEST(Preview, FewCountsAreListedOneByOne) {
  TempDir dir;
  const std::string path = dir.file("count.png");
  Grid<float> z(40, 40, 10.0f);
  Grid<float> values(40, 40, 0.0f);
  for (int c = 0; c < 40; ++c) values.at(c, 0) = 3.0f;
  values.at(5, 5) = 1.0f;
  values.at(6, 5) = 2.0f;
  PreviewLayout layout;
  ASSERT_TRUE(
      write_ramp_preview(path, z, values, {PreviewRamp::kCount, "Observers", "count", "0: none"}, {}, &layout).ok());
  const Image img = read_png(path);
  const int x0 = layout.legend_x, y0 = layout.legend_y;
  for (double t : {0.0, 0.5, 1.0})  // counts 1, 2, 3 each get a swatch
    EXPECT_GE(img.count(preview_ramp_colour(PreviewRamp::kCount, t), x0, y0, layout.width, y0 + 200), 30 * 16) << t;
  EXPECT_GE(img.count(kPreviewHidden, x0, y0, layout.width, y0 + 200), 30 * 16);
}

TEST(Preview, RegionBoxIsOutlinedOnTheMap) {
  TempDir dir;
  const std::string path = dir.file("region.png");
  Grid<float> z(100, 100, 10.0f);
  Grid<std::uint8_t> codes(100, 100, 2);
  PreviewOptions options;
  options.region = PreviewRect{39.5, 39.5, 59.5, 59.5};  // cells 40..59: pixels 192..288 at 4.8 pixels a cell
  PreviewLayout layout;
  ASSERT_TRUE(write_viewshed_preview(path, z, codes, options, &layout).ok());
  const Image img = read_png(path);
  const int mid = layout.map_y + layout.map_height / 2;
  int ink = 0;
  for (int x = layout.map_x; x < layout.map_x + layout.map_width; ++x) ink += img.at(x, mid) == Rgb8{20, 20, 20};
  EXPECT_EQ(ink, 4);  // two edges, two pixels each
}

TEST(Preview, RejectsBadInputAndWritesNothing) {
  TempDir dir;
  const std::string path = dir.file("bad.png");
  Grid<float> z(4, 4, 1.0f);
  EXPECT_EQ(write_viewshed_preview(path, z, Grid<std::uint8_t>(3, 4), {}).error().code, ErrorCode::kInvalidArgument);
  EXPECT_EQ(write_viewshed_preview(path, Grid<float>(), {}, {}).error().code, ErrorCode::kInvalidArgument);
  EXPECT_EQ(write_ramp_preview(path, z, Grid<float>(4, 5), {}, {}).error().code, ErrorCode::kInvalidArgument);
  PreviewOptions zero_cell;
  zero_cell.metres_per_row = 0.0;
  EXPECT_EQ(write_viewshed_preview(path, z, {}, zero_cell).error().code, ErrorCode::kInvalidArgument);
  PreviewOptions zero_size;
  zero_size.max_size = 0;
  EXPECT_EQ(write_viewshed_preview(path, z, {}, zero_size).error().code, ErrorCode::kInvalidArgument);
  PreviewOptions bad_observer;
  bad_observer.observers.push_back({std::numeric_limits<double>::quiet_NaN(), 1.0});
  EXPECT_EQ(write_viewshed_preview(path, z, {}, bad_observer).error().code, ErrorCode::kInvalidArgument);
  EXPECT_TRUE(std::filesystem::is_empty(dir.path()));
}

TEST(Preview, RejectsMissingDirectoryAndLeavesNothing) {
  TempDir dir;
  const std::string path = dir.file("nowhere/p.png");
  const Status st = write_viewshed_preview(path, Grid<float>(4, 4, 1.0f), {}, {});
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().code, ErrorCode::kIoError);
  EXPECT_NE(st.error().message.find(path), std::string::npos);
  EXPECT_TRUE(std::filesystem::is_empty(dir.path()));
}

}  // namespace
}  // namespace horizon::terrain
