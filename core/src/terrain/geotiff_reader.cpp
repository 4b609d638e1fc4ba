// geotiff_reader.cpp — single-band GeoTIFF DEMs into terrain::Dem.
//
// Formats and specifications:
//   * TIFF 6.0 (Adobe, 1992) and BigTIFF; pixels are decoded by libtiff, so
//     any layout and compression it handles works (striped or tiled; none,
//     LZW, deflate, ZSTD, ...), block by block, only the blocks a window
//     needs, on several threads. (OpenImageIO 2.4 was used for full reads
//     before: it decodes tiled Float64 as zeros, decodes on one thread, and
//     loading it costs a process ~0.3 s of start-up; see imageio.hpp.)
//   * OGC GeoTIFF 1.1 (OGC 19-008r4): ModelPixelScaleTag (33550) +
//     ModelTiepointTag (33922), or ModelTransformationTag (34264); GeoKeys
//     GTModelTypeGeoKey (1024), GTRasterTypeGeoKey (1025) and the CRS keys
//     (geotiff_crs.hpp: EPSG codes, user-defined CRSs, vertical CRS), read
//     with libgeotiff because OIIO exposes none of them (TOOLCHAIN.md).
//   * GDAL_NODATA (TIFF tag 42113, ASCII, e.g. "-32768" or "nan"), GDAL's
//     private tag, described at https://gdal.org/drivers/raster/gtiff.html.
//
// Geometry: Horizon's GeoTransform always describes the outer corner of cell
// (0, 0) ("PixelIsArea"). A PixelIsPoint file's tiepoint names the *centre*
// of a cell, so its origin moves back by half a cell — as GDAL does.
// Rotated or sheared transforms are rejected: every algorithm downstream
// assumes rows run east-west.
//
// Pixel types: Int16, UInt16, Int32, Float32, Float64 for DEMs, and UInt8
// and UInt32 so that Horizon's own results (viewsheds, observer counts) read
// back (UInt32 values past 2^24 round to float32).
// Memory: a header may claim any size, so the cost of a read is bounded from
// the header before anything is decoded: a block (tile, or a strip down to
// the window's last row; a whole strip for codecs that decode strips whole)
// needing more than ReadOptions::max_block_bytes is a kResourceExhausted
// error naming it, and every single allocation libtiff makes for the file is
// held to the same figure. A block whose bytes run past the end of the file
// is refused as truncated before it is decoded.
// Values: integer pixels are converted to float32 exactly (|v| < 2^24 for any
// real elevation); cells equal to the GDAL_NODATA code become NaN and
// Dem::nodata keeps the code for writers.
#include <sys/stat.h>

#include <algorithm>
#include <cassert>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <type_traits>
#include <vector>

#include "geokeys.hpp"
#include "geotiff_crs.hpp"
#include "horizon/common/parallel.hpp"
#include "horizon/terrain/dem_reader.hpp"
#include "tiff_predictor.hpp"
#include "tiff_support.hpp"

#ifdef __SSE2__
#include <immintrin.h>
#endif

namespace horizon::terrain {
namespace {

using detail::CrsKeys;
using detail::read_crs_keys;
using detail::TiffMessages;
using detail::TiffPtr;

// Cells we are willing to hold (8 GiB of float32); more is a resource error.
constexpr std::uint64_t kMaxCells = std::uint64_t{1} << 31;

// The bound on each allocation libtiff makes for a file read under a block
// limit (ReadOptions::max_block_bytes; 0 = none): the limit itself, but never
// below 16 MiB, which libtiff's own tables need whatever the blocks (the
// handle, a codec's state and code tables, the offset and byte-count arrays
// of up to a million strips, 8 MB each).
std::uint64_t libtiff_alloc_limit(std::uint64_t max_block_bytes) {
  constexpr std::uint64_t kFloor = std::uint64_t{16} << 20;
  return max_block_bytes == 0 ? 0 : std::max(max_block_bytes, kFloor);
}

Error dem_error(ErrorCode code, const std::string& path, const std::string& what) {
  return make_error(code, "dem '" + path + "': " + what, path);
}

std::string compression_name(std::uint16_t c) {
  switch (c) {
    case COMPRESSION_NONE:
      return "uncompressed";
    case COMPRESSION_LZW:
      return "LZW";
    case COMPRESSION_ADOBE_DEFLATE:
    case COMPRESSION_DEFLATE:
      return "deflate";
    case COMPRESSION_PACKBITS:
      return "PackBits";
    case COMPRESSION_JPEG:
      return "JPEG";
    case COMPRESSION_OJPEG:
      return "old-style JPEG";
    case COMPRESSION_PIXARLOG:
      return "PixarLog";
    case COMPRESSION_SGILOG:
    case COMPRESSION_SGILOG24:
      return "LogLuv";
    case COMPRESSION_JBIG:
      return "JBIG";
    case COMPRESSION_LZMA:
      return "LZMA";
    case COMPRESSION_ZSTD:
      return "ZSTD";
    case COMPRESSION_WEBP:
      return "WebP";
    case COMPRESSION_LERC:
      return "LERC";
    default:
      return "compression " + std::to_string(c);
  }
}

std::optional<double> parse_nodata(const char* text) {
  if (!text) return std::nullopt;
  std::string s(text);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\0' || s.back() == '\n')) s.pop_back();
  std::size_t start = s.find_first_not_of(' ');
  if (start == std::string::npos) return std::nullopt;
  s = s.substr(start);
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(s.c_str(), &end);  // accepts "nan", "-inf", "1e38"
  if (end == s.c_str() || *end != '\0') return std::nullopt;
  return v;
}

// The pixel types we read, from the TIFF's SampleFormat and BitsPerSample.
enum class PixelType { kUInt8, kInt16, kUInt16, kInt32, kUInt32, kFloat32, kFloat64 };

const char* pixel_type_name(PixelType t) {
  switch (t) {
    case PixelType::kUInt8:
      return "UInt8";
    case PixelType::kInt16:
      return "Int16";
    case PixelType::kUInt16:
      return "UInt16";
    case PixelType::kInt32:
      return "Int32";
    case PixelType::kUInt32:
      return "UInt32";
    case PixelType::kFloat32:
      return "Float32";
    case PixelType::kFloat64:
      return "Float64";
  }
  return "?";
}

std::size_t pixel_type_size(PixelType t) {
  switch (t) {
    case PixelType::kUInt8:
      return 1;
    case PixelType::kInt16:
    case PixelType::kUInt16:
      return 2;
    case PixelType::kInt32:
    case PixelType::kUInt32:
    case PixelType::kFloat32:
      return 4;
    case PixelType::kFloat64:
      return 8;
  }
  return 0;
}

struct TiffFacts {
  Georeference georef;
  std::optional<double> nodata;
  std::string layout;  // "deflate, tiled 256x256"
  bool bigtiff = false;
  // Pixel layout, as libtiff reports it.
  int width = 0, height = 0;
  int samples = 1;
  bool planar_separate = false;
  std::uint16_t bits = 0, sample_format = SAMPLEFORMAT_UINT;
  bool tiled = false;
  int block_width = 0, block_height = 0;  // a tile, or a strip (width x rows per strip)
  std::uint64_t blocks_per_plane = 0;
  std::uint16_t compression = COMPRESSION_NONE;
  std::uint64_t block_bytes = 0;  // one whole tile or strip of one plane, decoded (libtiff's count)
  std::uint16_t predictor = PREDICTOR_NONE;
  bool own_predictor = false;  // undone by tiff_predictor.hpp rather than by libtiff
  // What ReadOptions asked for, checked against the layout.
  int channel = 0;  // 0-based sample of the chosen band
  PixelType type = PixelType::kUInt8;
};

// Codecs that may carry a predictor (libtiff registers TIFFTAG_PREDICTOR for them).
bool takes_predictor(std::uint16_t compression) {
  switch (compression) {
    case COMPRESSION_LZW:
    case COMPRESSION_ADOBE_DEFLATE:
    case COMPRESSION_DEFLATE:
    case COMPRESSION_LZMA:
    case COMPRESSION_ZSTD:
      return true;
    default:
      return false;
  }
}

Result<int> channel_of(const ReadOptions& options, int bands, const std::string& path);
Result<PixelType> pixel_type_of(const TiffFacts& f, const std::string& path);

// A TIFF whose first directory (TIFF 6.0 section 2: its offset in bytes
// 4-7, BigTIFF's in bytes 8-15; a count of entries, 12 bytes each, 20 in
// BigTIFF) runs past the end of the file: a file cut short, said as such
// rather than as libtiff's directory error.
std::optional<std::string> truncated_header(const std::string& path) {
  std::error_code ec;
  const std::uintmax_t size = std::filesystem::file_size(path, ec);
  std::FILE* file = ec ? nullptr : std::fopen(path.c_str(), "rb");
  if (!file) return std::nullopt;
  auto read_at = [&](std::uint64_t at, unsigned char* out, std::size_t n) {
    return at + n <= size && std::fseek(file, static_cast<long>(at), SEEK_SET) == 0 && std::fread(out, 1, n, file) == n;
  };
  unsigned char head[16] = {};
  const bool have_head = read_at(0, head, 8) && (head[0] == 'I' || head[0] == 'M');
  const bool little = head[0] == 'I';
  const bool big_tiff = (little ? head[2] : head[3]) == 43;
  const std::size_t width = big_tiff ? 8 : 4;
  auto number = [&](const unsigned char* b, std::size_t n) {
    std::uint64_t v = 0;
    for (std::size_t i = 0; i < n; ++i) v |= static_cast<std::uint64_t>(b[little ? i : n - 1 - i]) << (8 * i);
    return v;
  };
  std::optional<std::string> cut;
  const auto says = [&](std::uint64_t needed, const std::string& what) {
    return "the file is truncated: it has " + std::to_string(size) + " bytes, but " + what + " runs to byte " +
           std::to_string(needed) + " (a copy or download that stopped early?)";
  };
  if (have_head && (!big_tiff || read_at(0, head, 16))) {
    const std::uint64_t offset = number(head + (big_tiff ? 8 : 4), width);
    unsigned char count_bytes[8] = {};
    const std::size_t count_width = big_tiff ? 8 : 2;
    if (offset + count_width > size) {
      cut = says(offset + count_width, "its first directory");
    } else if (read_at(offset, count_bytes, count_width)) {
      const std::uint64_t entries = number(count_bytes, count_width);
      const std::uint64_t end = offset + count_width + entries * (big_tiff ? 20 : 12) + width;
      if (end > size) cut = says(end, "its first directory, of " + std::to_string(entries) + " entries,");
    }
  }
  std::fclose(file);
  return cut;
}

// Reads georeferencing, nodata and layout through libtiff + libgeotiff.
Result<TiffFacts> read_tiff_facts(const std::string& path, const ReadOptions& options) {
  TiffMessages messages;
  TiffPtr tif = detail::open_tiff(path, "r", messages, libtiff_alloc_limit(options.max_block_bytes));
  if (!tif) {
    if (auto cut = truncated_header(path)) return dem_error(ErrorCode::kDataError, path, *cut);
    return dem_error(
        ErrorCode::kDataError, path,
        "not a raster (not a readable TIFF" + (messages.errors.empty() ? std::string() : ": " + messages.errors) + ")");
  }

  TiffFacts facts;
  facts.bigtiff = TIFFIsBigTIFF(tif.get()) != 0;
  std::uint32_t width = 0, height = 0;
  std::uint16_t samples = 1, planar = PLANARCONFIG_CONTIG;
  TIFFGetField(tif.get(), TIFFTAG_IMAGEWIDTH, &width);
  TIFFGetField(tif.get(), TIFFTAG_IMAGELENGTH, &height);
  TIFFGetFieldDefaulted(tif.get(), TIFFTAG_SAMPLESPERPIXEL, &samples);
  TIFFGetFieldDefaulted(tif.get(), TIFFTAG_PLANARCONFIG, &planar);
  TIFFGetFieldDefaulted(tif.get(), TIFFTAG_BITSPERSAMPLE, &facts.bits);
  TIFFGetFieldDefaulted(tif.get(), TIFFTAG_SAMPLEFORMAT, &facts.sample_format);
  if (width == 0 || height == 0 || width > 0x7fffffffu || height > 0x7fffffffu || samples == 0)
    return dem_error(ErrorCode::kDataError, path, "has no 2-D pixel grid");
  facts.width = static_cast<int>(width);
  facts.height = static_cast<int>(height);
  facts.samples = samples;
  // The band and the pixel type before the georeferencing: a layout problem
  // is the first thing to tell.
  auto channel = channel_of(options, facts.samples, path);
  if (!channel.ok()) return channel.error();
  auto type = pixel_type_of(facts, path);
  if (!type.ok()) return type.error();
  facts.channel = *channel;
  facts.type = *type;
  facts.planar_separate = planar == PLANARCONFIG_SEPARATE && samples > 1;
  facts.tiled = TIFFIsTiled(tif.get()) != 0;
  if (facts.tiled) {
    std::uint32_t tw = 0, th = 0;
    TIFFGetField(tif.get(), TIFFTAG_TILEWIDTH, &tw);
    TIFFGetField(tif.get(), TIFFTAG_TILELENGTH, &th);
    if (tw == 0 || th == 0 || tw > 0x7fffffffu || th > 0x7fffffffu)
      return dem_error(ErrorCode::kDataError, path, "inconsistent tile layout");
    facts.block_width = static_cast<int>(tw);
    facts.block_height = static_cast<int>(th);
  } else {
    std::uint32_t rows_per_strip = height;
    TIFFGetFieldDefaulted(tif.get(), TIFFTAG_ROWSPERSTRIP, &rows_per_strip);
    facts.block_width = facts.width;
    facts.block_height = static_cast<int>(std::clamp<std::uint32_t>(rows_per_strip, 1, height));
  }
  // In 64 bits: a width and a block width near 2^31 overflow an int.
  const auto blocks_along = [](std::int64_t cells, std::int64_t block) {
    return static_cast<std::uint64_t>((cells + block - 1) / block);
  };
  facts.blocks_per_plane =
      blocks_along(facts.width, facts.block_width) * blocks_along(facts.height, facts.block_height);
  TIFFGetFieldDefaulted(tif.get(), TIFFTAG_COMPRESSION, &facts.compression);
  facts.block_bytes = facts.tiled ? TIFFTileSize64(tif.get()) : TIFFStripSize64(tif.get());
  if (facts.block_bytes == 0) return dem_error(ErrorCode::kDataError, path, "inconsistent block layout");
  // Only these codecs register the predictor tag (asking another codec for
  // it would read its state as a predictor's).
  if (takes_predictor(facts.compression)) TIFFGetField(tif.get(), TIFFTAG_PREDICTOR, &facts.predictor);
  facts.own_predictor = detail::predictor_is_ours(facts.predictor, facts.bits, facts.planar_separate ? 1 : samples,
                                                  TIFFIsByteSwapped(tif.get()) != 0);
  facts.layout = compression_name(facts.compression);
  if (TIFFIsTiled(tif.get())) {
    std::uint32_t tw = 0, th = 0;
    TIFFGetField(tif.get(), TIFFTAG_TILEWIDTH, &tw);
    TIFFGetField(tif.get(), TIFFTAG_TILELENGTH, &th);
    facts.layout += ", tiled " + std::to_string(tw) + "x" + std::to_string(th);
  } else {
    facts.layout += ", striped";
  }

  char* nodata_text = nullptr;
  if (TIFFGetField(tif.get(), detail::kTagGdalNodata, &nodata_text) == 1) {
    facts.nodata = parse_nodata(nodata_text);
    if (!facts.nodata)
      return dem_error(ErrorCode::kDataError, path,
                       std::string("GDAL_NODATA tag '") + nodata_text + "' is not a number");
  }

  // --- Geotransform -----------------------------------------------------
  const std::vector<double> scale = detail::tiff_doubles(tif.get(), detail::kTagModelPixelScale);
  const std::vector<double> ties = detail::tiff_doubles(tif.get(), detail::kTagModelTiepoint);
  const std::vector<double> matrix = detail::tiff_doubles(tif.get(), detail::kTagModelTransformation);
  GeoTransform& t = facts.georef.transform;
  bool has_transform = false;
  if (scale.size() >= 2 && ties.size() >= 6) {
    // Tiepoint (I, J, K) -> (X, Y, Z); raster rows grow down, so y = Y - (j - J) * Sy.
    t.pixel_width = scale[0];
    t.pixel_height = -scale[1];
    t.origin_x = ties[3] - ties[0] * scale[0];
    t.origin_y = ties[4] + ties[1] * scale[1];
    has_transform = true;
  } else if (matrix.size() >= 16) {
    // x = m0 i + m1 j + m3, y = m4 i + m5 j + m7 (GeoTIFF 1.1, B.6).
    const double a = matrix[0], b = matrix[1], d = matrix[3];
    const double e = matrix[4], f = matrix[5], h = matrix[7];
    const double size = std::max(std::abs(a), std::abs(f));
    if (std::abs(b) > 1e-12 * size || std::abs(e) > 1e-12 * size)
      return dem_error(ErrorCode::kUnsupported, path,
                       "rotated or sheared geotransform (ModelTransformation terms " + std::to_string(b) + ", " +
                           std::to_string(e) + ") is not supported; warp it north-up first (e.g. gdalwarp)");
    t = GeoTransform{d, a, h, f};
    has_transform = true;
  } else if (ties.size() >= 12) {
    return dem_error(ErrorCode::kUnsupported, path,
                     "georeferenced by " + std::to_string(ties.size() / 6) +
                         " ground control points, not a geotransform; warp it first (e.g. gdalwarp)");
  }
  if (has_transform) {
    if (!std::isfinite(t.origin_x) || !std::isfinite(t.origin_y) || !std::isfinite(t.pixel_width) ||
        !std::isfinite(t.pixel_height) || t.pixel_height == 0.0)
      return dem_error(ErrorCode::kDataError, path, "geotransform is degenerate (zero or non-finite cell size)");
    if (t.pixel_width <= 0.0)
      return dem_error(ErrorCode::kUnsupported, path,
                       "east-west mirrored raster (negative pixel width) is not supported");
  }

  // --- GeoKeys ----------------------------------------------------------
  auto geokeys = detail::GeoKeys::read(tif.get());
  if (!geokeys.ok())
    return dem_error(ErrorCode::kDataError, path, "GeoKeyDirectory is corrupt (" + geokeys.error().message + ")");
  if (geokeys->short_value(GTRasterTypeGeoKey) == RasterPixelIsPoint && has_transform) {
    t.origin_x -= 0.5 * t.pixel_width;
    t.origin_y -= 0.5 * t.pixel_height;
  }
  const CrsKeys crs = read_crs_keys(*geokeys, tif.get());
  if (!has_transform && !options.allow_missing_crs)
    return dem_error(ErrorCode::kDataError, path,
                     "has no georeferencing (no ModelPixelScale/ModelTiepoint or ModelTransformation tags); "
                     "set allow_missing_crs to read it as a plain grid");
  if (crs.absent && !options.allow_missing_crs)
    return dem_error(ErrorCode::kUnsupported, path, crs.problem + "; set allow_missing_crs to read it as a plain grid");
  if (!crs.problem.empty() && !options.allow_missing_crs)
    return dem_error(ErrorCode::kUnsupported, path, "its CRS cannot be used: " + crs.problem);
  if (!has_transform) t = GeoTransform{};  // grid coordinates: x = col + 0.5, y = -(row + 0.5)
  facts.georef.epsg = crs.epsg;
  facts.georef.crs = crs.crs;
  if (!crs.absent) facts.georef.crs_problem = crs.problem;
  return facts;
}

// The pixel type of the facts, or the unsupported-type error.
Result<PixelType> pixel_type_of(const TiffFacts& f, const std::string& path) {
  const std::uint16_t fmt = f.sample_format, bits = f.bits;
  if (fmt == SAMPLEFORMAT_UINT && bits == 8) return PixelType::kUInt8;
  if (fmt == SAMPLEFORMAT_INT && bits == 16) return PixelType::kInt16;
  if (fmt == SAMPLEFORMAT_UINT && bits == 16) return PixelType::kUInt16;
  if (fmt == SAMPLEFORMAT_INT && bits == 32) return PixelType::kInt32;
  if (fmt == SAMPLEFORMAT_UINT && bits == 32) return PixelType::kUInt32;
  if (fmt == SAMPLEFORMAT_IEEEFP && bits == 32) return PixelType::kFloat32;
  if (fmt == SAMPLEFORMAT_IEEEFP && bits == 64) return PixelType::kFloat64;
  const char* kind = fmt == SAMPLEFORMAT_INT ? "int" : fmt == SAMPLEFORMAT_IEEEFP ? "float" : "uint";
  return dem_error(ErrorCode::kUnsupported, path,
                   std::string("pixel type ") + kind + std::to_string(bits) +
                       " is not supported (UInt8, Int16, UInt16, Int32, UInt32, Float32 and Float64 are)");
}

// The 0-based channel for options.band against `bands`, or the band error.
Result<int> channel_of(const ReadOptions& options, int bands, const std::string& path) {
  if (options.band == 0 && bands != 1)
    return make_error(ErrorCode::kInvalidArgument,
                      "dem '" + path + "': the file has " + std::to_string(bands) +
                          " bands; choose one with band = 1.." + std::to_string(bands),
                      "band");
  if (options.band > bands)
    return make_error(
        ErrorCode::kInvalidArgument,
        "dem '" + path + "': band " + std::to_string(options.band) + " requested, file has " + std::to_string(bands),
        "band");
  return options.band == 0 ? 0 : options.band - 1;
}

// Converts `count` native samples of type T, `stride` bytes apart (several
// bands interleaved), to float elevations, replacing the nodata code by NaN.
template <class T>
void convert_run(const unsigned char* src, std::size_t stride, int count, float* dst, std::optional<double> nodata) {
  constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
  bool use = false;
  T code{};
  if constexpr (std::is_integral_v<T>) {
    // An integer code only matches when it is an exact value of T.
    use = nodata && std::isfinite(*nodata) && std::floor(*nodata) == *nodata &&
          *nodata >= static_cast<double>(std::numeric_limits<T>::lowest()) &&
          *nodata <= static_cast<double>(std::numeric_limits<T>::max());
  } else {
    // Float files compare in the file's own precision (GDAL does the same).
    use = nodata && !std::isnan(*nodata);
  }
  if (use) code = static_cast<T>(*nodata);
  int i = 0;
#ifdef __SSE2__
  // One band, samples side by side, of the two commonest DEM types: eight
  // Int16 or four Float32 samples a step. (The compiler leaves the general
  // loop below scalar, a conversion, a compare and a store a sample.)
  if constexpr (std::is_same_v<T, std::int16_t>) {
    if (stride == sizeof(T)) {
      const __m128i codes = _mm_set1_epi16(use ? code : 0);
      const __m128i matching = use ? _mm_set1_epi16(-1) : _mm_setzero_si128();
      const __m128 nan = _mm_set1_ps(kNaN);
      for (; i + 8 <= count; i += 8) {
        const __m128i v = _mm_loadu_si128(reinterpret_cast<const __m128i*>(src + 2 * static_cast<std::size_t>(i)));
        const __m128i is_void = _mm_and_si128(_mm_cmpeq_epi16(v, codes), matching);
        // Sign-extended halves: each sample into the high half of a 32-bit
        // lane, then shifted down arithmetically (SSE2 has no pmovsxwd).
        const __m128 lo = _mm_cvtepi32_ps(_mm_srai_epi32(_mm_unpacklo_epi16(v, v), 16));
        const __m128 hi = _mm_cvtepi32_ps(_mm_srai_epi32(_mm_unpackhi_epi16(v, v), 16));
        const __m128 void_lo = _mm_castsi128_ps(_mm_unpacklo_epi16(is_void, is_void));
        const __m128 void_hi = _mm_castsi128_ps(_mm_unpackhi_epi16(is_void, is_void));
        _mm_storeu_ps(dst + i, _mm_or_ps(_mm_andnot_ps(void_lo, lo), _mm_and_ps(void_lo, nan)));
        _mm_storeu_ps(dst + i + 4, _mm_or_ps(_mm_andnot_ps(void_hi, hi), _mm_and_ps(void_hi, nan)));
      }
    }
  } else if constexpr (std::is_same_v<T, float>) {
    if (stride == sizeof(T)) {
      const __m128 codes = _mm_set1_ps(use ? code : 0.0f);
      const __m128 matching = _mm_castsi128_ps(use ? _mm_set1_epi32(-1) : _mm_setzero_si128());
      const __m128 nan = _mm_set1_ps(kNaN);
      for (; i + 4 <= count; i += 4) {
        const __m128 v = _mm_loadu_ps(reinterpret_cast<const float*>(src + 4 * static_cast<std::size_t>(i)));
        const __m128 is_void = _mm_and_ps(_mm_cmpeq_ps(v, codes), matching);
        _mm_storeu_ps(dst + i, _mm_or_ps(_mm_andnot_ps(is_void, v), _mm_and_ps(is_void, nan)));
      }
    }
  }
#endif
  for (; i < count; ++i) {
    T v;
    std::memcpy(&v, src + static_cast<std::size_t>(i) * stride, sizeof(T));
    dst[i] = (use && v == code) ? kNaN : static_cast<float>(v);
  }
}

void convert_any(PixelType type, const unsigned char* src, std::size_t stride, int count, float* dst,
                 std::optional<double> nodata) {
  switch (type) {
    case PixelType::kUInt8:
      return convert_run<std::uint8_t>(src, stride, count, dst, nodata);
    case PixelType::kInt16:
      return convert_run<std::int16_t>(src, stride, count, dst, nodata);
    case PixelType::kUInt16:
      return convert_run<std::uint16_t>(src, stride, count, dst, nodata);
    case PixelType::kInt32:
      return convert_run<std::int32_t>(src, stride, count, dst, nodata);
    case PixelType::kUInt32:
      return convert_run<std::uint32_t>(src, stride, count, dst, nodata);
    case PixelType::kFloat32:
      return convert_run<float>(src, stride, count, dst, nodata);
    case PixelType::kFloat64:
      return convert_run<double>(src, stride, count, dst, nodata);
  }
}

// Widens [lo, hi] to take in the values of `row` that are not voids (NaN).
void widen_value_range(const float* row, int count, float& lo, float& hi) {
  int i = 0;
#ifdef __SSE2__
  // minps / maxps return their second operand when the first is NaN, so a
  // void leaves the running bounds as they are.
  // Two pairs of running bounds, so that each min and max waits on the one
  // two iterations back rather than the last.
  __m128 l = _mm_set1_ps(lo), h = _mm_set1_ps(hi), l2 = l, h2 = h;
  for (; i + 8 <= count; i += 8) {
    const __m128 v = _mm_loadu_ps(row + i), w = _mm_loadu_ps(row + i + 4);
    l = _mm_min_ps(v, l);
    h = _mm_max_ps(v, h);
    l2 = _mm_min_ps(w, l2);
    h2 = _mm_max_ps(w, h2);
  }
  for (; i + 4 <= count; i += 4) {
    const __m128 v = _mm_loadu_ps(row + i);
    l = _mm_min_ps(v, l);
    h = _mm_max_ps(v, h);
  }
  // The pairs' bounds are never NaN (min/max keep their second operand).
  l = _mm_min_ps(l, l2);
  h = _mm_max_ps(h, h2);
  alignas(16) float ls[4], hs[4];
  _mm_store_ps(ls, l);
  _mm_store_ps(hs, h);
  for (int k = 0; k < 4; ++k) {
    lo = std::min(lo, ls[k]);
    hi = std::max(hi, hs[k]);
  }
#endif
  for (; i < count; ++i) {
    lo = row[i] < lo ? row[i] : lo;
    hi = row[i] > hi ? row[i] : hi;
  }
}

// Bytes from one pixel of a block row to the next: the pixel type times the
// bands interleaved with it.
std::size_t pixel_stride(const TiffFacts& f) {
  const std::size_t bytes = pixel_type_size(f.type);
  return f.planar_separate ? bytes : bytes * static_cast<std::size_t>(f.samples);
}

// Codecs that decode a strip into the caller's buffer row after row and stop
// where the buffer ends, holding nothing of the strip's size themselves: a
// window at the top of a tall strip costs only its rows. Every other codec
// (JPEG, old JPEG, PixarLog, LogLuv, LERC, WebP, JBIG, ...) keeps a whole
// strip or tile, or more, in buffers of its own.
bool decodes_strips_partly(std::uint16_t compression) {
  switch (compression) {
    case COMPRESSION_NONE:
    case COMPRESSION_LZW:
    case COMPRESSION_ADOBE_DEFLATE:
    case COMPRESSION_DEFLATE:
    case COMPRESSION_PACKBITS:
    case COMPRESSION_LZMA:
    case COMPRESSION_ZSTD:
      return true;
    default:
      return false;
  }
}

// Bytes of the buffer that decodes the top `rows` rows of a strip of
// `block_bytes`, `row_pitch` bytes a row: never more than the whole strip.
std::uint64_t strip_top_bytes(std::uint64_t block_bytes, std::uint64_t row_pitch, int rows) {
  const auto n = static_cast<std::uint64_t>(rows);
  return row_pitch != 0 && n <= block_bytes / row_pitch ? n * row_pitch : block_bytes;
}

// Refuses, before anything is decoded, a read of `window` whose biggest
// block needs more than `limit` bytes at once (ReadOptions::max_block_bytes;
// 0 = no limit). Each thread holds one such buffer, and libtiff a codec's or
// predictor's copy beside it, so this bounds the read's memory whatever the
// header claims.
Status check_block_cost(const std::string& path, const TiffFacts& f, const Window& window, std::uint64_t limit) {
  if (limit == 0) return Status::Ok();
  const std::size_t stride = pixel_stride(f);
  const int bw = f.block_width, bh = f.block_height;
  const int first_row = window.row0 / bh * bh, first_col = window.col0 / bw * bw;
  const bool whole = f.tiled || !decodes_strips_partly(f.compression);
  // The first block under the window costs the most: a strip is needed from
  // its top down to the window's end, or whole when the window runs past it
  // (the strips below then cost no more; the image's last may be shorter).
  const int rows = std::min(bh, window.row1 - first_row);
  const std::uint64_t row_pitch = static_cast<std::uint64_t>(bw) * stride;
  const std::uint64_t need = whole ? f.block_bytes : strip_top_bytes(f.block_bytes, row_pitch, rows);
  if (need <= limit) return Status::Ok();
  std::string cells = std::to_string(bw) + " " + pixel_type_name(f.type) + " cells";
  if (f.samples > 1 && !f.planar_separate) cells += " of " + std::to_string(f.samples) + " bands";
  std::string what;
  if (f.tiled) {
    what = "the tile at col " + std::to_string(first_col) + ", row " + std::to_string(first_row) + " (" +
           std::to_string(bh) + " rows of " + cells + ")";
  } else {
    what = "the strip at row " + std::to_string(first_row) + " (" +
           (whole ? std::to_string(std::min(bh, f.height - first_row)) + " rows of " + cells + ", which " +
                        compression_name(f.compression) + " decodes whole"
                  : "its top " + std::to_string(rows) + " rows of " + cells + ", down to row " +
                        std::to_string(first_row + rows - 1)) +
           ")";
  }
  return dem_error(ErrorCode::kResourceExhausted, path,
                   what + " needs " + std::to_string(need) +
                       " bytes decoded at once, more than the reader's limit of " + std::to_string(limit) +
                       " bytes (max_block_bytes); re-tile the file (e.g. gdal_translate -co TILED=YES) or raise "
                       "the limit");
}

// When a block's bytes, as the file's own offsets and counts place them, run
// past the end of the file: the file is cut short (a copy or a download that
// stopped). Checked before each block is decoded, whatever the codec, so such
// a block is refused before libtiff sizes anything from it. `block_name()`
// names the block, made only for the message.
template <class BlockName>
std::optional<std::string> truncation(std::uint64_t file_size, TIFF* tif, std::uint32_t index,
                                      const BlockName& block_name) {
  const std::uint64_t start = TIFFGetStrileOffset(tif, index), count = TIFFGetStrileByteCount(tif, index);
  if (count <= file_size && start <= file_size - count) return std::nullopt;
  return "the file is truncated: it has " + std::to_string(file_size) + " bytes, but the " + block_name() +
         " lies at bytes " + std::to_string(start) + ".." + std::to_string(start + count) +
         " (a copy or download that stopped early?)";
}

// One libtiff handle and its decode buffer, lent to one block at a time
// (a handle is not thread-safe). libtiff writes every byte it reports, so
// the buffer is left uninitialised, and grown only as far as the blocks
// read need: a strip is decoded down to the window's last row in it and no
// further (a 256-row window at the top of a one-strip file of 65 000 rows
// decodes 256 rows, and touches no more memory).
struct Reader {
  TiffMessages messages;
  TiffPtr tif;
  std::unique_ptr<unsigned char[]> block;
  std::uint64_t capacity = 0;
  std::vector<unsigned char> samples;  // a row's samples, floating-point predictor undone
};

// Whether libtiff should map the file to read the blocks of `f` rather than
// read(2) each block's bytes into a buffer of its own. Mapped, a block's
// pages fault in one by one, each a trip through the kernel (and, on a VM
// whose hypervisor shadows the page tables, through the hypervisor too:
// the 12 M-cell DEM's read took 78 ms mapped and 39 ms read on the AMD
// EPYC PVM, docs/benchmarks.md). Read, libtiff takes a block's compressed
// bytes whole: so a big strip, which a window may need only the top of, is
// still mapped, and its pages below the rows decoded are never touched.
bool map_for_blocks(const TiffFacts& f) {
  constexpr std::uint64_t kBigStripBytes = std::uint64_t{1} << 20;
  return !f.tiled && decodes_strips_partly(f.compression) && f.block_bytes > kBigStripBytes;
}

// The readers of one read: as many as blocks run at once, each opened on
// first need and kept for the next block.
class ReaderPool {
 public:
  // `own_predictor`: libtiff's predictor is turned off on each handle
  // (TiffFacts::own_predictor), the reader undoing it. `mapped`: libtiff
  // maps the file (map_for_blocks).
  ReaderPool(const std::string& path, std::uint64_t max_block_bytes, bool own_predictor, bool mapped)
      : path_(path), limit_(max_block_bytes), own_predictor_(own_predictor), mapped_(mapped) {}
  // A reader, or one whose `tif` is null (its messages say why).
  std::unique_ptr<Reader> take() {
    {
      std::lock_guard lock(mutex_);
      if (!idle_.empty()) {
        auto r = std::move(idle_.back());
        idle_.pop_back();
        return r;
      }
    }
    auto r = std::make_unique<Reader>();
    r->tif = detail::open_tiff(path_, mapped_ ? "r" : "rm", r->messages, libtiff_alloc_limit(limit_));
    // Before the first decode, which sets libtiff's predictor up.
    if (r->tif && own_predictor_) TIFFSetField(r->tif.get(), TIFFTAG_PREDICTOR, PREDICTOR_NONE);
    return r;
  }
  void give_back(std::unique_ptr<Reader> r) {
    std::lock_guard lock(mutex_);
    idle_.push_back(std::move(r));
  }

 private:
  const std::string& path_;
  std::uint64_t limit_;
  bool own_predictor_;
  bool mapped_;
  std::mutex mutex_;
  std::vector<std::unique_ptr<Reader>> idle_;
};

// Decodes only the blocks (tiles or strips) of one channel that intersect
// `window`, straight through libtiff, and converts them into `out` (window-
// sized float elevations, nodata as NaN). Each block is one task on
// `threads` threads (a handle from ReaderPool each), so the work is shared
// evenly whatever the blocks' layout; each block writes its own cells of
// `out`. Counts the blocks it decodes. libtiff undoes the compression and
// the byte order, and the predictor unless the reader does
// (TiffFacts::own_predictor), exactly as for a full read. The caller has
// checked the blocks' cost (check_block_cost); `max_block_bytes` also bounds
// each allocation libtiff makes (libtiff_alloc_limit). Every block is
// decoded even after one fails, so the error is always the first failing
// block's in the file's order.
Status read_window_with_libtiff(const std::string& path, const TiffFacts& f, const Window& window, unsigned threads,
                                std::uint64_t max_block_bytes, Grid<float>& out, ReadStats& stats) {
  const std::size_t stride = pixel_stride(f);
  const std::size_t offset = f.planar_separate ? 0 : pixel_type_size(f.type) * static_cast<std::size_t>(f.channel);
  const std::uint16_t plane = f.planar_separate ? static_cast<std::uint16_t>(f.channel) : 0;
  const int bw = f.block_width, bh = f.block_height;
  std::error_code size_error;
  const std::uint64_t file_size = std::filesystem::file_size(path, size_error);
  if (size_error) return dem_error(ErrorCode::kIoError, path, "cannot read its size: " + size_error.message());
  // The blocks under the window, in the file's order (rows of blocks, then columns).
  struct Block {
    int bx, by;
  };
  std::vector<Block> blocks;
  // Stepped in 64 bits: the step past the last block may pass 2^31.
  for (std::int64_t by = window.row0 / bh * bh; by < window.row1; by += bh)
    for (std::int64_t bx = window.col0 / bw * bw; bx < window.col1; bx += bw)
      blocks.push_back({static_cast<int>(bx), static_cast<int>(by)});
  std::vector<Status> status(blocks.size(), Status::Ok());
  std::vector<std::uint64_t> cells(blocks.size(), 0);
  // Each block's lowest and highest value, taken from its rows while they
  // are in cache (ReadStats::value_min).
  constexpr float kInf = std::numeric_limits<float>::infinity();
  std::vector<float> lowest(blocks.size(), kInf), highest(blocks.size(), -kInf);
  ReaderPool pool(path, max_block_bytes, f.own_predictor, map_for_blocks(f));
  const int sample_bytes = static_cast<int>(pixel_type_size(f.type));
  // Tasks of consecutive blocks, ~256 KB decoded each: a tiled file's task
  // is a tile or two, a file of one-row strips' some forty strips.
  constexpr std::uint64_t kTaskBytes = 256 * 1024;
  const std::size_t per_task =
      static_cast<std::size_t>(std::max<std::uint64_t>(1, kTaskBytes / std::max<std::uint64_t>(f.block_bytes, 1)));
  const std::size_t tasks = (blocks.size() + per_task - 1) / per_task;
  parallel_for(tasks, threads, [&](std::size_t task) {
    auto reader = pool.take();
    for (std::size_t i = task * per_task, end = std::min(blocks.size(), i + per_task); i < end; ++i) {
      Status& st = status[i];
      const int bx = blocks[i].bx, by = blocks[i].by;
      [&] {
        if (!reader->tif) {
          st = dem_error(ErrorCode::kDataError, path, "cannot reopen (" + reader->messages.errors + ")");
          return;
        }
        TIFF* tif = reader->tif.get();
        // The rows and columns of this block inside the window; a strip's rows
        // are the image width long, a tile's the tile width.
        const int r0 = std::max(by, window.row0), c0 = std::max(bx, window.col0);
        const int r1 = static_cast<int>(std::min<std::int64_t>({std::int64_t{by} + bh, window.row1, f.height}));
        const int c1 = static_cast<int>(std::min<std::int64_t>({std::int64_t{bx} + bw, window.col1, f.width}));
        const std::size_t row_pitch = static_cast<std::size_t>(bw) * stride;
        const std::uint64_t wanted = f.tiled ? f.block_bytes : strip_top_bytes(f.block_bytes, row_pitch, r1 - by);
        assert(max_block_bytes == 0 || wanted <= max_block_bytes);  // check_block_cost
        if (wanted > reader->capacity) {
          reader->block.reset(new unsigned char[static_cast<std::size_t>(wanted)]);
          reader->capacity = wanted;
        }
        const std::uint32_t index =
            f.tiled ? TIFFComputeTile(tif, static_cast<std::uint32_t>(bx), static_cast<std::uint32_t>(by), 0, plane)
                    : TIFFComputeStrip(tif, static_cast<std::uint32_t>(by), plane);
        const auto block_name = [&] {
          return std::string(f.tiled ? "tile" : "strip") + " at col " + std::to_string(bx) + ", row " +
                 std::to_string(by);
        };
        if (auto cut = truncation(file_size, tif, index, block_name)) {
          st = dem_error(ErrorCode::kDataError, path, *cut);
          return;
        }
        unsigned char* block = reader->block.get();
        const tmsize_t got = f.tiled ? TIFFReadEncodedTile(tif, index, block, static_cast<tmsize_t>(wanted))
                                     : TIFFReadEncodedStrip(tif, index, block, static_cast<tmsize_t>(wanted));
        if (got < 0) {
          st = dem_error(ErrorCode::kDataError, path,
                         "cannot decode " + block_name() +
                             (reader->messages.errors.empty() ? std::string() : " (" + reader->messages.errors + ")"));
          reader->messages.errors.clear();
          return;
        }
        cells[i] = static_cast<std::uint64_t>(bw) * static_cast<std::uint64_t>(f.tiled ? bh : r1 - by);
        // A predictor runs over whole block rows; without one, a row is read
        // only as far as the window's last column.
        const std::size_t needed = f.own_predictor ? static_cast<std::size_t>(r1 - by) * row_pitch
                                                   : static_cast<std::size_t>(r1 - by - 1) * row_pitch +
                                                         static_cast<std::size_t>(c1 - bx) * stride;
        if (static_cast<std::size_t>(got) < needed) {
          st = dem_error(ErrorCode::kDataError, path, "a block decodes shorter than its layout says");
          return;
        }
        const auto count = static_cast<std::size_t>(c1 - c0);
        if (f.own_predictor && f.predictor == PREDICTOR_FLOATINGPOINT)
          reader->samples.resize(count * static_cast<std::size_t>(sample_bytes));
        for (int r = r0; r < r1; ++r) {
          unsigned char* row = block + static_cast<std::size_t>(r - by) * row_pitch;
          const unsigned char* src = row + offset + static_cast<std::size_t>(c0 - bx) * stride;
          if (f.own_predictor && f.predictor == PREDICTOR_HORIZONTAL) {
            detail::undo_horizontal(row, static_cast<std::size_t>(bw), sample_bytes);
          } else if (f.own_predictor && f.predictor == PREDICTOR_FLOATINGPOINT) {
            detail::undo_floating_point(row, static_cast<std::size_t>(bw), sample_bytes,
                                        static_cast<std::size_t>(c0 - bx), count, reader->samples.data());
            src = reader->samples.data();
          }
          float* dst = out.row(r - window.row0) + (c0 - window.col0);
          convert_any(f.type, src, stride, c1 - c0, dst, f.nodata);
          widen_value_range(dst, c1 - c0, lowest[i], highest[i]);
        }
      }();
    }
    pool.give_back(std::move(reader));
  });
  for (std::size_t i = 0; i < blocks.size(); ++i) HORIZON_RETURN_IF_ERROR(status[i]);
  stats.value_min = kInf;
  stats.value_max = -kInf;
  for (std::size_t i = 0; i < blocks.size(); ++i) {
    stats.blocks_read += cells[i] > 0;
    stats.cells_decoded += cells[i];
    stats.value_min = std::min(stats.value_min, lowest[i]);
    stats.value_max = std::max(stats.value_max, highest[i]);
  }
  return Status::Ok();
}

std::string format_name(const TiffFacts& facts, PixelType type, int channel) {
  std::string name =
      std::string(facts.bigtiff ? "BigTIFF " : "GeoTIFF ") + pixel_type_name(type) + " (" + facts.layout + ")";
  if (facts.samples > 1) name += ", band " + std::to_string(channel + 1) + " of " + std::to_string(facts.samples);
  return name;
}

Status check_path(const std::string& path, const ReadOptions& options) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    if (errno == ENOENT || errno == ENOTDIR) return dem_error(ErrorCode::kNotFound, path, "no such file");
    return dem_error(ErrorCode::kIoError, path, std::string("cannot access: ") + std::strerror(errno));
  }
  if (S_ISDIR(st.st_mode)) return dem_error(ErrorCode::kDataError, path, "not a raster (it is a directory)");
  if (options.band < 0)
    return make_error(ErrorCode::kInvalidArgument,
                      "dem '" + path + "': band " + std::to_string(options.band) + " is invalid (bands count from 1)",
                      "band");
  return Status::Ok();
}

// Reads `options.window` (or the whole raster) through libtiff.
Result<Dem> read_geotiff_window(const std::string& path, const ReadOptions& options, const TiffFacts& facts,
                                std::chrono::steady_clock::time_point start, ReadStats* stats) {
  const int channel = facts.channel;
  const PixelType type = facts.type;
  auto window = clip_read_window(*options.window, facts.width, facts.height, path);
  if (!window.ok()) return window.error();

  ReadStats local;
  local.file_width = facts.width;
  local.file_height = facts.height;
  local.window = *window;
  local.tiled = facts.tiled;
  local.block_width = facts.block_width;
  local.block_height = facts.block_height;
  local.blocks_total = facts.blocks_per_plane;
  if (window->cell_count() > kMaxCells)
    return dem_error(ErrorCode::kResourceExhausted, path,
                     std::to_string(window->width()) + "x" + std::to_string(window->height()) +
                         " cells exceed the limit of " + std::to_string(kMaxCells));
  HORIZON_RETURN_IF_ERROR(check_block_cost(path, facts, *window, options.max_block_bytes));
  Dem dem;
  dem.elevation = Grid<float>(window->width(), window->height(), kUninitialized);  // every block writes its cells
  HORIZON_RETURN_IF_ERROR(
      read_window_with_libtiff(path, facts, *window, options.threads, options.max_block_bytes, dem.elevation, local));
  dem.georef = facts.georef;
  dem.georef.transform = facts.georef.transform.shifted(window->col0, window->row0);
  dem.nodata = facts.nodata;
  dem.source = path;
  dem.format = format_name(facts, type, channel);
  local.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (stats) *stats = local;
  return dem;
}

DemHeader header_of(const std::string& path, const TiffFacts& facts) {
  DemHeader h;
  h.width = facts.width;
  h.height = facts.height;
  h.georef = facts.georef;
  h.nodata = facts.nodata;
  h.source = path;
  h.format = format_name(facts, facts.type, facts.channel);
  h.tiled = facts.tiled;
  h.block_width = facts.block_width;
  h.block_height = facts.block_height;
  h.blocks_total = facts.blocks_per_plane;
  return h;
}

// The facts are read once; each read_cells() opens its own libtiff handles
// (a handle is not thread-safe), so reads on several threads do not wait on
// each other.
class GeoTiffFile final : public RasterFile {
 public:
  GeoTiffFile(std::string path, TiffFacts facts, std::uint64_t max_block_bytes)
      : RasterFile(header_of(path, facts)),
        path_(std::move(path)),
        facts_(std::move(facts)),
        max_block_bytes_(max_block_bytes) {}

  Result<Grid<float>> read_cells(const Window& window, unsigned threads, ReadStats* stats) const override {
    const auto start = std::chrono::steady_clock::now();
    assert(!window.empty() && window.col0 >= 0 && window.row0 >= 0 && window.col1 <= facts_.width &&
           window.row1 <= facts_.height);
    ReadStats local;
    local.file_width = facts_.width;
    local.file_height = facts_.height;
    local.window = window;
    local.tiled = facts_.tiled;
    local.block_width = facts_.block_width;
    local.block_height = facts_.block_height;
    local.blocks_total = facts_.blocks_per_plane;
    HORIZON_RETURN_IF_ERROR(check_block_cost(path_, facts_, window, max_block_bytes_));
    Grid<float> cells(window.width(), window.height(), kUninitialized);  // every block writes its cells
    HORIZON_RETURN_IF_ERROR(read_window_with_libtiff(path_, facts_, window, threads, max_block_bytes_, cells, local));
    local.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (stats) *stats = local;
    return cells;
  }

 private:
  std::string path_;
  TiffFacts facts_;
  std::uint64_t max_block_bytes_;
};

}  // namespace

Result<DemHeader> read_geotiff_header(const std::string& path, const ReadOptions& options) {
  HORIZON_RETURN_IF_ERROR(check_path(path, options));
  auto facts = read_tiff_facts(path, options);
  if (!facts.ok()) return facts.error();
  return header_of(path, *facts);
}

Result<std::unique_ptr<RasterFile>> open_geotiff(const std::string& path, const ReadOptions& options) {
  HORIZON_RETURN_IF_ERROR(check_path(path, options));
  auto facts = read_tiff_facts(path, options);
  if (!facts.ok()) return facts.error();
  return std::unique_ptr<RasterFile>(std::make_unique<GeoTiffFile>(path, std::move(*facts), options.max_block_bytes));
}

Result<Dem> read_geotiff(const std::string& path, const ReadOptions& options, ReadStats* stats) {
  HORIZON_RETURN_IF_ERROR(check_path(path, options));
  const auto start = std::chrono::steady_clock::now();
  auto facts = read_tiff_facts(path, options);
  if (!facts.ok()) return facts.error();
  if (options.window) return read_geotiff_window(path, options, *facts, start, stats);
  // The whole raster: a window that covers it.
  ReadOptions whole = options;
  whole.window = Window{0, 0, facts->width, facts->height};
  return read_geotiff_window(path, whole, *facts, start, stats);
}

}  // namespace horizon::terrain
