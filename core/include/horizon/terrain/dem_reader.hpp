// horizon/terrain/dem_reader.hpp — reading DEMs from files.
//
// Formats (chosen by content/extension, not trusted blindly):
//   * GeoTIFF / BigTIFF / COG: Int16, UInt16, Int32, Float32, Float64 (and
//     UInt8 and UInt32, so the engine's own rasters read back); striped
//     or tiled; any compression libtiff handles. Pixels are decoded by
//     libtiff (only the blocks a window needs, on several threads);
//     georeferencing (ModelPixelScale + ModelTiepoint or
//     ModelTransformation, GeoKeys) and GDAL_NODATA through libgeotiff.
//   * SRTM .hgt: 1201x1201 (3") or 3601x3601 (1") big-endian int16; bounds
//     from the file name (N27E086.hgt = 27..28 N, 86..87 E, samples on whole
//     degrees); -32768 = void.
//   * Mapbox terrain-RGB PNG: height = -10000 + (R*65536 + G*256 + B) * 0.1
//     metres, georeferenced in EPSG:3857 from the tile's z/x/y, given in
//     ReadOptions::tile or taken from a path ending in .../z/x/y.png.
//
// Every failure is an Error naming the file: missing, not a raster, more than
// one band without a band choice, unsupported pixel type, rotated transform,
// CRS not supported by horizon::geodesy::Crs, ...
//
// Windows and work. read_dem_header() answers size, georeference, nodata and
// layout without decoding any pixel (a GeoTIFF's directory only: milliseconds
// whatever the file's size). ReadOptions::window reads only a rectangle of
// cells: for a tiled or striped GeoTIFF only the tiles (strips) that intersect
// it are decoded, so a small viewshed of a large tiled file reads a small part
// of it. The returned Dem is the window itself, with its georeference shifted
// to the window's corner, so everything downstream works on it unchanged (an
// output's georeference comes out right, a point resolves to the same place).
// Formats without internal blocks (SRTM .hgt, terrain-RGB tiles; both small)
// are read whole and cropped, and count as one block. ReadStats says what was
// decoded, so "skip what a scene doesn't need" is a number.
#pragma once

#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <utility>

#include "horizon/common/error.hpp"
#include "horizon/terrain/dem.hpp"
#include "horizon/terrain/grid.hpp"

namespace horizon::terrain {

struct TileId {
  int z = 0, x = 0, y = 0;  // slippy-map tile (XYZ scheme, y grows south)
};

struct ReadOptions {
  // 1-based band to read. 0 = "the only band": a multi-band file is an error
  // that lists the band count, so the caller must choose.
  int band = 0;
  // Terrain-RGB tile position; otherwise parsed from the path.
  std::optional<TileId> tile;
  // Set true to accept a raster without a supported CRS (grid maths only).
  bool allow_missing_crs = false;
  // Cells to read, in the file's grid (half-open). Clipped to the raster; an
  // empty intersection is kOutOfRange. Absent: the whole raster.
  std::optional<Window> window;
  // Threads decoding a GeoTIFF's blocks (0 = all cores).
  unsigned threads = 0;
  // The most bytes a GeoTIFF block (a strip or a tile) may need decoded at
  // once, per decoding thread; 0 = no limit. A header may claim any size (a
  // 150-byte file can declare one strip of 100 000 x 20 000 Float64 cells,
  // 16 GB), so the cost is bounded from the header, before anything is read.
  // What counts, in the file's own pixel type and all its interleaved bands:
  //   * a tile: the whole tile;
  //   * a strip: its rows from the top down to the window's last row
  //     (libtiff decodes a strip from the top and stops there), for the
  //     codecs that decode into the caller's buffer as far as it asks (none,
  //     LZW, deflate, PackBits, LZMA, ZSTD); every other codec (JPEG,
  //     PixarLog, LogLuv, LERC, WebP, ...) holds the whole strip, and counts it.
  // A read that needs more fails with kResourceExhausted naming the file,
  // the block, its bytes and this limit. The same figure (but at least 16 MiB,
  // for libtiff's own tables) bounds every single allocation libtiff makes
  // while reading the file (a codec's buffer, the floating-point predictor's
  // copy, tag and strip-offset arrays). A read's peak memory is
  // then the cells it returns plus, per thread, a few blocks' worth (the
  // block, a predictor's or codec's copy of it). The default, 1 GiB, is a
  // strip of 16 384 x 16 384 Float32 cells; a file with larger strips reads
  // with a larger limit, or once re-tiled (gdal_translate -co TILED=YES).
  std::uint64_t max_block_bytes = std::uint64_t{1} << 30;
};

// What a read decoded. A "block" is the file's unit of storage and decoding:
// a tile of a tiled TIFF, a strip of a striped one, the whole file otherwise.
struct ReadStats {
  int file_width = 0, file_height = 0;    // the raster's size in cells
  Window window;                          // the cells returned, in the file's grid
  bool tiled = false;                     // blocks are tiles (else strips, or the whole file)
  int block_width = 0, block_height = 0;  // cells per block (a strip: the width x rows per strip)
  std::uint64_t blocks_total = 0;         // blocks of the band read
  std::uint64_t blocks_read = 0;          // blocks decoded (0 for a header read)
  std::uint64_t cells_decoded = 0;        // cells decoded: whole tiles, a strip down to the last row wanted
  double seconds = 0.0;                   // wall time of the read
  // Every cell returned that is not a void lies in [value_min, value_max]
  // (an infinity counts as a value). A reader that does not track them
  // leaves the whole line; the GeoTIFF reader narrows them to the lowest and
  // highest value it converted, so that an elevation source can check the
  // cells' plausibility without a pass over them (source.hpp, valid_min).
  float value_min = -std::numeric_limits<float>::infinity();
  float value_max = std::numeric_limits<float>::infinity();
};

// A raster's facts without its pixels.
struct DemHeader {
  int width = 0, height = 0;
  Georeference georef;
  std::optional<double> nodata;
  std::string source;  // the path
  std::string format;  // as Dem::format
  bool tiled = false;
  int block_width = 0, block_height = 0;
  std::uint64_t blocks_total = 0;
  // A window's read costs only its own rows, not the whole block's: an .hgt
  // (raw rows at known offsets) and the formats held decoded. A source may
  // then cut the block into bands of rows; a TIFF's strip is decoded whole
  // by any read that touches it, so it is never cut.
  bool rows_read_alone = false;
};

// An opened raster whose cells can be read many times, window by window,
// from any thread at once, without parsing its header again: what a tiled
// source (source.hpp) holds for each of its files. GeoTIFF windows decode
// only the blocks under them; .hgt windows read only their rows; the other
// formats are held decoded (they are small).
class RasterFile {
 public:
  virtual ~RasterFile() = default;
  const DemHeader& header() const { return header_; }
  // Cells of `window` (the file's grid, inside the raster: callers clip),
  // nodata as NaN, decoded on `threads` threads (0 = all cores). Errors name
  // the file and the block that failed to decode. Thread-safe.
  virtual Result<Grid<float>> read_cells(const Window& window, unsigned threads, ReadStats* stats = nullptr) const = 0;

 protected:
  explicit RasterFile(DemHeader header) : header_(std::move(header)) {}

 private:
  DemHeader header_;
};

// Opens any supported format; same checks and errors as read_dem_header().
Result<std::unique_ptr<RasterFile>> open_raster(const std::string& path, const ReadOptions& options = {});

// Reads any supported format. `stats`, when given, receives what was decoded.
Result<Dem> read_dem(const std::string& path, const ReadOptions& options = {}, ReadStats* stats = nullptr);

// Size, georeference, nodata and layout; no pixel is decoded for a GeoTIFF
// (the other formats are small and read whole). Same checks and errors as
// read_dem() except those that need pixels. ReadOptions::window is ignored.
Result<DemHeader> read_dem_header(const std::string& path, const ReadOptions& options = {});

// `window` clipped to a width x height raster; kOutOfRange (naming `path`)
// when nothing of it is inside. For readers.
Result<Window> clip_read_window(const Window& window, int width, int height, const std::string& path);

// Format-specific entry points (read_dem dispatches to these).
Result<Dem> read_geotiff(const std::string& path, const ReadOptions& options, ReadStats* stats = nullptr);
Result<DemHeader> read_geotiff_header(const std::string& path, const ReadOptions& options);
Result<Dem> read_hgt(const std::string& path);
Result<std::unique_ptr<RasterFile>> open_geotiff(const std::string& path, const ReadOptions& options);
Result<std::unique_ptr<RasterFile>> open_hgt(const std::string& path);
Result<Dem> read_terrain_rgb(const std::string& path, const ReadOptions& options);

}  // namespace horizon::terrain
