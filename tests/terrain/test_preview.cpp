// Tests for terrain/preview.cpp: colours of visible / hidden / void cells,
// metric hillshading, the observer marker, downsampling, and refusals. The
// PNG is read back with OpenImageIO.
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
  const std::uint8_t* at(int x, int y) const {
    return rgb.data() + (static_cast<std::size_t>(y) * width + x) * channels;
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

TEST(Preview, ColoursVisibleHiddenVoidAndObserver) {
  TempDir dir;
  const std::string path = dir.file("p.png");
  Grid<float> z(60, 40, 100.0f);  // flat
  z.at(5, 30) = std::numeric_limits<float>::quiet_NaN();
  Grid<std::uint8_t> vis(60, 40, 1);
  for (int r = 0; r < 40; ++r)
    for (int c = 40; c < 60; ++c) vis.at(c, r) = 0;
  vis.at(20, 35) = 255;  // not computed
  PreviewOptions options;
  options.observer_col = 10.0;
  options.observer_row = 10.0;
  ASSERT_TRUE(write_viewshed_preview(path, z, vis, options).ok());
  const Image img = read_png(path);
  ASSERT_EQ(img.width, 60);
  ASSERT_EQ(img.height, 40);
  ASSERT_EQ(img.channels, 3);
  // Flat ground under a sun 45 degrees up: grey 255 * sin(45) = 180.
  const std::uint8_t* plain = img.at(20, 35);
  EXPECT_EQ(plain[0], 180);
  EXPECT_EQ(plain[1], 180);
  EXPECT_EQ(plain[2], 180);
  const std::uint8_t* visible = img.at(30, 30);
  EXPECT_GT(visible[1], visible[0] + 60);
  EXPECT_GT(visible[1], visible[2] + 60);
  const std::uint8_t* hidden = img.at(50, 20);
  EXPECT_GT(hidden[0], hidden[1] + 40);
  EXPECT_LT(hidden[1], 80);  // darkened
  const std::uint8_t* blue_grey = img.at(5, 30);
  EXPECT_EQ(blue_grey[0], 112);
  EXPECT_EQ(blue_grey[1], 120);
  EXPECT_EQ(blue_grey[2], 136);
  // Observer dot (yellow) at its centre, and on its ring (radius 5 px).
  for (const auto& [x, y] : {std::pair{10, 10}, std::pair{15, 10}, std::pair{10, 5}}) {
    const std::uint8_t* p = img.at(x, y);
    EXPECT_GT(p[0], 240) << x << "," << y;
    EXPECT_GT(p[1], 200) << x << "," << y;
    EXPECT_LT(p[2], 40) << x << "," << y;
  }
  EXPECT_FALSE(std::filesystem::exists(path + ".tmp"));
}

TEST(Preview, HillshadeUsesMetricCellSizes) {
  // A slope rising to the east by 1 m per cell: lit from the north-west it
  // faces away from the sun (darker than flat); with 10x wider cells it is
  // gentler, hence closer to flat grey.
  TempDir dir;
  Grid<float> z(20, 20);
  for (int r = 0; r < 20; ++r)
    for (int c = 0; c < 20; ++c) z.at(c, r) = static_cast<float>(c);
  PreviewOptions steep;
  PreviewOptions gentle;
  gentle.metres_per_col = 10.0;
  ASSERT_TRUE(write_viewshed_preview(dir.file("a.png"), z, {}, steep).ok());
  ASSERT_TRUE(write_viewshed_preview(dir.file("b.png"), z, {}, gentle).ok());
  const int a = read_png(dir.file("a.png")).at(10, 10)[0];
  const int b = read_png(dir.file("b.png")).at(10, 10)[0];
  // n = (-1, 0, 1)/sqrt(2), sun = (-0.5, 0.5, 0.7071): shade = (0.5 + 0.7071)/1.4142 = 0.8536 -> 218.
  // Rising east faces *towards* the west-lit side, so it is brighter than 180.
  EXPECT_EQ(a, 218);
  // Gentle: n = (-0.1, 0, 1)/|.|: (0.05 + 0.7071)/1.005 = 0.7534 -> 192.
  EXPECT_EQ(b, 192);
}

TEST(Preview, DownsamplesLongSide) {
  TempDir dir;
  const std::string path = dir.file("small.png");
  Grid<float> z(3000, 10, 5.0f);
  PreviewOptions options;
  options.max_size = 1000;
  ASSERT_TRUE(write_viewshed_preview(path, z, {}, options).ok());
  const Image img = read_png(path);
  EXPECT_EQ(img.width, 1000);
  EXPECT_EQ(img.height, 4);
}

TEST(Preview, RejectsBadInputAndWritesNothing) {
  TempDir dir;
  const std::string path = dir.file("bad.png");
  Grid<float> z(4, 4, 1.0f);
  EXPECT_EQ(write_viewshed_preview(path, z, Grid<std::uint8_t>(3, 4), {}).error().code, ErrorCode::kInvalidArgument);
  EXPECT_EQ(write_viewshed_preview(path, Grid<float>(), {}, {}).error().code, ErrorCode::kInvalidArgument);
  PreviewOptions zero_cell;
  zero_cell.metres_per_row = 0.0;
  EXPECT_EQ(write_viewshed_preview(path, z, {}, zero_cell).error().code, ErrorCode::kInvalidArgument);
  PreviewOptions zero_size;
  zero_size.max_size = 0;
  EXPECT_EQ(write_viewshed_preview(path, z, {}, zero_size).error().code, ErrorCode::kInvalidArgument);
  PreviewOptions half_observer;
  half_observer.observer_col = 1.0;
  EXPECT_EQ(write_viewshed_preview(path, z, {}, half_observer).error().code, ErrorCode::kInvalidArgument);
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
