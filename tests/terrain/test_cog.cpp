// Cloud-Optimised GeoTIFFs (terrain/geotiff_options.hpp): the layout checked
// byte by byte through libtiff's own view of the file (IFDs before the
// tiles, the smallest overview's tiles first, each tile's size before it and
// its last four bytes after it), the overviews' cells against the resampling
// rule, and GDAL's reading of the result (LAYOUT=COG, its overviews).
#include <gtest/gtest.h>
#include <tiffio.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>
#include <string>
#include <vector>

#include "horizon/geodesy/crs.hpp"
#include "horizon/terrain/dem_reader.hpp"
#include "horizon/terrain/geotiff_writer.hpp"
#include "test_support.hpp"

namespace horizon::terrain {
namespace {

using testing::TempDir;

Georeference utm() {
  return {GeoTransform{712000.0, 10.0, 9561000.0, -10.0}, 32717};
}

GeoTiffOptions cog(std::vector<std::string> items = {}) {
  auto o = parse_creation_options(TiffFormat::kCog, items);
  EXPECT_TRUE(o.ok()) << o.error().message;
  return *o;
}

// 1100 x 700 codes: 1 and 0 in 3 x 3 blocks, 255 (nodata) in a band.
Grid<std::uint8_t> codes() {
  Grid<std::uint8_t> g(1100, 700);
  for (int r = 0; r < g.height(); ++r)
    for (int c = 0; c < g.width(); ++c)
      g.at(c, r) = r >= 600 ? 255 : static_cast<std::uint8_t>(((c / 3) + (r / 3)) % 2);
  return g;
}

struct Image {
  std::uint32_t width = 0, height = 0, tile_width = 0, tile_height = 0;
  std::uint64_t ifd_offset = 0;
  std::vector<std::uint64_t> offsets, counts;
  bool reduced = false;
};

// Every image of the file, as libtiff reads them.
std::vector<Image> images_of(const std::string& path) {
  std::vector<Image> out;
  TIFF* tif = TIFFOpen(path.c_str(), "r");
  if (!tif) return out;
  do {
    Image im;
    im.ifd_offset = TIFFCurrentDirOffset(tif);
    TIFFGetField(tif, TIFFTAG_IMAGEWIDTH, &im.width);
    TIFFGetField(tif, TIFFTAG_IMAGELENGTH, &im.height);
    TIFFGetField(tif, TIFFTAG_TILEWIDTH, &im.tile_width);
    TIFFGetField(tif, TIFFTAG_TILELENGTH, &im.tile_height);
    std::uint32_t subfile = 0;
    TIFFGetField(tif, TIFFTAG_SUBFILETYPE, &subfile);
    im.reduced = subfile & FILETYPE_REDUCEDIMAGE;
    const ttile_t n = TIFFNumberOfTiles(tif);
    for (ttile_t t = 0; t < n; ++t) {
      im.offsets.push_back(TIFFGetStrileOffset(tif, t));
      im.counts.push_back(TIFFGetStrileByteCount(tif, t));
    }
    out.push_back(im);
  } while (TIFFReadDirectory(tif));
  TIFFClose(tif);
  return out;
}

// Image `index` decoded whole by libtiff.
template <class T>
Grid<T> decode(const std::string& path, int index) {
  TIFF* tif = TIFFOpen(path.c_str(), "r");
  TIFFSetDirectory(tif, static_cast<tdir_t>(index));
  std::uint32_t w = 0, h = 0, tw = 0, th = 0;
  TIFFGetField(tif, TIFFTAG_IMAGEWIDTH, &w);
  TIFFGetField(tif, TIFFTAG_IMAGELENGTH, &h);
  TIFFGetField(tif, TIFFTAG_TILEWIDTH, &tw);
  TIFFGetField(tif, TIFFTAG_TILELENGTH, &th);
  Grid<T> g(static_cast<int>(w), static_cast<int>(h));
  std::vector<T> tile(static_cast<std::size_t>(tw) * th);
  for (std::uint32_t y = 0; y < h; y += th)
    for (std::uint32_t x = 0; x < w; x += tw) {
      TIFFReadTile(tif, tile.data(), x, y, 0, 0);
      for (std::uint32_t r = 0; r < th && y + r < h; ++r)
        for (std::uint32_t c = 0; c < tw && x + c < w; ++c)
          g.at(static_cast<int>(x + c), static_cast<int>(y + r)) = tile[r * tw + c];
    }
  TIFFClose(tif);
  return g;
}

std::uint32_t le32(const std::string& bytes, std::uint64_t at) {
  std::uint32_t v = 0;
  std::memcpy(&v, bytes.data() + at, 4);
  return v;
}

// The COG layout rules, checked on the file's bytes and libtiff's offsets.
void expect_cog_layout(const std::string& path) {
  const std::string bytes = testing::read_bytes(path);
  const std::vector<Image> images = images_of(path);
  ASSERT_FALSE(images.empty());
  // GDAL's structural metadata right after the header.
  const std::uint64_t header = bytes[2] == 43 ? 16 : 8;
  EXPECT_EQ(bytes.compare(header, 30, "GDAL_STRUCTURAL_METADATA_SIZE="), 0);
  EXPECT_NE(bytes.find("LAYOUT=IFDS_BEFORE_DATA\n"), std::string::npos);
  std::uint64_t first_tile = bytes.size(), last_ifd = 0;
  for (const Image& im : images) {
    last_ifd = std::max(last_ifd, im.ifd_offset);
    for (std::size_t t = 0; t < im.offsets.size(); ++t)
      if (im.counts[t]) first_tile = std::min(first_tile, im.offsets[t]);
  }
  EXPECT_LT(last_ifd, first_tile) << "every IFD comes before every tile";
  for (std::size_t i = 0; i + 1 < images.size(); ++i) {
    EXPECT_GT(images[i].ifd_offset, 0u);
    EXPECT_LT(images[i].ifd_offset, images[i + 1].ifd_offset) << "IFDs in order, full resolution first";
    const auto lowest = *std::min_element(images[i].offsets.begin(), images[i].offsets.end());
    const auto highest = *std::max_element(images[i + 1].offsets.begin(), images[i + 1].offsets.end());
    EXPECT_LT(highest, lowest) << "image " << i + 1 << "'s tiles before image " << i << "'s";
  }
  for (const Image& im : images)
    for (std::size_t t = 0; t < im.offsets.size(); ++t) {
      const std::uint64_t at = im.offsets[t], n = im.counts[t];
      ASSERT_GT(n, 4u);
      ASSERT_LE(at + n + 4, bytes.size());
      EXPECT_EQ(le32(bytes, at - 4), n) << "leader: the tile's size";
      EXPECT_EQ(bytes.compare(at + n, 4, bytes, at + n - 4, 4), 0) << "trailer: its last four bytes";
      if (t > 0) {
        EXPECT_EQ(im.offsets[t], im.offsets[t - 1] + im.counts[t - 1] + 8) << "row-major, contiguous";
      }
    }
}

TEST(Cog, CodesGetModeOverviewsDownToOneTile) {
  TempDir dir;
  const std::string path = dir.file("codes.tif");
  const Grid<std::uint8_t> full = codes();
  ASSERT_TRUE(write_geotiff(path, full, utm(), 255.0, cog({"BLOCKSIZE=256"})).ok());
  expect_cog_layout(path);
  const std::vector<Image> images = images_of(path);
  // 1100 x 700 -> 550 x 350 -> 275 x 175 -> 138 x 88: the first to fit 256 x 256.
  ASSERT_EQ(images.size(), 4u);
  const std::uint32_t sizes[][2] = {{1100, 700}, {550, 350}, {275, 175}, {138, 88}};
  for (std::size_t i = 0; i < 4; ++i) {
    EXPECT_EQ(images[i].width, sizes[i][0]);
    EXPECT_EQ(images[i].height, sizes[i][1]);
    EXPECT_EQ(images[i].reduced, i > 0);
    EXPECT_EQ(images[i].tile_width, 256u);
  }
  // Full resolution read back unchanged; each overview the mode of the 2 x 2
  // cells above it, nodata left out, ties to the first in row order.
  const Grid<std::uint8_t> back = decode<std::uint8_t>(path, 0);
  EXPECT_TRUE(std::equal(back.values().begin(), back.values().end(), full.values().begin()));
  Grid<std::uint8_t> above = full;
  for (int level = 1; level < 4; ++level) {
    const Grid<std::uint8_t> ov = decode<std::uint8_t>(path, level);
    for (int r = 0; r < ov.height(); ++r)
      for (int c = 0; c < ov.width(); ++c) {
        std::vector<std::uint8_t> present;
        for (int dr = 0; dr < 2; ++dr)
          for (int dc = 0; dc < 2; ++dc) {
            const int x = 2 * c + dc, y = 2 * r + dr;
            if (x < above.width() && y < above.height() && above.at(x, y) != 255) present.push_back(above.at(x, y));
          }
        std::uint8_t want = 255;
        int best = 0;
        for (std::uint8_t v : present) {
          const int votes = static_cast<int>(std::count(present.begin(), present.end(), v));
          if (votes > best) {
            best = votes;
            want = v;
          }
        }
        ASSERT_EQ(ov.at(c, r), want) << "level " << level << " at " << c << "," << r;
      }
    above = ov;
  }
  // Every overview cell is still a code: no 0.5, no blend of 1 and 255.
  const Grid<std::uint8_t> small = decode<std::uint8_t>(path, 3);
  for (std::uint8_t v : small.values()) EXPECT_TRUE(v == 0 || v == 1 || v == 255);
}

TEST(Cog, FloatsGetAverageOverviewsSkippingNodata) {
  TempDir dir;
  const std::string path = dir.file("heights.tif");
  Grid<float> full(600, 520);
  for (int r = 0; r < full.height(); ++r)
    for (int c = 0; c < full.width(); ++c) full.at(c, r) = static_cast<float>(c + 1000 * r);
  full.at(0, 0) = std::numeric_limits<float>::quiet_NaN();
  full.at(2, 0) = full.at(3, 0) = full.at(2, 1) = full.at(3, 1) = std::numeric_limits<float>::quiet_NaN();
  ASSERT_TRUE(write_geotiff(path, full, utm(), -9999.0, cog({"COMPRESS=ZSTD"})).ok());
  expect_cog_layout(path);
  ASSERT_EQ(images_of(path).size(), 2u);  // 600 x 520 -> 300 x 260, within a 512 tile
  const Grid<float> ov = decode<float>(path, 1);
  EXPECT_FLOAT_EQ(ov.at(0, 0), (1.0f + 1000.0f + 1001.0f) / 3);  // the NaN left out
  EXPECT_FLOAT_EQ(ov.at(1, 0), -9999.0f);                        // all four void: nodata
  EXPECT_FLOAT_EQ(ov.at(5, 7), 14510.5f);  // (14010 + 14011 + 15010 + 15011) / 4
  auto back = read_dem(path);  // our reader takes the full resolution
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(back->width(), 600);
  EXPECT_FLOAT_EQ(back->elevation.at(599, 519), 599 + 519000.0f);
}

TEST(Cog, NearestAndNoOverviewsOnRequest) {
  TempDir dir;
  const Grid<std::uint8_t> full = codes();
  const std::string nearest = dir.file("nearest.tif");
  ASSERT_TRUE(write_geotiff(nearest, full, utm(), 255.0, cog({"OVERVIEW_RESAMPLING=NEAREST"})).ok());
  expect_cog_layout(nearest);
  const Grid<std::uint8_t> ov = decode<std::uint8_t>(nearest, 1);
  for (int r = 0; r < ov.height(); ++r)
    for (int c = 0; c < ov.width(); ++c) ASSERT_EQ(ov.at(c, r), full.at(2 * c, 2 * r));
  const std::string bare = dir.file("bare.tif");
  ASSERT_TRUE(write_geotiff(bare, full, utm(), 255.0, cog({"OVERVIEWS=NONE"})).ok());
  expect_cog_layout(bare);
  EXPECT_EQ(images_of(bare).size(), 1u);
}

TEST(Cog, BigTiffAndAColourTableSurviveTheLayout) {
  TempDir dir;
  const std::string path = dir.file("big.tif");
  ColourTable colours{};
  colours[1] = {0, 114, 178};
  ASSERT_TRUE(write_geotiff(path, codes(), utm(), 255.0, colours, cog({"BIGTIFF=YES", "BLOCKSIZE=256"})).ok());
  expect_cog_layout(path);
  TIFF* tif = TIFFOpen(path.c_str(), "r");
  ASSERT_NE(tif, nullptr);
  EXPECT_TRUE(TIFFIsBigTIFF(tif));
  std::uint16_t *red = nullptr, *green = nullptr, *blue = nullptr;
  ASSERT_TRUE(TIFFGetField(tif, TIFFTAG_COLORMAP, &red, &green, &blue));
  EXPECT_EQ(blue[1], 178 * 257);
  TIFFClose(tif);
  auto back = read_dem(path);
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(back->georef.epsg, 32717);
  EXPECT_DOUBLE_EQ(back->georef.transform.origin_x, 712000.0);
}

// The layout copies the CRS keys as the writer put them: a CRS defined by
// its parameters (user-defined keys and their double and ASCII parameters)
// and a compound one read back as from the plain GeoTIFF.
TEST(Cog, UserDefinedAndCompoundCrsKeysSurviveTheLayout) {
  TempDir dir;
  auto aeqd = geodesy::Crs::from_definition("+proj=aeqd +lat_0=46.85 +lon_0=-121.76 +datum=WGS84 +units=m +type=crs");
  ASSERT_TRUE(aeqd.ok()) << aeqd.error().message;
  const GeoTransform t{-5000.0, 10.0, 3500.0, -10.0};
  for (const Georeference& georef : {Georeference{t, 0, aeqd->wkt()}, Georeference{t, 27700, "EPSG:27700+5701"}}) {
    const std::string plain = dir.file("plain.tif"), laid_out = dir.file("cog.tif");
    ASSERT_TRUE(write_geotiff(plain, codes(), georef, 255.0).ok());
    ASSERT_TRUE(write_geotiff(laid_out, codes(), georef, 255.0, cog({"BLOCKSIZE=256"})).ok());
    expect_cog_layout(laid_out);
    auto a = read_dem(plain), b = read_dem(laid_out);
    ASSERT_TRUE(a.ok()) << a.error().message;
    ASSERT_TRUE(b.ok()) << b.error().message;
    EXPECT_TRUE(b->georef.same_crs(a->georef)) << b->georef.crs << "\n  vs\n" << a->georef.crs;
    auto crs_a = geodesy::Crs::of(a->georef), crs_b = geodesy::Crs::of(b->georef);
    ASSERT_TRUE(crs_a.ok() && crs_b.ok());
    EXPECT_TRUE(crs_b->equivalent_to(*crs_a)) << crs_b->wkt();
    EXPECT_EQ(crs_b->vertical_epsg(), georef.epsg ? 5701 : 0);
  }
}

TEST(Cog, GdalSeesACogWithItsOverviews) {
  if (testing::run_command("gdalinfo --version").exit_code != 0) GTEST_SKIP() << "gdalinfo not installed";
  TempDir dir;
  const std::string path = dir.file("codes.tif");
  ASSERT_TRUE(write_geotiff(path, codes(), utm(), 255.0, cog({"BLOCKSIZE=256"})).ok());
  const auto run = testing::run_command("gdalinfo -json '" + path + "'");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const auto info = nlohmann::json::parse(run.output.substr(run.output.find('{')));
  EXPECT_EQ(info.at("metadata").at("IMAGE_STRUCTURE").at("LAYOUT").get<std::string>(), "COG");
  const auto& overviews = info.at("bands").at(0).at("overviews");
  ASSERT_EQ(overviews.size(), 3u);
  EXPECT_EQ(overviews.at(0).at("size"), nlohmann::json::parse("[550, 350]"));
  EXPECT_EQ(overviews.at(2).at("size"), nlohmann::json::parse("[138, 88]"));
  // GDAL decodes an overview to the same codes libtiff does (its checks of
  // the leaders and trailers pass: it reports no error).
  const auto translate = testing::run_command("gdal_translate -q -ovr 1 -of AAIGrid '" + path + "' '" +
                                              dir.file("ovr.asc") + "' 2>&1");
  ASSERT_EQ(translate.exit_code, 0) << translate.output;
  EXPECT_EQ(translate.output.find("ERROR"), std::string::npos) << translate.output;
  const std::string text = testing::read_bytes(dir.file("ovr.asc"));
  const Grid<std::uint8_t> ov = decode<std::uint8_t>(path, 2);
  std::size_t pos = text.find('\n', text.find("NODATA_value"));
  for (int i = 0; i < 20; ++i) {
    const int v = std::stoi(text.substr(pos));
    EXPECT_EQ(v, ov.values()[static_cast<std::size_t>(i)]) << i;
    pos = text.find_first_of(" \n", text.find_first_not_of(" \n", pos));
  }
}

}  // namespace
}  // namespace horizon::terrain
