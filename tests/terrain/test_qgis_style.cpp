// Tests for terrain/qgis_style.cpp: the documents QGIS loads as a raster's
// default style (entries, values, colours, labels, escaping), the style's
// path beside its raster, and the atomic write. tests/qgis loads them in
// QGIS itself.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "horizon/terrain/qgis_style.hpp"
#include "test_support.hpp"

namespace horizon::terrain {
namespace {

using testing::TempDir;

std::string contents(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

long entries(const TempDir& dir) {
  return std::distance(std::filesystem::directory_iterator(dir.path()), {});
}

int occurrences(const std::string& s, const std::string& what) {
  int n = 0;
  for (std::size_t at = s.find(what); at != std::string::npos; at = s.find(what, at + 1)) ++n;
  return n;
}

TEST(QgisStyle, PalettedListsEachValueWithItsColourAndEscapedLabel) {
  const std::vector<StyleEntry> entries{{0.0, {213, 94, 0}, "hidden"}, {1.0, {0, 114, 178}, "visible <& \"seen\">"}};
  const std::string qml = qml_paletted(entries);
  EXPECT_EQ(qml.rfind("<!DOCTYPE qgis", 0), 0u);
  EXPECT_NE(qml.find("<rasterrenderer type=\"paletted\" band=\"1\""), std::string::npos);
  EXPECT_NE(qml.find("<paletteEntry value=\"0\" color=\"#d55e00\" alpha=\"255\" label=\"hidden\"/>"),
            std::string::npos);
  EXPECT_NE(qml.find("<paletteEntry value=\"1\" color=\"#0072b2\" alpha=\"255\" "
                     "label=\"visible &lt;&amp; &quot;seen&quot;&gt;\"/>"),
            std::string::npos);
  EXPECT_EQ(occurrences(qml, "<paletteEntry"), 2);
  EXPECT_NE(qml.find("zoomedInResamplingMethod=\"nearestNeighbour\""), std::string::npos);
  EXPECT_EQ(qml.substr(qml.size() - 8), "</qgis>\n");
}

TEST(QgisStyle, PseudocolorHasItsRangeAndRampType) {
  const std::vector<StyleEntry> entries{
      {714.5, {68, 1, 84}, "714 m"}, {2000.0, {33, 145, 140}, "2000 m"}, {7340.25, {253, 231, 37}, "7340 m"}};
  const std::string interpolated = qml_pseudocolor(entries, false, 0);
  EXPECT_NE(interpolated.find("type=\"singlebandpseudocolor\""), std::string::npos);
  EXPECT_NE(interpolated.find("classificationMin=\"714.5\" classificationMax=\"7340.25\""), std::string::npos);
  EXPECT_NE(interpolated.find("colorRampType=\"INTERPOLATED\""), std::string::npos);
  EXPECT_NE(interpolated.find("<item value=\"2000\" color=\"#21918c\" alpha=\"255\" label=\"2000 m\"/>"),
            std::string::npos);
  EXPECT_EQ(occurrences(interpolated, "<item "), 3);
  EXPECT_NE(qml_pseudocolor(entries, true, 0).find("colorRampType=\"DISCRETE\""), std::string::npos);
}

TEST(QgisStyle, SitsBesideItsRasterAndIsWrittenWhole) {
  EXPECT_EQ(qml_path_for("out/rainier.tif"), "out/rainier.qml");
  EXPECT_EQ(qml_path_for("a.b/view.tiff"), "a.b/view.qml");
  EXPECT_EQ(qml_path_for("view"), "view.qml");
  TempDir dir;
  const std::string path = dir.file("v.qml");
  ASSERT_TRUE(write_text_file(path, "first").ok());
  ASSERT_TRUE(write_text_file(path, "second").ok());
  EXPECT_EQ(contents(path), "second");
  EXPECT_EQ(entries(dir), 1);
  const Status missing = write_text_file(dir.file("nowhere/v.qml"), "x");
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().message.find("nowhere/v.qml"), std::string::npos);
}

TEST(QgisStyle, AStagedStyleIsFlushedAsideAndPutInPlaceOnlyWhenCommitted) {
  TempDir dir;
  const std::string path = dir.file("v.qml");
  ASSERT_TRUE(write_text_file(path, "old").ok());
  {
    auto staged = StagedTextFile::stage(path, "never committed");
    ASSERT_TRUE(staged.ok()) << staged.error().message;
    EXPECT_EQ(entries(dir), 2);  // the old file and the staged temporary beside it
    EXPECT_EQ(contents(path), "old");
  }
  EXPECT_EQ(entries(dir), 1);  // dropped uncommitted: the temporary is gone
  EXPECT_EQ(contents(path), "old");
  auto staged = StagedTextFile::stage(path, "new");
  ASSERT_TRUE(staged.ok());
  StagedTextFile moved = std::move(*staged);  // the move carries the temporary
  EXPECT_EQ(contents(path), "old");
  ASSERT_TRUE(moved.commit().ok());
  EXPECT_EQ(contents(path), "new");
  EXPECT_EQ(entries(dir), 1);
  auto nowhere = StagedTextFile::stage(dir.file("nowhere/v.qml"), "x");
  ASSERT_FALSE(nowhere.ok());
  EXPECT_NE(nowhere.error().message.find("nowhere/v.qml"), std::string::npos);
}

// write_with_style: the raster's writer runs while the style is staged; the
// style is put in place only after a written raster, and a failed raster
// leaves an existing style as it was (its error returned, nothing staged
// left behind).
TEST(QgisStyle, AStyleWrittenWithItsRasterFollowsTheRastersFate) {
  TempDir dir;
  const std::string raster = dir.file("v.tif"), style = qml_path_for(raster);
  ASSERT_TRUE(write_text_file(style, "old").ok());
  const Status failed = write_with_style(
      raster, "new", [] { return make_error(ErrorCode::kIoError, "geotiff 'v.tif': disk full", "v.tif"); });
  ASSERT_FALSE(failed.ok());
  EXPECT_EQ(failed.error().message, "geotiff 'v.tif': disk full");
  EXPECT_EQ(contents(style), "old");
  EXPECT_EQ(entries(dir), 1);
  const Status written = write_with_style(raster, "new", [&] { return write_text_file(raster, "raster"); });
  ASSERT_TRUE(written.ok()) << written.error().message;
  EXPECT_EQ(contents(raster), "raster");
  EXPECT_EQ(contents(style), "new");
  EXPECT_EQ(entries(dir), 2);
}

}  // namespace
}  // namespace horizon::terrain
