// horizon/terrain/source.hpp — where elevations come from: one file, or a
// mosaic of many files on one grid, read window by window.
//
//   auto source = terrain::ElevationSource::open("dem/srtm/", {});  // a folder of N46W122.hgt, ...
//   terrain::BlockCache cache({.budget_bytes = 128 << 20});         // shared by every request
//   auto dem = (*source)->read(window, &cache, &control);           // a Dem of just that window
//
// A source is opened from
//   * a file (GeoTIFF/BigTIFF/COG, SRTM .hgt, terrain-RGB PNG: dem_reader.hpp), or
//   * a folder: every `.tif`, `.tiff` and `.hgt` file directly in it (other
//     files are ignored), e.g. a folder of SRTM tiles named by their corner
//     or GeoTIFF tiles cut from one raster (gdal_translate -srcwin).
// The files of a folder must share one CRS and one cell size, and lie on one
// grid: each file's corner an integer number of cells from the others'
// (to 1e-6 cell). The mosaic is the rectangle they span; its georeference
// is taken from the files themselves (the west-most file's x origin, the
// north-most file's y origin), so a mosaic cut from a raster has exactly
// that raster's georeference and gives bit-identical answers. Where files
// overlap (SRTM neighbours repeat their shared edge row or column) the one
// first in name order wins. Cells of the rectangle that no file covers are
// a "missing tile": a read that needs one fails naming its position, unless
// SourceOptions::missing_as_nodata reads them as voids (NaN).
//
// Blocks. A source's unit of decoding and caching is a block of one file: the
// file's own tiles or strips, grouped until a block holds about
// SourceOptions::block_cells cells (an .hgt, which has no internal blocks,
// is cut into bands of rows). blocks_in() names the blocks under a window,
// so a plan knows what a request will read before reading it.
//
// Reading. read() returns the window as a Dem (georeference shifted to its
// corner, nodata as NaN), so everything downstream runs on it unchanged.
// With a BlockCache the window's blocks come from the cache (decoded on its
// I/O pool when absent, shared with every other request); without one the
// files are read directly, only the blocks under the window, on `threads`
// threads, and nothing is kept (the one-shot CLI). Both give the same cells.
// A file that fails to decode, or decodes to elevations outside
// SourceOptions' plausible range, fails the read with an error naming the
// file and the block; a file that vanished after open() reads as voids under
// missing_as_nodata.
//
// A source is immutable after open() and safe to share between threads.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "horizon/common/control.hpp"
#include "horizon/common/error.hpp"
#include "horizon/terrain/block_cache.hpp"
#include "horizon/terrain/dem.hpp"
#include "horizon/terrain/dem_reader.hpp"
#include "horizon/terrain/grid.hpp"

namespace horizon::terrain {

struct SourceOptions {
  int band = 0;                    // as ReadOptions::band, for every file
  bool allow_missing_crs = false;  // as ReadOptions (a single file only; a mosaic needs its CRS)
  // As ReadOptions::max_block_bytes, for every file: a GeoTIFF strip or tile
  // needing more to decode fails the read that touches it (kResourceExhausted).
  std::uint64_t max_block_bytes = std::uint64_t{1} << 30;
  // Cells no file covers (and files gone since open()) read as voids instead
  // of failing the read.
  bool missing_as_nodata = false;
  // Cells a block aims at: smaller tiles and strips are grouped up to it
  // (262 144 cells = 1 MiB of float32).
  std::uint64_t block_cells = 1u << 18;
  // Plausible elevations: a cell outside [valid_min, valid_max] (infinities
  // included; voids are not checked) fails the read as corrupt data, naming
  // the file, the block and the cell, so that a damaged file is refused
  // rather than served as terrain 3e38 m high. The default is the Earth's
  // relief in metres with a margin; widen it for other units or planets.
  double valid_min = -12000.0;
  double valid_max = 9000.0;
};

// One file of a source, placed in the source's grid.
struct SourceFile {
  std::string path;
  Window cells;  // where it lies in the source's grid
  std::unique_ptr<RasterFile> raster;
  int block_width = 0, block_height = 0;  // the source's blocks of this file, in cells
  int blocks_x = 0, blocks_y = 0;
  std::uint64_t first_block = 0;  // index of its block (0, 0) in the source
};

// What one read() did.
struct SourceReadStats {
  Window window;                    // the cells returned, in the source's grid
  std::uint64_t blocks_total = 0;   // the source's blocks
  std::uint64_t blocks = 0;         // blocks under the window (all read, from the cache or a file)
  std::uint64_t files = 0;          // files under the window
  std::uint64_t cells_decoded = 0;  // cells decoded by this read (cache hits decode nothing)
  FetchStats cache;                 // with a cache: hits, joins, misses, wait
  // Without a cache, from a single file: that file's own blocks (tiles or
  // strips) decoded, as read_dem reports them.
  ReadStats file;
  double seconds = 0.0;
};

class ElevationSource : public std::enable_shared_from_this<ElevationSource> {
 public:
  static Result<std::shared_ptr<const ElevationSource>> open(const std::string& path,
                                                             const SourceOptions& options = {});

  // The source as one raster: size, georeference, nodata code (the first
  // file's), `source` = the path opened, `format` (a mosaic: "mosaic of N
  // files, <first file's format>"), and blocks_total = block_count().
  const DemHeader& header() const { return header_; }
  int width() const { return header_.width; }
  int height() const { return header_.height; }
  const std::vector<SourceFile>& files() const { return files_; }
  bool is_mosaic() const { return mosaic_; }

  std::uint64_t id() const { return id_; }  // namespace of its keys in a BlockCache
  std::uint64_t block_count() const { return block_count_; }
  // The blocks whose cells meet `window` (the source's grid), by file then row.
  std::vector<std::uint64_t> blocks_in(const Window& window) const;
  // A block's cells in the source's grid, and its decoded size in bytes.
  Window block_cells(std::uint64_t block) const;
  std::uint64_t block_bytes(std::uint64_t block) const { return block_cells(block).cell_count() * sizeof(float); }

  // The cells of `window` (clipped to the source; kOutOfRange when nothing
  // is inside) as a Dem georeferenced at the clipped window's corner.
  // `cache` may be null (read the files directly, keep nothing); `control`
  // may be null; `threads` (0 = all cores) decode an uncached read.
  // `reuse` (may be null): a grid whose storage a cached read takes over
  // instead of allocating (a request's workspace, plan.hpp).
  Result<Dem> read(const Window& window, BlockCache* cache, const RunControl* control = nullptr,
                   SourceReadStats* stats = nullptr, unsigned threads = 0, Grid<float>* reuse = nullptr) const;

  // Decodes every block once on `threads` threads and returns the
  // elevation statistics: a load-time check that every file decodes,
  // naming the first file and block that does not. Through `cache` (may be
  // null: nothing is kept) the blocks stay resident while they fit.
  Result<ElevationStats> scan(unsigned threads, BlockCache* cache = nullptr, const RunControl* control = nullptr) const;

 private:
  ElevationSource() = default;
  const SourceFile& file_of(std::uint64_t block) const;
  Status check_covered(const Window& window) const;
  Result<Grid<float>> load_block(std::uint64_t block) const;

  DemHeader header_;
  std::vector<SourceFile> files_;
  SourceOptions options_;
  std::uint64_t id_ = 0;
  std::uint64_t block_count_ = 0;
  bool mosaic_ = false;
};

}  // namespace horizon::terrain
