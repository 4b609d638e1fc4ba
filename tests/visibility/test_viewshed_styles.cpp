// The QGIS style and the colour table of a visible raster written in the
// caller's value codes (visibility/viewshed_preview.hpp): every code drawn
// in its class's colour and words, the nodata left to QGIS (transparent).
#include <gtest/gtest.h>

#include <string>

#include "horizon/terrain/preview.hpp"
#include "horizon/visibility/viewshed_preview.hpp"

namespace horizon::visibility {
namespace {

// The paletteEntry lines of a paletted style, in order.
std::vector<std::string> entries(const std::string& qml) {
  std::vector<std::string> out;
  for (std::size_t at = qml.find("<paletteEntry"); at != std::string::npos; at = qml.find("<paletteEntry", at + 1))
    out.push_back(qml.substr(at, qml.find("/>", at) - at));
  return out;
}

TEST(VisibilityStyle, DefaultCodesListVisibleAndHiddenOnly) {
  const auto e = entries(visibility_style({}));
  ASSERT_EQ(e.size(), 2u);
  EXPECT_NE(e[0].find("value=\"0\" color=\"#d55e00\""), std::string::npos) << e[0];
  EXPECT_NE(e[0].find("label=\"hidden\""), std::string::npos);
  EXPECT_NE(e[1].find("value=\"1\" color=\"#0072b2\""), std::string::npos) << e[1];
  // The same document the fixed-code style always gave.
  EXPECT_EQ(visibility_style({}), viewshed_style(PreviewRaster::kVisibility, 0, 0));
}

TEST(VisibilityStyle, GdalStyleCodesDrawOutOfRangeOfItsOwn) {
  // gdal_viewshed's defaults: -vv 255 -iv 0 -ov 0 would merge; here -ov 100, nodata 254.
  const auto e = entries(visibility_style({.visible = 255, .hidden = 0, .out_of_range = 100, .nodata = 254}));
  ASSERT_EQ(e.size(), 3u);
  EXPECT_NE(e[0].find("value=\"0\""), std::string::npos);
  EXPECT_NE(e[1].find("value=\"100\" color=\"#dedede\""), std::string::npos) << e[1];
  EXPECT_NE(e[1].find("out of range"), std::string::npos);
  EXPECT_NE(e[2].find("value=\"255\" color=\"#0072b2\""), std::string::npos) << e[2];
}

TEST(VisibilityStyle, BooleanCodesSayNotVisible) {
  const auto e = entries(visibility_style(kBooleanCodes));
  ASSERT_EQ(e.size(), 2u);
  EXPECT_NE(e[0].find("label=\"not visible\""), std::string::npos) << e[0];
}

TEST(VisibilityStyle, HiddenAsNodataIsLeftTransparent) {
  const auto e = entries(visibility_style({.visible = 1, .hidden = 255, .out_of_range = 255, .nodata = 255}));
  ASSERT_EQ(e.size(), 1u);
  EXPECT_NE(e[0].find("label=\"visible\""), std::string::npos);
}

TEST(CodeColourTable, EachCodeInItsClassColour) {
  const auto table = code_colour_table({.visible = 7, .hidden = 3, .out_of_range = 9, .nodata = 200});
  EXPECT_EQ(table[7], terrain::kPreviewVisible);
  EXPECT_EQ(table[3], terrain::kPreviewHidden);
  EXPECT_EQ(table[9], terrain::kPreviewBeyond);
  EXPECT_EQ(table[200], terrain::kPreviewBeyond);
  EXPECT_EQ(code_colour_table(ValueCodes{}), code_colour_table()) << "the default codes' table is the old one";
  // Shared codes: hidden wins over out of range.
  EXPECT_EQ(code_colour_table(kBooleanCodes)[0], terrain::kPreviewHidden);
}

// The picture says which part of the surroundings was looked at: out of
// range is then not only beyond the reach.
TEST(FieldOfViewTitle, SaysTheViewWhenItLimits) {
  ViewshedResult result;
  result.frame.eye = 1002.0;
  result.frame.max_distance = 1500.0;
  const PreviewCaption caption{.dem = "dem", .algorithm = "fast", .x = 1, .y = 2, .ground = 1000.0};
  EXPECT_EQ(viewshed_title(result, PreviewRaster::kVisibility, caption)[1].find("view"), std::string::npos);
  result.field_of_view = {
      .azimuth_start = 300, .azimuth_end = 60, .min_distance = 400, .pitch_min = -10.5, .pitch_max = 2};
  EXPECT_NE(viewshed_title(result, PreviewRaster::kVisibility, caption)[1].find(
                "; reach 1.50 km; view azimuth 300 to 60 deg, from 400 m, pitch -10.5 to 2 deg; algorithm fast"),
            std::string::npos);
  result.field_of_view = {.min_distance = 2500};
  EXPECT_NE(viewshed_title(result, PreviewRaster::kOhf, caption)[1].find("; view from 2.50 km;"), std::string::npos);
}

}  // namespace
}  // namespace horizon::visibility
