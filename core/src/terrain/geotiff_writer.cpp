// geotiff_writer.cpp — single-band result rasters as GeoTIFF.
//
// Formats and specifications:
//   * TIFF 6.0 (Adobe, 1992): tiled layout (section 15), 256x256 tiles,
//     Adobe deflate compression (tag value 8), with no predictor for UInt8
//     codes, the horizontal predictor (2) for wider integers and the
//     floating-point predictor (3, Adobe Photoshop TIFF technical note 3)
//     for Float32.
//   * OGC GeoTIFF 1.1 (OGC 19-008r4): ModelPixelScaleTag + ModelTiepointTag
//     for north-up rasters (ModelTransformationTag otherwise),
//     GTModelTypeGeoKey, GTRasterTypeGeoKey = PixelIsArea, and the CRS keys
//     (geotiff_crs.hpp): ProjectedCSTypeGeoKey or GeographicTypeGeoKey with
//     the EPSG code (and VerticalCSTypeGeoKey for a compound CRS), or the
//     user-defined keys of a CRS without a code, as GDAL writes them.
//   * GDAL_NODATA (TIFF tag 42113, ASCII), https://gdal.org/drivers/raster/gtiff.html.
//   * A UInt8 raster's colour table: PhotometricInterpretation = Palette (3)
//     and ColorMap (tag 320), TIFF 6.0 section 5.
//
// Written with libtiff + libgeotiff (OIIO 2.4 cannot write GeoTIFF tags).
// Tiles are predicted and deflated here, on every core (zlib format), and
// handed to libtiff raw in tile order; libtiff alone deflates on one thread
// (0.4 s of a 48 MB float OHF). Float and 32-bit rasters: libdeflate at
// level 6 (libtiff's own). 8-bit rasters (visibility codes: long runs of a
// few values) with no level asked for: zlib's run-length strategy (Z_RLE,
// matches at distance 1 only), standard deflate that every reader reads,
// five times faster than libdeflate's level 1 on a viewshed's codes and
// smaller (the 1.4 M-cell Saentis mask: 1.2 ms and 14 KB against 5.5 ms
// and 20 KB). A level asked for (ZLEVEL) takes libdeflate at that level.
// Deterministic: no DateTime/Software tags, fixed tile order, and edge tiles
// padded with the nodata value (or 0), so equal input gives equal bytes.
// Atomic: see atomic_file.hpp.
#include "horizon/terrain/geotiff_writer.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <type_traits>
#include <vector>

#include <libdeflate.h>
#include <zlib.h>

#include "atomic_file.hpp"
#include "cog_layout.hpp"
#include "geokeys.hpp"
#include "geotiff_crs.hpp"
#include "horizon/common/parallel.hpp"
#include "horizon/geodesy/crs.hpp"
#include "overviews.hpp"
#include "tiff_support.hpp"

namespace horizon::terrain {
namespace {

using detail::TiffMessages;
using detail::TiffPtr;

constexpr std::uint32_t kTileSize = 256;
// Classic TIFF offsets are 32-bit; leave room for tile tables and tags.
constexpr std::uint64_t kClassicTiffLimitBytes = 3'500'000'000ULL;

Error write_error(ErrorCode code, const std::string& path, const std::string& what) {
  return make_error(code, "geotiff '" + path + "': " + what, path);
}

// Shortest text that reads back as exactly this double ("-32768", "255", "nan").
std::string nodata_text(double v) {
  if (std::isnan(v)) return "nan";
  char buf[64];
  const auto res = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, res.ptr);
}

Status check_georef(const std::string& path, const Georeference& georef) {
  const GeoTransform& t = georef.transform;
  if (!std::isfinite(t.origin_x) || !std::isfinite(t.origin_y) || !std::isfinite(t.pixel_width) ||
      !std::isfinite(t.pixel_height) || !(t.pixel_width > 0.0) || t.pixel_height == 0.0)
    return write_error(ErrorCode::kInvalidArgument, path,
                       "geotransform must be finite with pixel_width > 0 and pixel_height != 0");
  if (georef.has_crs()) {
    auto crs = geodesy::Crs::of(georef);
    if (!crs.ok()) return write_error(ErrorCode::kUnsupported, path, crs.error().message);
  }
  return Status::Ok();
}

// Pixel-to-model transform and CRS keys. Tags set here are written with the directory.
Status write_georef(const std::string& path, TIFF* tif, const Georeference& georef) {
  const GeoTransform& t = georef.transform;
  if (t.pixel_height < 0.0) {
    double scale[3] = {t.pixel_width, -t.pixel_height, 0.0};
    double tie[6] = {0.0, 0.0, 0.0, t.origin_x, t.origin_y, 0.0};
    TIFFSetField(tif, detail::kTagModelPixelScale, 3, scale);
    TIFFSetField(tif, detail::kTagModelTiepoint, 6, tie);
  } else {
    // South-up: pixel scale cannot carry a positive y step, the matrix can.
    double m[16] = {t.pixel_width, 0, 0, t.origin_x, 0, t.pixel_height, 0, t.origin_y, 0, 0, 0, 0, 0, 0, 0, 1};
    TIFFSetField(tif, detail::kTagModelTransformation, 16, m);
  }

  detail::GeoKeys keys;
  keys.set_short(GTRasterTypeGeoKey, RasterPixelIsArea);
  if (Status crs = detail::write_crs_keys(keys, georef); !crs.ok())
    return write_error(crs.error().code, path, crs.error().message);
  if (!keys.write(tif)) return write_error(ErrorCode::kInternal, path, "libtiff could not set the GeoKey tags");
  return Status::Ok();
}

// TIFF predictors, applied in place to one block of `width` x `rows`
// samples, exactly as libtiff's encoder applies them (tif_predict.c):
// horizontal (2) differences each row's samples (modulo their width);
// floating point (3) first splits each row into byte planes, most
// significant first, then differences the row's bytes.
template <class T>
void predict_horizontal(T* block, std::size_t width, std::size_t rows) {
  for (std::size_t r = 0; r < rows; ++r) {
    T* row = block + r * width;
    for (std::size_t i = width - 1; i > 0; --i) row[i] = static_cast<T>(row[i] - row[i - 1]);
  }
}

void predict_floating_point(float* block, std::size_t width, std::size_t rows, std::vector<std::uint8_t>& scratch) {
  static_assert(std::endian::native == std::endian::little, "the byte planes below are laid out for little-endian");
  constexpr std::size_t kBytes = sizeof(float);
  const std::size_t row_bytes = width * kBytes;
  scratch.resize(row_bytes);
  for (std::size_t r = 0; r < rows; ++r) {
    auto* row = reinterpret_cast<std::uint8_t*>(block + r * width);
    std::copy_n(row, row_bytes, scratch.data());
    for (std::size_t i = 0; i < width; ++i)
      for (std::size_t b = 0; b < kBytes; ++b) {
        // Little-endian host: byte b of a sample goes to plane kBytes - 1 - b.
        row[(kBytes - 1 - b) * width + i] = scratch[kBytes * i + b];
      }
    for (std::size_t i = row_bytes - 1; i > 0; --i) row[i] = static_cast<std::uint8_t>(row[i] - row[i - 1]);
  }
}

struct CompressorDeleter {
  void operator()(libdeflate_compressor* c) const { libdeflate_free_compressor(c); }
};

// zlib's deflate with the run-length strategy, its state reused block after
// block (deflateReset), for 8-bit code rasters. zlib makes the raw deflate
// stream only; the zlib format's header and Adler-32 trailer are written
// here, the checksum by libdeflate (zlib 1.2's own Adler-32 runs a byte at a
// time: a third of the encoding's time on a viewshed's codes). The bytes are
// those zlib writes itself for level 1: header 78 01, then the stream, then
// the checksum, most significant byte first (RFC 1950).
class RleDeflater {
 public:
  RleDeflater() { ok_ = deflateInit2(&z_, 1, Z_DEFLATED, -15, 8, Z_RLE) == Z_OK; }
  ~RleDeflater() {
    if (ok_) deflateEnd(&z_);
  }
  RleDeflater(const RleDeflater&) = delete;
  RleDeflater& operator=(const RleDeflater&) = delete;
  bool ok() const { return ok_; }
  // `in` deflated into `out` (zlib format); false on failure.
  bool compress(const std::uint8_t* in, std::size_t bytes, std::vector<std::uint8_t>& out) {
    if (!ok_ || deflateReset(&z_) != Z_OK) return false;
    constexpr std::size_t kHeader = 2, kTrailer = 4;
    out.resize(kHeader + deflateBound(&z_, static_cast<uLong>(bytes)) + kTrailer);
    out[0] = 0x78;  // deflate, 32 KB window
    out[1] = 0x01;  // level "fastest", no dictionary; (0x78 * 256 + 0x01) % 31 == 0
    z_.next_in = const_cast<Bytef*>(in);
    z_.avail_in = static_cast<uInt>(bytes);
    z_.next_out = out.data() + kHeader;
    z_.avail_out = static_cast<uInt>(out.size() - kHeader - kTrailer);
    if (deflate(&z_, Z_FINISH) != Z_STREAM_END) return false;
    const std::uint32_t adler = libdeflate_adler32(1, in, bytes);
    std::uint8_t* tail = out.data() + kHeader + z_.total_out;
    for (int i = 0; i < 4; ++i) tail[i] = static_cast<std::uint8_t>(adler >> (24 - 8 * i));
    out.resize(kHeader + z_.total_out + kTrailer);
    return true;
  }

 private:
  z_stream z_{};
  bool ok_ = false;
};

// How the options lay a raster of T out: blocks, codec, predictor, BigTIFF.
struct Layout {
  bool tiled = true;
  std::uint32_t block_width = kTileSize, block_height = kTileSize;  // strips: the image width, rows per strip
  std::uint16_t compression = COMPRESSION_ADOBE_DEFLATE;
  std::uint16_t predictor = PREDICTOR_NONE;
  std::optional<int> level;
  bool bigtiff = false;
  bool overviews = false;
  OverviewResampling resampling = OverviewResampling::kAverage;
};

template <class T>
Result<Layout> layout_for(const std::string& path, const GeoTiffOptions& o, int width, std::uint64_t bytes) {
  constexpr bool kFloat = std::is_floating_point_v<T>;
  const char* type = kFloat ? "Float32" : sizeof(T) == 1 ? "UInt8" : "UInt32";
  Layout l;
  l.tiled = o.tiled || o.format == TiffFormat::kCog;
  if (l.tiled) {
    l.block_width = static_cast<std::uint32_t>(o.block_width);
    l.block_height = static_cast<std::uint32_t>(o.block_height ? o.block_height : o.block_width);
  } else {
    l.block_width = static_cast<std::uint32_t>(width);
    const std::uint64_t row_bytes = static_cast<std::uint64_t>(width) * sizeof(T);
    l.block_height = o.block_height ? static_cast<std::uint32_t>(o.block_height)
                                    : static_cast<std::uint32_t>(std::max<std::uint64_t>(1, 65536 / row_bytes));
  }
  switch (o.compression) {
    case TiffCompression::kDeflate:
      l.compression = COMPRESSION_ADOBE_DEFLATE;
      break;
    case TiffCompression::kLzw:
      l.compression = COMPRESSION_LZW;
      break;
    case TiffCompression::kZstd:
      l.compression = COMPRESSION_ZSTD;
      break;
    case TiffCompression::kLzma:
      l.compression = COMPRESSION_LZMA;
      break;
    case TiffCompression::kPackBits:
      l.compression = COMPRESSION_PACKBITS;
      break;
    case TiffCompression::kNone:
      l.compression = COMPRESSION_NONE;
      break;
  }
  const bool codes_only = o.compression == TiffCompression::kNone || o.compression == TiffCompression::kPackBits;
  switch (o.predictor) {
    case TiffPredictor::kDefault:
      // 8-bit rasters hold codes (visible, hidden, ...): a difference of two
      // codes means nothing, and undifferenced runs compress smaller (the
      // 12 M-cell visible raster: 145 KB against 175 KB, and 2 ms less).
      l.predictor = codes_only || sizeof(T) == 1 ? PREDICTOR_NONE
                    : kFloat                     ? PREDICTOR_FLOATINGPOINT
                                                 : PREDICTOR_HORIZONTAL;
      break;
    case TiffPredictor::kNone:
      l.predictor = PREDICTOR_NONE;
      break;
    case TiffPredictor::kHorizontal:
      l.predictor = PREDICTOR_HORIZONTAL;
      break;
    case TiffPredictor::kFloatingPoint:
      if (!kFloat)
        return make_error(ErrorCode::kInvalidArgument,
                          "PREDICTOR=3: the floating-point predictor is for float rasters; this one is " +
                              std::string(type) + " (use PREDICTOR=2)",
                          "creation_options");
      l.predictor = PREDICTOR_FLOATINGPOINT;
      break;
  }
  if (l.predictor != PREDICTOR_NONE && codes_only)
    return make_error(ErrorCode::kInvalidArgument,
                      "PREDICTOR: a predictor helps a compressing codec only; COMPRESS is " +
                          std::string(o.compression == TiffCompression::kNone ? "NONE" : "PACKBITS"),
                      "creation_options");
  l.level = o.level;
  l.overviews = o.format == TiffFormat::kCog && o.overviews;
  l.resampling = o.resampling != OverviewResampling::kDefault ? o.resampling
                 : sizeof(T) == 1                             ? OverviewResampling::kMode  // codes
                                                              : OverviewResampling::kAverage;
  // Overviews add a third at most.
  const std::uint64_t total = l.overviews ? bytes + bytes / 3 : bytes;
  switch (o.bigtiff) {
    case BigTiff::kYes:
      l.bigtiff = true;
      break;
    case BigTiff::kNo:
      l.bigtiff = false;
      break;
    case BigTiff::kIfNeeded:
      l.bigtiff = total > kClassicTiffLimitBytes;
      break;
    case BigTiff::kIfSafer:
      l.bigtiff = total > kClassicTiffLimitBytes / 2;
      break;
  }
  (void)path;
  return l;
}

// One image's tags: size, sample layout, colours, codec, blocks, nodata.
template <class T>
void set_image_tags(TIFF* t, int width, int height, int bands, const Layout& l, std::optional<double> nodata,
                    const ColourTable* colours, bool reduced) {
  constexpr bool kFloat = std::is_floating_point_v<T>;
  if (reduced) TIFFSetField(t, TIFFTAG_SUBFILETYPE, FILETYPE_REDUCEDIMAGE);
  TIFFSetField(t, TIFFTAG_IMAGEWIDTH, static_cast<std::uint32_t>(width));
  TIFFSetField(t, TIFFTAG_IMAGELENGTH, static_cast<std::uint32_t>(height));
  TIFFSetField(t, TIFFTAG_SAMPLESPERPIXEL, bands);
  TIFFSetField(t, TIFFTAG_BITSPERSAMPLE, static_cast<int>(8 * sizeof(T)));
  TIFFSetField(t, TIFFTAG_SAMPLEFORMAT, kFloat ? SAMPLEFORMAT_IEEEFP : SAMPLEFORMAT_UINT);
  if (colours && sizeof(T) == 1 && bands == 1) {
    // TIFF 6.0 section 5: 16-bit components, 0..65535 (v * 257 maps 255 to 65535).
    std::array<std::array<std::uint16_t, 256>, 3> map;
    for (std::size_t i = 0; i < 256; ++i)
      for (std::size_t k = 0; k < 3; ++k) map[k][i] = static_cast<std::uint16_t>((*colours)[i][k] * 257u);
    TIFFSetField(t, TIFFTAG_PHOTOMETRIC, PHOTOMETRIC_PALETTE);
    TIFFSetField(t, TIFFTAG_COLORMAP, map[0].data(), map[1].data(), map[2].data());
  } else {
    TIFFSetField(t, TIFFTAG_PHOTOMETRIC, PHOTOMETRIC_MINISBLACK);
  }
  TIFFSetField(t, TIFFTAG_PLANARCONFIG, bands > 1 ? PLANARCONFIG_SEPARATE : PLANARCONFIG_CONTIG);
  TIFFSetField(t, TIFFTAG_COMPRESSION, l.compression);
  if (l.predictor != PREDICTOR_NONE) TIFFSetField(t, TIFFTAG_PREDICTOR, l.predictor);
  if (l.level && l.compression == COMPRESSION_ZSTD) TIFFSetField(t, TIFFTAG_ZSTD_LEVEL, *l.level);
  if (l.level && l.compression == COMPRESSION_LZMA) TIFFSetField(t, TIFFTAG_LZMAPRESET, *l.level);
  if (l.tiled) {
    TIFFSetField(t, TIFFTAG_TILEWIDTH, l.block_width);
    TIFFSetField(t, TIFFTAG_TILELENGTH, l.block_height);
  } else {
    TIFFSetField(t, TIFFTAG_ROWSPERSTRIP, l.block_height);
  }
  if (kFloat || nodata) {
    const std::string text = nodata ? nodata_text(*nodata) : std::string("nan");
    TIFFSetField(t, detail::kTagGdalNodata, text.c_str());
  }
}

// Writes one band of the current image, block by block in TIFF's order.
// Deflate is encoded here, on every core (libdeflate, zlib format), and the
// blocks handed to libtiff raw; the other codecs are libtiff's own, on one
// thread. Tiles are padded with `fill`; strips are cut to the image.
template <class T>
Status write_band(TIFF* t, const std::string& path, const Grid<T>& grid, int band_index, const Layout& l, T fill,
                  bool nan_to_fill, TiffMessages& messages) {
  constexpr bool kFloat = std::is_floating_point_v<T>;
  const std::uint32_t bw = l.block_width, bh = l.block_height;
  const int blocks_x = l.tiled ? static_cast<int>((grid.width() + bw - 1) / bw) : 1;
  const int blocks_y = static_cast<int>((grid.height() + bh - 1) / bh);
  // The block at (bx, by), predicted when this writer encodes it.
  const auto fill_block = [&](int bx, int by, std::vector<T>& block, std::size_t& rows_out) {
    const int x0 = bx * static_cast<int>(bw), y0 = by * static_cast<int>(bh);
    const int rows = std::min<int>(static_cast<int>(bh), grid.height() - y0);
    const int cols = std::min<int>(static_cast<int>(bw), grid.width() - x0);
    rows_out = l.tiled ? bh : static_cast<std::size_t>(rows);
    block.assign(static_cast<std::size_t>(bw) * rows_out, fill);
    for (int r = 0; r < rows; ++r) {
      const T* src = grid.row(y0 + r) + x0;
      T* dst = block.data() + static_cast<std::size_t>(r) * bw;
      for (int c = 0; c < cols; ++c) {
        if constexpr (kFloat)
          dst[c] = (nan_to_fill && std::isnan(src[c])) ? fill : src[c];
        else
          dst[c] = src[c];
      }
    }
  };
  const auto block_index = [&](int bx, int by) -> std::uint32_t {
    if (l.tiled)
      return TIFFComputeTile(t, static_cast<std::uint32_t>(bx) * bw, static_cast<std::uint32_t>(by) * bh, 0,
                             static_cast<std::uint16_t>(band_index));
    return TIFFComputeStrip(t, static_cast<std::uint32_t>(by) * bh, static_cast<std::uint16_t>(band_index));
  };

  if (l.compression != COMPRESSION_ADOBE_DEFLATE) {
    std::vector<T> block;
    for (int by = 0; by < blocks_y; ++by)
      for (int bx = 0; bx < blocks_x; ++bx) {
        std::size_t rows = 0;
        fill_block(bx, by, block, rows);
        const tmsize_t size = static_cast<tmsize_t>(block.size() * sizeof(T));
        const tmsize_t done = l.tiled ? TIFFWriteEncodedTile(t, block_index(bx, by), block.data(), size)
                                      : TIFFWriteEncodedStrip(t, block_index(bx, by), block.data(), size);
        if (done < 0) return write_error(ErrorCode::kIoError, path, "cannot write a block (" + messages.errors + ")");
      }
    return Status::Ok();
  }

  // Deflate: every block encoded as its own task on every core (a raster
  // of a few block rows still shares out evenly), then written in order.
  // Each task borrows a compressor and a block buffer from `idle`.
  // zlib counts a call's bytes in 32 bits: a block beyond that (a single
  // strip of a > 4 GB raster) takes libdeflate.
  const bool run_length =
      sizeof(T) == 1 && !l.level && static_cast<std::uint64_t>(bw) * bh < std::numeric_limits<uInt>::max() / 2;
  const int level = l.level.value_or(6);
  std::vector<std::vector<std::uint8_t>> encoded(static_cast<std::size_t>(blocks_x) * blocks_y);
  std::vector<char> failed(encoded.size(), 0);
  struct Encoder {
    std::unique_ptr<libdeflate_compressor, CompressorDeleter> compressor;
    std::unique_ptr<RleDeflater> rle;
    std::vector<T> block;
    std::vector<std::uint8_t> scratch;
    // A block's stream before it is copied out at its own size: the bound
    // an encoder must be given is the block's size or more, while a code
    // raster's tile packs to a few hundred bytes, so the blocks' buffers
    // would otherwise touch as much fresh memory as the raster itself.
    std::vector<std::uint8_t> packed;
  };
  std::mutex idle_mutex;
  std::vector<std::unique_ptr<Encoder>> idle;
  parallel_for(encoded.size(), 0, [&](std::size_t index) {
    std::unique_ptr<Encoder> e;
    {
      std::lock_guard lock(idle_mutex);
      if (!idle.empty()) {
        e = std::move(idle.back());
        idle.pop_back();
      }
    }
    if (!e) {
      e = std::make_unique<Encoder>();
      if (run_length)
        e->rle = std::make_unique<RleDeflater>();
      else
        e->compressor.reset(libdeflate_alloc_compressor(level));
    }
    const int bx = static_cast<int>(index % static_cast<std::size_t>(blocks_x));
    const int by = static_cast<int>(index / static_cast<std::size_t>(blocks_x));
    if (run_length ? !e->rle->ok() : !e->compressor) {
      failed[index] = 1;
    } else {
      std::vector<T>& block = e->block;
      std::size_t rows = 0;
      fill_block(bx, by, block, rows);
      if constexpr (kFloat) {
        if (l.predictor == PREDICTOR_FLOATINGPOINT) predict_floating_point(block.data(), bw, rows, e->scratch);
      }
      if (l.predictor == PREDICTOR_HORIZONTAL) predict_horizontal(block.data(), bw, rows);
      const std::size_t bytes = block.size() * sizeof(T);
      std::vector<std::uint8_t>& packed = e->packed;
      if (run_length) {
        if (!e->rle->compress(reinterpret_cast<const std::uint8_t*>(block.data()), bytes, packed)) failed[index] = 1;
      } else {
        packed.resize(libdeflate_zlib_compress_bound(e->compressor.get(), bytes));
        const std::size_t size =
            libdeflate_zlib_compress(e->compressor.get(), block.data(), bytes, packed.data(), packed.size());
        if (size == 0) failed[index] = 1;
        packed.resize(size);
      }
      if (!failed[index]) encoded[index].assign(packed.begin(), packed.end());
    }
    std::lock_guard lock(idle_mutex);
    idle.push_back(std::move(e));
  });
  for (int by = 0; by < blocks_y; ++by)
    for (int bx = 0; bx < blocks_x; ++bx) {
      const std::size_t index = static_cast<std::size_t>(by) * blocks_x + static_cast<std::size_t>(bx);
      if (failed[index]) return write_error(ErrorCode::kInternal, path, "cannot deflate a block");
      const tmsize_t size = static_cast<tmsize_t>(encoded[index].size());
      const tmsize_t done = l.tiled ? TIFFWriteRawTile(t, block_index(bx, by), encoded[index].data(), size)
                                    : TIFFWriteRawStrip(t, block_index(bx, by), encoded[index].data(), size);
      if (done < 0) return write_error(ErrorCode::kIoError, path, "cannot write a block (" + messages.errors + ")");
      std::vector<std::uint8_t>().swap(encoded[index]);
    }
  return Status::Ok();
}

// Writes `bands` (one or more grids of one size) as one file, band after
// band (planar configuration "separate"); georeferenced when `georef` is
// given, a plain image otherwise. A COG is written with its overviews first
// to a scratch file beside `path`, then laid out (cog_layout.hpp).
template <class T>
Status write_impl(const std::string& path, std::span<const Grid<T>* const> bands, const Georeference* georef,
                  std::optional<double> nodata, const ColourTable* colours = nullptr,
                  const GeoTiffOptions& options = {}) {
  constexpr bool kFloat = std::is_floating_point_v<T>;
  if (bands.empty() || bands[0]->empty()) return write_error(ErrorCode::kInvalidArgument, path, "grid is empty");
  const Grid<T>& first_band = *bands[0];
  for (const Grid<T>* b : bands)
    if (b->width() != first_band.width() || b->height() != first_band.height())
      return write_error(ErrorCode::kInvalidArgument, path, "bands differ in size");
  if (georef) HORIZON_RETURN_IF_ERROR(check_georef(path, *georef));
  if (nodata) {
    if constexpr (kFloat) {
      if (std::isinf(*nodata) || (std::isfinite(*nodata) && std::abs(*nodata) > std::numeric_limits<float>::max()))
        return write_error(ErrorCode::kInvalidArgument, path,
                           "nodata " + nodata_text(*nodata) + " is not representable as float32");
    } else {
      constexpr double kMax = static_cast<double>(std::numeric_limits<T>::max());
      if (!(*nodata >= 0.0 && *nodata <= kMax && std::floor(*nodata) == *nodata))
        return write_error(ErrorCode::kInvalidArgument, path,
                           "nodata " + nodata_text(*nodata) + " is not a " + (sizeof(T) == 1 ? "UInt8" : "UInt32") +
                               " value (0.." + nodata_text(kMax) + ")");
    }
  }
  if (options.format == TiffFormat::kCog && bands.size() > 1)
    return write_error(ErrorCode::kInvalidArgument, path, "a COG is written for one band");
  // What NaN cells become, and what pads the edge tiles.
  const T fill = nodata ? static_cast<T>(*nodata) : T{};
  const std::uint64_t bytes = static_cast<std::uint64_t>(first_band.size()) * sizeof(T) * bands.size();
  auto layout = layout_for<T>(path, options, first_band.width(), bytes);
  if (!layout.ok()) return layout.error();
  const Layout& l = *layout;
  std::vector<Grid<T>> overviews;
  if (l.overviews)
    overviews = detail::build_overviews(first_band, static_cast<int>(std::max(l.block_width, l.block_height)),
                                        l.resampling, nodata);

  detail::AtomicFile file(path);
  HORIZON_RETURN_IF_ERROR(file.create("geotiff"));
  // A COG's images go to a scratch file first, then laid out into the temporary.
  std::optional<detail::AtomicFile> scratch;
  if (options.format == TiffFormat::kCog) {
    scratch.emplace(path + ".unordered");
    HORIZON_RETURN_IF_ERROR(scratch->create("geotiff"));
  }
  const std::string& written = scratch ? scratch->temp_path() : file.temp_path();
  {
    TiffMessages messages;
    TiffPtr tif = detail::open_tiff(written, l.bigtiff ? "w8" : "w", messages);
    if (!tif)
      return write_error(ErrorCode::kIoError, path, "cannot create '" + written + "' (" + messages.errors + ")");

    TIFF* t = tif.get();
    set_image_tags<T>(t, first_band.width(), first_band.height(), static_cast<int>(bands.size()), l, nodata, colours,
                      false);
    if (georef) HORIZON_RETURN_IF_ERROR(write_georef(path, t, *georef));
    for (std::size_t band_index = 0; band_index < bands.size(); ++band_index)
      HORIZON_RETURN_IF_ERROR(
          write_band(t, path, *bands[band_index], static_cast<int>(band_index), l, fill, nodata.has_value(), messages));
    for (const Grid<T>& level : overviews) {
      if (!TIFFWriteDirectory(t))
        return write_error(ErrorCode::kIoError, path, "cannot finish an image (" + messages.errors + ")");
      set_image_tags<T>(t, level.width(), level.height(), 1, l, nodata, colours, true);
      HORIZON_RETURN_IF_ERROR(write_band(t, path, level, 0, l, fill, nodata.has_value(), messages));
    }
    if (TIFFFlush(t) != 1 || !messages.errors.empty())
      return write_error(ErrorCode::kIoError, path, "cannot finish the file (" + messages.errors + ")");
    tif.reset();  // TIFFClose
    if (!messages.errors.empty())
      return write_error(ErrorCode::kIoError, path, "cannot close the file (" + messages.errors + ")");
  }
  if (scratch) HORIZON_RETURN_IF_ERROR(detail::write_cog_layout(scratch->temp_path(), file.temp_path(), path));
  return file.commit("geotiff");
}

}  // namespace

Status write_geotiff(const std::string& path, const Grid<float>& grid, const Georeference& georef,
                     std::optional<double> nodata, const GeoTiffOptions& options) {
  const Grid<float>* band = &grid;
  return write_impl<float>(path, {&band, 1}, &georef, nodata, nullptr, options);
}

Status write_geotiff(const std::string& path, const Grid<std::uint8_t>& grid, const Georeference& georef,
                     std::optional<double> nodata, const GeoTiffOptions& options) {
  const Grid<std::uint8_t>* band = &grid;
  return write_impl<std::uint8_t>(path, {&band, 1}, &georef, nodata, nullptr, options);
}

Status write_geotiff(const std::string& path, const Grid<std::uint8_t>& grid, const Georeference& georef,
                     std::optional<double> nodata, const ColourTable& colours, const GeoTiffOptions& options) {
  const Grid<std::uint8_t>* band = &grid;
  return write_impl<std::uint8_t>(path, {&band, 1}, &georef, nodata, &colours, options);
}

Status write_geotiff(const std::string& path, const Grid<std::uint32_t>& grid, const Georeference& georef,
                     std::optional<double> nodata, const GeoTiffOptions& options) {
  const Grid<std::uint32_t>* band = &grid;
  return write_impl<std::uint32_t>(path, {&band, 1}, &georef, nodata, nullptr, options);
}

Status write_tiff_image(const std::string& path, std::span<const Grid<float>* const> bands) {
  return write_impl<float>(path, bands, nullptr, std::nullopt);
}

}  // namespace horizon::terrain
