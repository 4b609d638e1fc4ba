// test_geokeys.cpp — Horizon's GeoKey directory (core/src/terrain/geokeys.hpp)
// against libgeotiff: what one writes the other reads, key for key; the
// directories libgeotiff refuses are refused, with the reason named; and
// the ASCII values libgeotiff forgives are read as it reads them.
#include <geo_normalize.h>
#include <geotiffio.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "horizon/terrain/dem_reader.hpp"
#include "terrain/geokeys.hpp"
#include "terrain/tiff_support.hpp"
#include "test_support.hpp"

namespace horizon::testing {
namespace {

using terrain::detail::GeoKeys;
using terrain::detail::open_tiff;
using terrain::detail::TiffMessages;
using terrain::detail::TiffPtr;

// What a test puts in the GeoTIFF tags of a 4 x 4 Int16 image.
struct RawTags {
  std::vector<std::uint16_t> directory;
  std::vector<double> doubles;
  std::optional<std::string> ascii;
};

// Writes a georeferenced 4 x 4 Int16 image; `set` fills its GeoKey tags.
template <class SetKeys>
void write_image(const std::string& path, SetKeys set) {
  TiffMessages messages;
  TiffPtr tif = open_tiff(path, "w", messages);
  ASSERT_TRUE(tif) << messages.errors;
  TIFF* t = tif.get();
  TIFFSetField(t, TIFFTAG_IMAGEWIDTH, 4);
  TIFFSetField(t, TIFFTAG_IMAGELENGTH, 4);
  TIFFSetField(t, TIFFTAG_BITSPERSAMPLE, 16);
  TIFFSetField(t, TIFFTAG_SAMPLESPERPIXEL, 1);
  TIFFSetField(t, TIFFTAG_SAMPLEFORMAT, SAMPLEFORMAT_INT);
  TIFFSetField(t, TIFFTAG_PHOTOMETRIC, PHOTOMETRIC_MINISBLACK);
  TIFFSetField(t, TIFFTAG_ROWSPERSTRIP, 4);
  double scale[3] = {30.0, 30.0, 0.0};
  double tie[6] = {0.0, 0.0, 0.0, 500000.0, 5000000.0, 0.0};
  TIFFSetField(t, terrain::detail::kTagModelPixelScale, 3, scale);
  TIFFSetField(t, terrain::detail::kTagModelTiepoint, 6, tie);
  set(t);
  std::int16_t row[4] = {100, 200, 300, 400};
  for (int r = 0; r < 4; ++r) ASSERT_EQ(TIFFWriteScanline(t, row, r, 0), 1) << messages.errors;
  ASSERT_EQ(TIFFWriteDirectory(t), 1) << messages.errors;
}

void write_raw(const std::string& path, const RawTags& raw) {
  write_image(path, [&](TIFF* t) {
    TIFFSetField(t, terrain::detail::kTagGeoKeyDirectory, static_cast<int>(raw.directory.size()), raw.directory.data());
    if (!raw.doubles.empty())
      TIFFSetField(t, terrain::detail::kTagGeoDoubleParams, static_cast<int>(raw.doubles.size()), raw.doubles.data());
    if (raw.ascii) TIFFSetField(t, terrain::detail::kTagGeoAsciiParams, raw.ascii->c_str());
  });
}

// Opens `path` and hands its TIFF* to `use`.
template <class Use>
void with_tiff(const std::string& path, Use use) {
  TiffMessages messages;
  TiffPtr tif = open_tiff(path, "r", messages);
  ASSERT_TRUE(tif) << messages.errors;
  use(tif.get());
}

struct GtifFree {
  void operator()(GTIF* g) const { GTIFFree(g); }
};

std::optional<int> libgeotiff_short(GTIF* g, geokey_t key) {
  geocode_t v = 0;
  if (GTIFKeyGet(g, key, &v, 0, 1) != 1) return std::nullopt;
  return v;
}

std::optional<std::string> libgeotiff_ascii(GTIF* g, geokey_t key) {
  int size = 0;
  tagtype_t type = TYPE_UNKNOWN;
  const int count = GTIFKeyInfo(g, key, &size, &type);
  if (count <= 0 || type != TYPE_ASCII) return std::nullopt;
  std::vector<char> buf(static_cast<std::size_t>(count) + 1, '\0');
  GTIFKeyGetASCII(g, key, buf.data(), static_cast<int>(buf.size()));
  return std::string(buf.data());
}

std::vector<double> libgeotiff_doubles(GTIF* g, geokey_t key) {
  int size = 0;
  tagtype_t type = TYPE_UNKNOWN;
  const int count = GTIFKeyInfo(g, key, &size, &type);
  if (count <= 0 || type != TYPE_DOUBLE) return {};
  std::vector<double> v(static_cast<std::size_t>(count));
  GTIFKeyGet(g, key, v.data(), 0, count);
  return v;
}

TEST(GeoKeys, LibgeotiffReadsWhatIsWritten) {
  TempDir dir;
  const std::string path = dir.file("keys.tif");
  const std::string citation = "GCS Name = Test|Datum = Test datum|Ellipsoid = GRS 1980|Primem = Greenwich|";
  write_image(path, [&](TIFF* t) {
    GeoKeys keys;
    keys.set_short(GTModelTypeGeoKey, ModelTypeProjected);
    keys.set_short(GTRasterTypeGeoKey, RasterPixelIsArea);
    keys.set_ascii(GTCitationGeoKey, "A test CRS");
    keys.set_short(GeographicTypeGeoKey, KvUserDefined);
    keys.set_ascii(GeogCitationGeoKey, citation);
    keys.set_double(GeogSemiMajorAxisGeoKey, 6378137.0);
    keys.set_double(GeogInvFlatteningGeoKey, 298.257222101);
    keys.set_doubles(GeogTOWGS84GeoKey, {1.5, -2.25, 3.0});
    keys.set_short(ProjectedCSTypeGeoKey, KvUserDefined);
    keys.set_short(VerticalCSTypeGeoKey, 5703);
    keys.set_revision(1, 1);
    ASSERT_TRUE(keys.write(t));
  });
  with_tiff(path, [&](TIFF* t) {
    std::unique_ptr<GTIF, GtifFree> g(GTIFNew(t));
    ASSERT_TRUE(g);
    int versions[3] = {};
    int count = 0;
    GTIFDirectoryInfo(g.get(), versions, &count);
    EXPECT_EQ(versions[0], 1);
    EXPECT_EQ(versions[1], 1);
    EXPECT_EQ(versions[2], 1);
    EXPECT_EQ(count, 10);
    EXPECT_EQ(libgeotiff_short(g.get(), GTModelTypeGeoKey), ModelTypeProjected);
    EXPECT_EQ(libgeotiff_short(g.get(), GTRasterTypeGeoKey), RasterPixelIsArea);
    EXPECT_EQ(libgeotiff_short(g.get(), GeographicTypeGeoKey), KvUserDefined);
    EXPECT_EQ(libgeotiff_short(g.get(), VerticalCSTypeGeoKey), 5703);
    EXPECT_EQ(libgeotiff_ascii(g.get(), GTCitationGeoKey), "A test CRS");
    // Only the '|' the writer added ends the string; GDAL's separators stay.
    EXPECT_EQ(libgeotiff_ascii(g.get(), GeogCitationGeoKey), citation);
    EXPECT_EQ(libgeotiff_doubles(g.get(), GeogSemiMajorAxisGeoKey), std::vector<double>{6378137.0});
    EXPECT_EQ(libgeotiff_doubles(g.get(), GeogInvFlatteningGeoKey), std::vector<double>{298.257222101});
    EXPECT_EQ(libgeotiff_doubles(g.get(), GeogTOWGS84GeoKey), (std::vector<double>{1.5, -2.25, 3.0}));

    // And Horizon reads back the same.
    auto keys = GeoKeys::read(t);
    ASSERT_TRUE(keys.ok()) << keys.error().message;
    EXPECT_EQ(keys->short_value(GTModelTypeGeoKey), ModelTypeProjected);
    EXPECT_EQ(keys->short_value(VerticalCSTypeGeoKey), 5703);
    EXPECT_EQ(keys->ascii(GeogCitationGeoKey), citation);
    EXPECT_EQ(keys->doubles(GeogTOWGS84GeoKey), (std::vector<double>{1.5, -2.25, 3.0}));
    // A key asked for as another type is absent.
    EXPECT_EQ(keys->short_value(GTCitationGeoKey), std::nullopt);
    EXPECT_EQ(keys->ascii(GTModelTypeGeoKey), std::nullopt);
    EXPECT_EQ(keys->doubles(ProjLinearUnitsGeoKey), std::nullopt);
  });
}

TEST(GeoKeys, ReadsWhatLibgeotiffWrites) {
  TempDir dir;
  const std::string path = dir.file("libgeotiff.tif");
  const double towgs84[7] = {-168, -60, 320, 0.1, -0.2, 0.3, 1.5};
  write_image(path, [&](TIFF* t) {
    std::unique_ptr<GTIF, GtifFree> g(GTIFNew(t));
    ASSERT_TRUE(g);
    GTIFKeySet(g.get(), GTModelTypeGeoKey, TYPE_SHORT, 1, ModelTypeGeographic);
    GTIFKeySet(g.get(), GeographicTypeGeoKey, TYPE_SHORT, 1, 4807);
    GTIFKeySet(g.get(), GTCitationGeoKey, TYPE_ASCII, 0, "NTF (Paris)");
    GTIFKeySet(g.get(), GeogTOWGS84GeoKey, TYPE_DOUBLE, 7, towgs84);
    GTIFKeySet(g.get(), GeogPrimeMeridianLongGeoKey, TYPE_DOUBLE, 1, 2.33722917);
    ASSERT_TRUE(GTIFWriteKeys(g.get()));
  });
  with_tiff(path, [&](TIFF* t) {
    auto keys = GeoKeys::read(t);
    ASSERT_TRUE(keys.ok()) << keys.error().message;
    EXPECT_EQ(keys->short_value(GTModelTypeGeoKey), ModelTypeGeographic);
    EXPECT_EQ(keys->short_value(GeographicTypeGeoKey), 4807);
    EXPECT_EQ(keys->ascii(GTCitationGeoKey), "NTF (Paris)");
    EXPECT_EQ(keys->doubles(GeogTOWGS84GeoKey), std::vector<double>(towgs84, towgs84 + 7));
    EXPECT_EQ(keys->doubles(GeogPrimeMeridianLongGeoKey), std::vector<double>{2.33722917});
    EXPECT_EQ(keys->short_value(ProjectedCSTypeGeoKey), std::nullopt);
  });
}

TEST(GeoKeys, NoDirectoryIsNoKeys) {
  TempDir dir;
  const std::string path = dir.file("plain.tif");
  write_image(path, [](TIFF*) {});
  with_tiff(path, [](TIFF* t) {
    auto keys = GeoKeys::read(t);
    ASSERT_TRUE(keys.ok()) << keys.error().message;
    EXPECT_TRUE(keys->empty());
  });
}

TEST(GeoKeys, RefusesWhatLibgeotiffRefuses) {
  struct Case {
    const char* name;
    RawTags raw;
    const char* says;
    // libgeotiff reads past a directory shorter than it claims (and may
    // then accept it); Horizon refuses it.
    bool libgeotiff_checks = true;
  };
  const std::vector<Case> cases = {
      {"version", {{2, 1, 0, 0}, {}, {}}, "version 2; GeoTIFF defines version 1"},
      {"short header", {{1, 1, 0}, {}, {}}, "3 values, fewer than its 4-value header", false},
      {"keys claimed", {{1, 1, 0, 3, 1024, 0, 1, 1}, {}, {}}, "3 keys claimed, 1 held", false},
      {"location",
       {{1, 1, 0, 1, 1024, 1234, 1, 1}, {}, {}},
       "GeoKey 1024 is stored in TIFF tag 1234, none of GeoKeyDirectory, GeoDoubleParams or GeoAsciiParams"},
      {"count in entry",
       {{1, 1, 0, 1, 1024, 0, 2, 1}, {}, {}},
       "GeoKey 1024 holds its value in its entry but counts 2"},
      {"shorts beyond", {{1, 1, 0, 1, 2048, 34735, 2, 7}, {}, {}}, "GeoKey 2048's values lie beyond its end"},
      {"doubles beyond",
       {{1, 1, 0, 1, 2057, 34736, 2, 1}, {6378137.0}, {}},
       "GeoKey 2057's values lie beyond GeoDoubleParams"},
      {"no doubles", {{1, 1, 0, 1, 2057, 34736, 1, 0}, {}, {}}, "GeoKey 2057's values lie beyond GeoDoubleParams"},
      {"text beyond", {{1, 1, 0, 1, 1026, 34737, 4, 9}, {}, "abc|"}, "GeoKey 1026's text lies beyond GeoAsciiParams"},
      {"no text", {{1, 1, 0, 1, 1026, 34737, 4, 0}, {}, {}}, "GeoKey 1026's text lies beyond GeoAsciiParams"},
  };
  TempDir dir;
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const std::string path = dir.file("corrupt.tif");
    write_raw(path, c.raw);
    with_tiff(path, [&](TIFF* t) {
      if (c.libgeotiff_checks) {
        std::unique_ptr<GTIF, GtifFree> g(GTIFNew(t));
        EXPECT_FALSE(g) << "libgeotiff accepts it";
      }
      auto keys = GeoKeys::read(t);
      ASSERT_FALSE(keys.ok());
      EXPECT_EQ(keys.error().message, c.says);
    });
  }
  // The DEM reader names the file and the reason.
  const std::string path = dir.file("dem.tif");
  write_raw(path, {{1, 1, 0, 1, 2057, 34736, 2, 1}, {6378137.0}, {}});
  auto dem = terrain::read_dem(path);
  ASSERT_FALSE(dem.ok());
  EXPECT_NE(dem.error().message.find("GeoKeyDirectory is corrupt (GeoKey 2057's values lie beyond GeoDoubleParams)"),
            std::string::npos)
      << dem.error().message;
}

TEST(GeoKeys, ReadsTextAsLibgeotiffForgivesIt) {
  // A count that takes in the string's NUL, or runs past the end, is cut
  // at the end; an entry without its '|' keeps every character.
  struct Case {
    const char* name;
    std::uint16_t count, offset;
    const char* ascii;
    const char* reads;
  };
  const std::vector<Case> cases = {
      {"terminated", 4, 0, "abc|def|", "abc"},        {"counts the NUL", 4, 4, "abc|def", "def"},
      {"runs past the end", 10, 2, "abcdef", "cdef"}, {"no bar", 3, 0, "abcdef", "abc"},
      {"empty at the end", 1, 6, "abcdef", ""},
  };
  TempDir dir;
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const std::string path = dir.file("text.tif");
    write_raw(path, {{1, 1, 0, 1, 1026, 34737, c.count, c.offset}, {}, std::string(c.ascii)});
    with_tiff(path, [&](TIFF* t) {
      std::unique_ptr<GTIF, GtifFree> g(GTIFNew(t));
      ASSERT_TRUE(g);
      auto keys = GeoKeys::read(t);
      ASSERT_TRUE(keys.ok()) << keys.error().message;
      EXPECT_EQ(keys->ascii(GTCitationGeoKey), std::string(c.reads));
      EXPECT_EQ(libgeotiff_ascii(g.get(), GTCitationGeoKey).value_or("(none)"), std::string(c.reads));
    });
  }
}

TEST(GeoKeys, ALaterEntryForAKeyWins) {
  TempDir dir;
  const std::string path = dir.file("twice.tif");
  write_raw(path, {{1, 1, 0, 2, 1024, 0, 1, 1, 1024, 0, 1, 2}, {}, {}});
  with_tiff(path, [&](TIFF* t) {
    std::unique_ptr<GTIF, GtifFree> g(GTIFNew(t));
    ASSERT_TRUE(g);
    auto keys = GeoKeys::read(t);
    ASSERT_TRUE(keys.ok()) << keys.error().message;
    EXPECT_EQ(keys->short_value(GTModelTypeGeoKey), libgeotiff_short(g.get(), GTModelTypeGeoKey));
    EXPECT_EQ(keys->short_value(GTModelTypeGeoKey), 2);
  });
}

}  // namespace
}  // namespace horizon::testing
