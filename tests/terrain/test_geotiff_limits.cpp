// Tests for the GeoTIFF reader's memory bound (ReadOptions::max_block_bytes):
// a header of a few hundred bytes may claim a strip or tile of many GB; the
// read is refused from the header, before anything is allocated or decoded,
// with an error naming the file, the block, its bytes and the limit. Honest
// files read exactly up to the limit, and a strip counts only the rows a
// window needs from it unless its codec decodes strips whole. The files are
// written byte by byte here (libtiff would not write such headers).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <optional>
#include <string>
#include <vector>

#include "horizon/terrain/block_cache.hpp"
#include "horizon/terrain/dem_reader.hpp"
#include "horizon/terrain/source.hpp"
#include "test_support.hpp"

namespace horizon::terrain {
namespace {

using testing::TempDir;

constexpr std::uint16_t kShort = 3, kLong = 4;
constexpr std::uint32_t kDataOffset = 0xffffffffu;  // placeholder: where `data` lands

struct Entry {
  std::uint16_t tag, type;
  std::uint32_t value;
  std::uint32_t count = 1;  // > 1: `count` copies of a LONG value, stored after the directory
};

void put(std::string& out, std::uint64_t v, int bytes) {
  for (int i = 0; i < bytes; ++i) out.push_back(static_cast<char>((v >> (8 * i)) & 0xff));
}

// A little-endian classic TIFF: the header, one directory of `entries`
// (ascending tags), the arrays of entries with count > 1, then `data`;
// kDataOffset values point at `data`.
std::string raw_tiff(const std::vector<Entry>& entries, const std::string& data) {
  std::uint32_t arrays_at = 8 + 2 + 12 * static_cast<std::uint32_t>(entries.size()) + 4, data_at = arrays_at;
  for (const Entry& e : entries) data_at += e.count > 1 ? 4 * e.count : 0;
  std::string out = "II", arrays;
  put(out, 42, 2);
  put(out, 8, 4);
  put(out, entries.size(), 2);
  for (const Entry& e : entries) {
    put(out, e.tag, 2);
    put(out, e.type, 2);
    put(out, e.count, 4);
    const std::uint32_t v = e.value == kDataOffset ? data_at : e.value;
    if (e.count > 1) {
      put(out, arrays_at + static_cast<std::uint32_t>(arrays.size()), 4);
      for (std::uint32_t i = 0; i < e.count; ++i) put(arrays, v, 4);
    } else if (e.type == kShort) {
      put(out, v, 2);
      put(out, 0, 2);
    } else {
      put(out, v, 4);
    }
  }
  put(out, 0, 4);  // no next directory
  return out + arrays + data;
}

// One strip of `rows` x `width` cells of `bits`-bit floats under `compression`,
// holding `data` (StripByteCounts = its size unless `claimed_bytes` is given).
std::string one_strip(std::uint32_t width, std::uint32_t rows, std::uint16_t bits, std::uint16_t compression,
                      const std::string& data, std::uint32_t claimed_bytes = 0) {
  return raw_tiff({{256, kLong, width},
                   {257, kLong, rows},
                   {258, kShort, bits},
                   {259, kShort, compression},
                   {262, kShort, 1},  // min-is-black
                   {273, kLong, kDataOffset},
                   {277, kShort, 1},
                   {278, kLong, rows},
                   {279, kLong, claimed_bytes ? claimed_bytes : static_cast<std::uint32_t>(data.size())},
                   {339, kShort, 3}},  // IEEE float
                  data);
}

std::string write(const TempDir& dir, const std::string& name, const std::string& bytes) {
  const std::string path = dir.file(name);
  std::ofstream(path, std::ios::binary) << bytes;
  return path;
}

ReadOptions plain_grid(std::uint64_t max_block_bytes = ReadOptions{}.max_block_bytes) {
  ReadOptions o;
  o.allow_missing_crs = true;
  o.max_block_bytes = max_block_bytes;
  return o;
}

bool has(const Error& e, const std::string& text) {
  return e.message.find(text) != std::string::npos;
}

// 100 000 x 20 000 Float64 cells in one deflate strip: 16 000 000 000 bytes
// claimed by a file of about 150 bytes (the data is never reached).
std::string huge_deflate_strip() {
  return one_strip(100000, 20000, 64, 8, std::string(16, '\0'));
}

TEST(GeoTiffLimits, RejectsAStripClaimingMoreThanTheLimit) {
  TempDir dir;
  const std::string path = write(dir, "huge_strip.tif", huge_deflate_strip());
  auto dem = read_geotiff(path, plain_grid());
  ASSERT_FALSE(dem.ok());
  const Error& e = dem.error();
  EXPECT_EQ(e.code, ErrorCode::kResourceExhausted);
  EXPECT_TRUE(has(e, "dem '" + path + "'")) << e.message;
  // The whole raster: the strip's 20 000 rows of 100 000 x 8 bytes.
  EXPECT_TRUE(has(e,
                  "the strip at row 0 (its top 20000 rows of 100000 Float64 cells, down to row 19999) needs "
                  "16000000000 bytes decoded at once, more than the reader's limit of 1073741824 bytes"))
      << e.message;
}

// A deflate strip is decoded from its top down to the last row wanted, so a
// window pays only for those rows: 256 rows of 800 000 bytes = 204 800 000.
TEST(GeoTiffLimits, CountsOnlyTheRowsOfAStripAWindowNeeds) {
  TempDir dir;
  const std::string path = write(dir, "huge_strip.tif", huge_deflate_strip());
  ReadOptions o = plain_grid(std::uint64_t{64} << 20);
  o.window = Window{0, 0, 256, 256};
  auto top = read_geotiff(path, o);
  ASSERT_FALSE(top.ok());
  EXPECT_EQ(top.error().code, ErrorCode::kResourceExhausted);
  EXPECT_TRUE(has(top.error(), "its top 256 rows of 100000 Float64 cells, down to row 255) needs 204800000 bytes"))
      << top.error().message;
  EXPECT_TRUE(has(top.error(), "limit of 67108864 bytes")) << top.error().message;

  o.window = Window{1000, 300, 1100, 556};  // rows 300..555: the strip's top 556 rows
  auto lower = read_geotiff(path, o);
  ASSERT_FALSE(lower.ok());
  EXPECT_TRUE(has(lower.error(), "its top 556 rows of 100000 Float64 cells, down to row 555) needs 444800000 bytes"))
      << lower.error().message;

  // Strips of 100 rows (all 200 pointing at the same bytes): a window over
  // rows 150..449 needs the strip at row 100 down to row 199, then whole
  // strips; 100 rows of 800 000 bytes = 80 000 000.
  const std::string strips = raw_tiff({{256, kLong, 100000},
                                       {257, kLong, 20000},
                                       {258, kShort, 64},
                                       {259, kShort, 8},
                                       {262, kShort, 1},
                                       {273, kLong, kDataOffset, 200},
                                       {277, kShort, 1},
                                       {278, kLong, 100},
                                       {279, kLong, 16, 200},
                                       {339, kShort, 3}},
                                      std::string(16, '\0'));
  o.window = Window{0, 150, 10, 450};
  auto striped = read_geotiff(write(dir, "strips.tif", strips), o);
  ASSERT_FALSE(striped.ok());
  EXPECT_TRUE(has(striped.error(),
                  "the strip at row 100 (its top 100 rows of 100000 Float64 cells, down to row 199) "
                  "needs 80000000 bytes"))
      << striped.error().message;

  // Under the default limit the 256 rows are allowed: the read goes on to
  // decode, and fails there (the 16 bytes are not a deflate stream).
  o.max_block_bytes = ReadOptions{}.max_block_bytes;
  o.window = Window{0, 0, 256, 256};
  auto allowed = read_geotiff(path, o);
  ASSERT_FALSE(allowed.ok());
  EXPECT_EQ(allowed.error().code, ErrorCode::kDataError) << allowed.error().message;
  EXPECT_TRUE(has(allowed.error(), "cannot decode strip at col 0, row 0")) << allowed.error().message;
}

// A source's block of a one-strip file is the whole strip; it is refused
// before its 8 GB of cells are allocated (a RasterFile keeps the limit it
// was opened with).
TEST(GeoTiffLimits, SourceRefusesAHugeStripBeforeAllocatingItsCells) {
  TempDir dir;
  const std::string path = write(dir, "huge_strip.tif", huge_deflate_strip());
  SourceOptions so;
  so.allow_missing_crs = true;
  auto source = ElevationSource::open(path, so);
  ASSERT_TRUE(source.ok()) << source.error().message;
  BlockCache cache({.budget_bytes = 1 << 20, .io_threads = 1});
  auto dem = (*source)->read(Window{0, 0, 128, 128}, &cache);
  ASSERT_FALSE(dem.ok());
  EXPECT_EQ(dem.error().code, ErrorCode::kResourceExhausted);
  EXPECT_TRUE(has(dem.error(), "needs 16000000000 bytes decoded at once")) << dem.error().message;

  auto raster = open_raster(path, plain_grid(1000));
  ASSERT_TRUE(raster.ok()) << raster.error().message;
  auto cells = (*raster)->read_cells(Window{0, 0, 1, 1}, 1);  // one row: 800 000 bytes
  ASSERT_FALSE(cells.ok());
  EXPECT_TRUE(has(cells.error(), "needs 800000 bytes decoded at once, more than the reader's limit of 1000 bytes"))
      << cells.error().message;
}

// PixarLog decodes a strip whole (libtiff sizes its buffer by the strip), so
// even a one-row window counts the strip: 100 000 x 30 000 x 4 bytes.
TEST(GeoTiffLimits, CountsTheWholeStripForCodecsThatDecodeStripsWhole) {
  TempDir dir;
  const std::string path = write(dir, "pixarlog.tif", one_strip(100000, 30000, 32, 32909, std::string(16, '\0')));
  ReadOptions o = plain_grid();
  o.window = Window{0, 0, 10, 1};
  auto dem = read_geotiff(path, o);
  ASSERT_FALSE(dem.ok());
  EXPECT_EQ(dem.error().code, ErrorCode::kResourceExhausted);
  EXPECT_TRUE(has(dem.error(),
                  "the strip at row 0 (30000 rows of 100000 Float32 cells, which PixarLog decodes "
                  "whole) needs 12000000000 bytes decoded at once"))
      << dem.error().message;
}

TEST(GeoTiffLimits, CountsAWholeTile) {
  TempDir dir;
  // 65 536 x 65 536 Float32 cells in one tile: 17 179 869 184 bytes.
  const std::string bytes = raw_tiff({{256, kLong, 65536},
                                      {257, kLong, 65536},
                                      {258, kShort, 32},
                                      {259, kShort, 8},
                                      {262, kShort, 1},
                                      {277, kShort, 1},
                                      {322, kLong, 65536},
                                      {323, kLong, 65536},
                                      {324, kLong, kDataOffset},
                                      {325, kLong, 16},
                                      {339, kShort, 3}},
                                     std::string(16, '\0'));
  const std::string path = write(dir, "huge_tile.tif", bytes);
  ReadOptions o = plain_grid();
  o.window = Window{0, 0, 1, 1};
  auto dem = read_geotiff(path, o);
  ASSERT_FALSE(dem.ok());
  EXPECT_EQ(dem.error().code, ErrorCode::kResourceExhausted);
  EXPECT_TRUE(has(dem.error(), "the tile at col 0, row 0 (65536 rows of 65536 Float32 cells) needs 17179869184 bytes"))
      << dem.error().message;
}

// An honest 4 x 3 Float32 strip (48 bytes, uncompressed) reads with a limit
// of exactly 48 bytes, not with 47; its top row alone needs 16.
TEST(GeoTiffLimits, HonestFileReadsUpToTheLimitExactly) {
  TempDir dir;
  std::string data;
  for (int i = 0; i < 12; ++i) {
    const float v = 100.0f + static_cast<float>(i);
    char b[4];
    std::memcpy(b, &v, 4);  // little-endian host, as the file
    data.append(b, 4);
  }
  const std::string path = write(dir, "small.tif", one_strip(4, 3, 32, 1, data));
  auto dem = read_geotiff(path, plain_grid(48));
  ASSERT_TRUE(dem.ok()) << dem.error().message;
  ASSERT_EQ(dem->width(), 4);
  ASSERT_EQ(dem->height(), 3);
  EXPECT_EQ(dem->elevation.at(0, 0), 100.0f);
  EXPECT_EQ(dem->elevation.at(3, 2), 111.0f);

  auto refused = read_geotiff(path, plain_grid(47));
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().code, ErrorCode::kResourceExhausted);
  EXPECT_TRUE(has(refused.error(), "needs 48 bytes decoded at once, more than the reader's limit of 47 bytes"))
      << refused.error().message;

  ReadOptions top = plain_grid(16);
  top.window = Window{0, 0, 4, 1};
  auto row = read_geotiff(path, top);
  ASSERT_TRUE(row.ok()) << row.error().message;
  EXPECT_EQ(row->elevation.at(2, 0), 102.0f);

  auto unlimited = read_geotiff(path, plain_grid(0));  // 0: no limit
  ASSERT_TRUE(unlimited.ok()) << unlimited.error().message;
}

// `data` as a zlib stream (RFC 1950) of stored deflate blocks of up to
// 65 535 bytes each (RFC 1951 3.2.4): no compression, so it is written by
// hand, and the stream is as long as the data.
std::string zlib_stored(const std::string& data) {
  std::string out = "\x78\x01";  // zlib header
  std::size_t at = 0;
  do {
    const std::size_t n = std::min<std::size_t>(65535, data.size() - at);
    out.push_back(at + n == data.size() ? '\x01' : '\x00');  // BFINAL on the last block; BTYPE 00, stored
    put(out, n, 2);
    put(out, ~n & 0xffff, 2);
    out.append(data, at, n);
    at += n;
  } while (at < data.size());
  std::uint32_t a = 1, b = 0;  // Adler-32, stored big-endian
  for (unsigned char c : data) {
    a = (a + c) % 65521;
    b = (b + a) % 65521;
  }
  for (int shift : {24, 16, 8, 0}) out.push_back(static_cast<char>((((b << 16) | a) >> shift) & 0xff));
  return out;
}

// The bytes this process has read through read(2) and its kin so far
// (/proc/self/io's rchar, all threads), or nothing where that is not kept.
std::optional<std::uint64_t> bytes_read_so_far() {
  std::ifstream io("/proc/self/io");
  std::string key;
  std::uint64_t value = 0;
  while (io >> key >> value)
    if (key == "rchar:") return value;
  return std::nullopt;
}

// A tall strip's compressed bytes are not read whole for a window at its
// top: the reader maps such a file, and libtiff decodes the rows wanted
// from the mapping, touching only their bytes. Read through read(2)
// instead, libtiff takes in the whole strip, 8 MB here (stored, so as long
// as its cells), for 256 000 bytes of rows.
TEST(GeoTiffLimits, AWindowAtTheTopOfATallStripReadsWithoutTheWholeStrip) {
  TempDir dir;
  constexpr std::uint32_t kWidth = 1000, kRows = 2000;
  std::string cells(std::size_t{kWidth} * kRows * 4, '\0');
  for (std::uint32_t i = 0; i < kWidth * kRows; ++i) {
    const float v = static_cast<float>(i);  // row * 1000 + col, exact in a float
    std::memcpy(cells.data() + std::size_t{i} * 4, &v, 4);
  }
  const std::string path = write(dir, "tall.tif", one_strip(kWidth, kRows, 32, 8, zlib_stored(cells)));
  ReadOptions o = plain_grid(std::uint64_t{1} << 20);
  o.window = Window{10, 0, 30, 64};  // the top 64 rows: 256 000 bytes decoded
  const auto before = bytes_read_so_far();
  auto top = read_geotiff(path, o);
  const auto after = bytes_read_so_far();
  ASSERT_TRUE(top.ok()) << top.error().message;
  if (before && after) {
    EXPECT_LT(*after - *before, 1000000u) << "the read took in most of the strip's 8 MB";
  }
  ASSERT_EQ(top->width(), 20);
  ASSERT_EQ(top->height(), 64);
  EXPECT_EQ(top->elevation.at(0, 0), 10.0f);
  EXPECT_EQ(top->elevation.at(19, 63), 63029.0f);
  // The whole strip needs 8 000 000 bytes decoded: refused from the header.
  o.window.reset();
  auto whole = read_geotiff(path, o);
  ASSERT_FALSE(whole.ok());
  EXPECT_TRUE(has(whole.error(), "needs 8000000 bytes decoded at once")) << whole.error().message;
}

// A strip whose byte count runs past the end of the file is refused as
// truncated before it is decoded, whatever its codec. Here the strip is a
// valid deflate stream of 48 bytes followed by padding, and its count claims
// 2 000 000 bytes: libtiff alone would cut the count to 10 x the strip +
// 4 KiB, which fits in the file, and decode it as if nothing were wrong.
TEST(GeoTiffLimits, RejectsAStripRunningPastTheEndBeforeDecoding) {
  TempDir dir;
  const std::string data = zlib_stored(std::string(48, '\0')) + std::string(8000, '\0');
  auto honest = read_geotiff(write(dir, "honest.tif", one_strip(4, 3, 32, 8, data)), plain_grid());
  ASSERT_TRUE(honest.ok()) << honest.error().message;  // the stream itself is sound
  EXPECT_EQ(honest->elevation.at(3, 2), 0.0f);

  const std::string bytes = one_strip(4, 3, 32, 8, data, 2000000);
  const std::string path = write(dir, "past_end.tif", bytes);
  auto dem = read_geotiff(path, plain_grid());
  ASSERT_FALSE(dem.ok());
  EXPECT_EQ(dem.error().code, ErrorCode::kDataError);
  EXPECT_TRUE(has(dem.error(), "the file is truncated: it has " + std::to_string(bytes.size()) +
                                   " bytes, but the strip at col 0, row 0 lies at bytes 134..2000134"))
      << dem.error().message;
}

}  // namespace
}  // namespace horizon::terrain
