// horizon/terrain/geotiff_options.hpp — how a result GeoTIFF is laid out:
// the format (a plain GeoTIFF or a Cloud-Optimised GeoTIFF) and its creation
// options, named and spelled as GDAL's GTiff and COG drivers take them
// (`gdal_translate -of COG -co COMPRESS=ZSTD`), so a GIS analyst's habits
// carry over.
//
//   GTiff  COMPRESS=DEFLATE|LZW|ZSTD|LZMA|PACKBITS|NONE  (default DEFLATE)
//          PREDICTOR=1|2|3 (NO, YES/STANDARD, FLOATING_POINT; default 2 for
//                    UInt32 counts, 3 for float rasters, 1 for UInt8
//                    codes and without compression)
//          ZLEVEL=1..12 (DEFLATE), ZSTD_LEVEL=1..22, LZMA_PRESET=0..9
//          TILED=YES|NO, BLOCKXSIZE=N, BLOCKYSIZE=N (tiles: multiples of 16,
//                    default 256; strips: BLOCKYSIZE rows each)
//          BIGTIFF=IF_NEEDED|IF_SAFER|YES|NO
//   COG    COMPRESS, PREDICTOR, BIGTIFF as above; LEVEL=N (the codec's
//          level), BLOCKSIZE=N (tiles, default 512 as GDAL's COG driver),
//          OVERVIEWS=AUTO|NONE, OVERVIEW_RESAMPLING=NEAREST|MODE|AVERAGE
//          (default MODE for code rasters, AVERAGE for measured values)
// Names and values are case-insensitive; an unknown name, a value out of
// range or an option of the other format is an error naming the option.
//
// A COG here is what GDAL's COG driver writes: tiled, with overviews halving
// the size until the image fits in one tile, the image file directories
// (IFDs) first, then the tiles from the smallest overview to the full
// resolution, each tile preceded by its size and followed by its last four
// bytes, and GDAL's structural-metadata header saying so; QGIS (and GDAL's
// /vsicurl/) then reads a large raster's overview or a window with a few
// ranged reads. The overviews are real: each level computed from the one
// above by the resampling chosen, nodata cells left out.
#pragma once

#include <optional>
#include <span>
#include <string>
#include <string_view>

#include "horizon/common/error.hpp"

namespace horizon::terrain {

enum class TiffFormat { kGTiff, kCog };
enum class TiffCompression { kDeflate, kLzw, kZstd, kLzma, kPackBits, kNone };
enum class TiffPredictor { kDefault, kNone, kHorizontal, kFloatingPoint };
enum class BigTiff { kIfNeeded, kIfSafer, kYes, kNo };
enum class OverviewResampling { kDefault, kNearest, kMode, kAverage };

struct GeoTiffOptions {
  TiffFormat format = TiffFormat::kGTiff;
  TiffCompression compression = TiffCompression::kDeflate;
  std::optional<int> level;  // the codec's level; absent: the writer's default
  TiffPredictor predictor = TiffPredictor::kDefault;
  bool tiled = true;
  int block_width = 256;  // tiles; unused for strips
  int block_height = 0;   // tiles: 0 = block_width; strips: rows per strip, 0 = about 64 KiB a strip
  BigTiff bigtiff = BigTiff::kIfNeeded;
  bool overviews = false;  // COG: reduced-resolution copies down to one tile
  OverviewResampling resampling = OverviewResampling::kDefault;

  // The writer's defaults (what every result raster had before options
  // existed): deflate, the predictor for the sample type, 256 x 256 tiles.
  bool is_default() const;
};

// "GTiff" or "COG" (case-insensitive), as GDAL names the drivers.
std::optional<TiffFormat> parse_tiff_format(std::string_view name);
std::string_view tiff_format_name(TiffFormat format);

// The options for `format` from "NAME=VALUE" items. Errors are
// kInvalidArgument with the field "creation_options" and a message that
// quotes the item ("COMPRESS=JPEG: not a lossless codec this writer offers;
// use DEFLATE, LZW, ZSTD, LZMA, PACKBITS or NONE"). A codec this libtiff was
// built without is kUnsupported.
Result<GeoTiffOptions> parse_creation_options(TiffFormat format, std::span<const std::string> items);

}  // namespace horizon::terrain
