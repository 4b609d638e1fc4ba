// test_tiff_predictor.cpp — the reader undoes TIFF predictors itself
// (core/src/terrain/tiff_predictor.hpp): the kernels against a reference
// encoder on rows of every length around the SIMD widths, and whole reads
// of files libtiff encoded with each predictor, layout and sample type,
// bit for bit against the values written. Files the reader leaves to
// libtiff (big-endian, several samples a pixel) read the same. (Not tested:
// big-endian floats with the floating-point predictor, which libtiff 4.5
// writes with their byte planes in file order and reads back swapped, in
// GDAL as here; the reader leaves them to libtiff.)
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "horizon/terrain/dem_reader.hpp"
#include "terrain/tiff_predictor.hpp"
#include "terrain/tiff_support.hpp"
#include "test_support.hpp"

namespace horizon::testing {
namespace {

using terrain::detail::undo_floating_point;
using terrain::detail::undo_horizontal;

std::vector<unsigned char> random_bytes(std::size_t n, std::mt19937& rng) {
  std::vector<unsigned char> v(n);
  for (auto& b : v) b = static_cast<unsigned char>(rng());
  return v;
}

// TIFF 6.0's horizontal differencing of `count` little-endian samples of `bytes`.
std::vector<unsigned char> difference(const std::vector<unsigned char>& row, std::size_t count, int bytes) {
  std::vector<unsigned char> out = row;
  for (std::size_t i = count; i-- > 1;) {
    std::uint64_t a = 0, b = 0;
    std::memcpy(&a, &row[i * bytes], bytes);
    std::memcpy(&b, &row[(i - 1) * bytes], bytes);
    const std::uint64_t d = a - b;
    std::memcpy(&out[i * bytes], &d, bytes);
  }
  return out;
}

// Adobe's floating-point predictor: byte planes, most significant first, then bytes differenced.
std::vector<unsigned char> float_encode(const std::vector<unsigned char>& row, std::size_t count, int bytes) {
  std::vector<unsigned char> planes(row.size());
  for (std::size_t i = 0; i < count; ++i)
    for (int k = 0; k < bytes; ++k) planes[(bytes - 1 - k) * count + i] = row[i * bytes + k];
  for (std::size_t i = planes.size(); i-- > 1;) planes[i] = static_cast<unsigned char>(planes[i] - planes[i - 1]);
  return planes;
}

TEST(TiffPredictor, HorizontalUndoesDifferencing) {
  std::mt19937 rng(7);
  for (int bytes : {1, 2, 4, 8})
    for (std::size_t count = 0; count <= 70; ++count) {
      const auto row = random_bytes(count * bytes, rng);
      auto coded = difference(row, count, bytes);
      undo_horizontal(coded.data(), count, bytes);
      ASSERT_EQ(coded, row) << bytes << " bytes, " << count << " samples";
    }
}

TEST(TiffPredictor, FloatingPointUndoesPlanesAndDifferencing) {
  std::mt19937 rng(11);
  for (int bytes : {4, 8})
    for (std::size_t count = 0; count <= 70; ++count) {
      const auto row = random_bytes(count * bytes, rng);
      // Sub-ranges of columns, as a window asks (empty ones included).
      for (std::size_t first : {std::size_t{0}, std::size_t{1}, count / 3})
        for (std::size_t n : {count - std::min(count, first), std::size_t{(count - std::min(count, first)) / 2}}) {
          if (first + n > count) continue;
          auto coded = float_encode(row, count, bytes);
          std::vector<unsigned char> out(n * bytes, 0xAB);
          undo_floating_point(coded.data(), count, bytes, first, n, out.data());
          const std::vector<unsigned char> want(row.begin() + static_cast<std::ptrdiff_t>(first * bytes),
                                                row.begin() + static_cast<std::ptrdiff_t>((first + n) * bytes));
          ASSERT_EQ(out, want) << bytes << " bytes, " << count << " samples, from " << first << ", " << n;
        }
    }
}

TEST(TiffPredictor, OnlyTheCommonLayoutsAreOurs) {
  using terrain::detail::predictor_is_ours;
  EXPECT_TRUE(predictor_is_ours(2, 16, 1, false));
  EXPECT_TRUE(predictor_is_ours(2, 8, 1, false));
  EXPECT_TRUE(predictor_is_ours(3, 32, 1, false));
  EXPECT_TRUE(predictor_is_ours(3, 64, 1, false));
  EXPECT_FALSE(predictor_is_ours(1, 16, 1, false));
  EXPECT_FALSE(predictor_is_ours(3, 16, 1, false));  // half floats: libtiff's
  EXPECT_FALSE(predictor_is_ours(2, 16, 3, false));  // interleaved bands: libtiff's
  EXPECT_FALSE(predictor_is_ours(2, 16, 1, true));   // big-endian file: libtiff's
}

// A file libtiff writes with a predictor: `samples` interleaved bands (or
// separate planes), tiled or in strips, each cell's value given by `value`.
struct Layout {
  const char* name;
  int bits;
  std::uint16_t format;
  std::uint16_t predictor;
  bool tiled;
  int width, height, block;  // block: tile side, or rows per strip
  int samples = 1;
  bool separate = false;
  bool big_endian = false;
};

// The value written at (col, row, band): random bits of the type, with
// NaN, infinities and -0 among the floats.
std::vector<unsigned char> cell_values(const Layout& l) {
  std::mt19937 rng(static_cast<unsigned>(l.width * 31 + l.bits));
  const std::size_t bytes = l.bits / 8;
  std::vector<unsigned char> v(static_cast<std::size_t>(l.width) * l.height * l.samples * bytes);
  for (auto& b : v) b = static_cast<unsigned char>(rng());
  if (l.format == SAMPLEFORMAT_IEEEFP && bytes == 4) {
    // Mostly finite elevations, so the conversion is exercised too.
    for (std::size_t i = 0; i < v.size() / 4; ++i) {
      float f = static_cast<float>(static_cast<int>(rng() % 900000) - 100000) / 100.0f;
      if (i % 97 == 5) f = std::numeric_limits<float>::quiet_NaN();
      if (i % 89 == 3) f = -0.0f;
      std::memcpy(&v[i * 4], &f, 4);
    }
  }
  if (l.format == SAMPLEFORMAT_IEEEFP && bytes == 8)
    for (std::size_t i = 0; i < v.size() / 8; ++i) {
      const double d = static_cast<double>(static_cast<int>(rng() % 900000) - 100000) / 7.0;
      std::memcpy(&v[i * 8], &d, 8);
    }
  return v;
}

void write_layout(const std::string& path, const Layout& l, const std::vector<unsigned char>& values) {
  terrain::detail::TiffMessages messages;
  auto tif = terrain::detail::open_tiff(path, l.big_endian ? "wb" : "wl", messages);
  ASSERT_TRUE(tif) << messages.errors;
  TIFF* t = tif.get();
  TIFFSetField(t, TIFFTAG_IMAGEWIDTH, l.width);
  TIFFSetField(t, TIFFTAG_IMAGELENGTH, l.height);
  TIFFSetField(t, TIFFTAG_BITSPERSAMPLE, l.bits);
  TIFFSetField(t, TIFFTAG_SAMPLESPERPIXEL, l.samples);
  TIFFSetField(t, TIFFTAG_SAMPLEFORMAT, l.format);
  TIFFSetField(t, TIFFTAG_PHOTOMETRIC, PHOTOMETRIC_MINISBLACK);
  TIFFSetField(t, TIFFTAG_PLANARCONFIG, l.separate ? PLANARCONFIG_SEPARATE : PLANARCONFIG_CONTIG);
  TIFFSetField(t, TIFFTAG_COMPRESSION, COMPRESSION_ADOBE_DEFLATE);
  TIFFSetField(t, TIFFTAG_PREDICTOR, l.predictor);
  const std::size_t bytes = l.bits / 8;
  const std::size_t pixel = l.separate ? bytes : bytes * l.samples;
  // The values of band s (or of every band, contiguous) for cells [c0, c1) of row r.
  auto cells = [&](int r, int c0, int c1, int s, unsigned char* to) {
    for (int c = c0; c < c1; ++c)
      for (int k = 0; k < (l.separate ? 1 : l.samples); ++k) {
        const int band = l.separate ? s : k;
        std::memcpy(to + static_cast<std::size_t>(c - c0) * pixel + k * bytes,
                    &values[((static_cast<std::size_t>(r) * l.width + c) * l.samples + band) * bytes], bytes);
      }
  };
  if (l.tiled) {
    TIFFSetField(t, TIFFTAG_TILEWIDTH, l.block);
    TIFFSetField(t, TIFFTAG_TILELENGTH, l.block);
    std::vector<unsigned char> tile(static_cast<std::size_t>(l.block) * l.block * pixel);
    for (int s = 0; s < (l.separate ? l.samples : 1); ++s)
      for (int y = 0; y < l.height; y += l.block)
        for (int x = 0; x < l.width; x += l.block) {
          std::fill(tile.begin(), tile.end(), 0);
          for (int r = y; r < std::min(y + l.block, l.height); ++r)
            cells(r, x, std::min(x + l.block, l.width), s, &tile[static_cast<std::size_t>(r - y) * l.block * pixel]);
          ASSERT_GE(TIFFWriteTile(t, tile.data(), x, y, 0, static_cast<std::uint16_t>(s)), 0) << messages.errors;
        }
  } else {
    TIFFSetField(t, TIFFTAG_ROWSPERSTRIP, l.block);
    std::vector<unsigned char> row(static_cast<std::size_t>(l.width) * pixel);
    for (int s = 0; s < (l.separate ? l.samples : 1); ++s)
      for (int r = 0; r < l.height; ++r) {
        cells(r, 0, l.width, s, row.data());
        ASSERT_EQ(TIFFWriteScanline(t, row.data(), r, static_cast<std::uint16_t>(s)), 1) << messages.errors;
      }
  }
  ASSERT_EQ(TIFFWriteDirectory(t), 1) << messages.errors;
}

// The float the reader must give for a written value (no nodata set).
float expected(const Layout& l, const std::vector<unsigned char>& values, std::size_t index) {
  const unsigned char* p = &values[index * (l.bits / 8)];
  auto as = [p](auto v) {
    std::memcpy(&v, p, sizeof v);
    return static_cast<float>(v);
  };
  if (l.format == SAMPLEFORMAT_IEEEFP) return l.bits == 32 ? as(float{}) : as(double{});
  const bool s = l.format == SAMPLEFORMAT_INT;
  switch (l.bits) {
    case 8:
      return s ? as(std::int8_t{}) : as(std::uint8_t{});
    case 16:
      return s ? as(std::int16_t{}) : as(std::uint16_t{});
    default:
      return s ? as(std::int32_t{}) : as(std::uint32_t{});
  }
}

bool same(float a, float b) {
  return (std::isnan(a) && std::isnan(b)) || std::memcmp(&a, &b, sizeof a) == 0;
}

TEST(TiffPredictor, ReadsWhatLibtiffEncodes) {
  const std::vector<Layout> layouts = {
      {"int16 horizontal tiled", 16, SAMPLEFORMAT_INT, PREDICTOR_HORIZONTAL, true, 70, 45, 32},
      {"uint16 horizontal strips", 16, SAMPLEFORMAT_UINT, PREDICTOR_HORIZONTAL, false, 37, 29, 5},
      {"uint8 horizontal strips", 8, SAMPLEFORMAT_UINT, PREDICTOR_HORIZONTAL, false, 33, 9, 4},
      {"int32 horizontal tiled", 32, SAMPLEFORMAT_INT, PREDICTOR_HORIZONTAL, true, 17, 40, 16},
      {"float32 floating point tiled", 32, SAMPLEFORMAT_IEEEFP, PREDICTOR_FLOATINGPOINT, true, 81, 50, 48},
      {"float32 floating point strips", 32, SAMPLEFORMAT_IEEEFP, PREDICTOR_FLOATINGPOINT, false, 15, 31, 1},
      {"float64 floating point strips", 64, SAMPLEFORMAT_IEEEFP, PREDICTOR_FLOATINGPOINT, false, 23, 12, 7},
      {"float32 planes, floating point", 32, SAMPLEFORMAT_IEEEFP, PREDICTOR_FLOATINGPOINT, true, 40, 20, 16, 2, true},
      // Left to libtiff's own predictor:
      {"int16 interleaved bands", 16, SAMPLEFORMAT_INT, PREDICTOR_HORIZONTAL, false, 19, 11, 4, 3},
      {"int16 big-endian", 16, SAMPLEFORMAT_INT, PREDICTOR_HORIZONTAL, false, 25, 8, 3, 1, false, true},
  };
  TempDir dir;
  for (const Layout& l : layouts) {
    SCOPED_TRACE(l.name);
    const std::string path = dir.file("p.tif");
    const auto values = cell_values(l);
    write_layout(path, l, values);
    for (int band = 1; band <= l.samples; ++band) {
      terrain::ReadOptions options;
      options.allow_missing_crs = true;
      options.band = l.samples > 1 ? band : 0;
      for (int threads : {1, 2}) {
        options.threads = static_cast<unsigned>(threads);
        auto dem = terrain::read_geotiff(path, options);
        ASSERT_TRUE(dem.ok()) << dem.error().message;
        for (int r = 0; r < l.height; ++r)
          for (int c = 0; c < l.width; ++c) {
            const std::size_t index = (static_cast<std::size_t>(r) * l.width + c) * l.samples + (band - 1);
            ASSERT_TRUE(same(dem->elevation.at(c, r), expected(l, values, index)))
                << "band " << band << " at " << c << "," << r << ": " << dem->elevation.at(c, r) << " vs "
                << expected(l, values, index);
          }
      }
      // A window starting inside a block: the predictor still runs from the block's first column.
      options.window = terrain::Window{3, 2, l.width - 1, l.height};
      auto part = terrain::read_geotiff(path, options);
      ASSERT_TRUE(part.ok()) << part.error().message;
      for (int r = 2; r < l.height; ++r)
        for (int c = 3; c < l.width - 1; ++c) {
          const std::size_t index = (static_cast<std::size_t>(r) * l.width + c) * l.samples + (band - 1);
          ASSERT_TRUE(same(part->elevation.at(c - 3, r - 2), expected(l, values, index)))
              << "window at " << c << "," << r;
        }
    }
  }
}

}  // namespace
}  // namespace horizon::testing
