// libFuzzer target: the raster readers (GeoTIFF/BigTIFF/COG, SRTM .hgt,
// terrain-RGB PNG) on arbitrary bytes. The first byte picks the format (the
// readers dispatch on the name); the rest is the file. A reader must answer
// an Error or cells, never crash, hang or read out of bounds; a header that
// opens is read through a bounded window, and whole when it is small.
//
// Memory: libFuzzer stops at 4 GiB of RSS (-rss_limit_mb=4096; one malloc
// above that counts too), under ASan, which adds shadow memory, redzones and
// a quarantine of freed blocks (64 MiB, scripts/fuzz.sh). A header of a few
// hundred bytes may claim a strip of many GB, and ZSTD, LZMA or LERC can fill
// most of it from a few KB of data, so the reader refuses a block needing
// more than ReadOptions::max_block_bytes and holds each allocation libtiff
// makes to that figure too. At 64 MiB a decoding thread holds at most a few
// such buffers (the reader's, a predictor's or codec's copy): the windows
// below decode on one thread, read_dem on every core but only rasters of at
// most 2^20 cells (8 MiB of Float64), and a source block is refused before
// its cells are allocated. RSS stays within some hundreds of MiB whatever a
// header claims, and small honest files, as the seeds are, still read whole.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <string>

#include "horizon/terrain/dem_reader.hpp"
#include "horizon/terrain/source.hpp"
#include "scratch_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace horizon::terrain;
  if (size < 1) return 0;
  // An .hgt must hold 1201^2 or 3601^2 samples (2.9 or 26 MB), beyond a
  // fuzzer's inputs: for it, the size check is what is fuzzed.
  static const char* const kNames[] = {"dem.tif", "dem.tiff", "N46W122.hgt", "dem.png"};
  const auto written = horizon::fuzz::write_scratch("raster", kNames[data[0] % 4], data + 1, size - 1);
  if (!written) return 0;
  const std::filesystem::path& path = *written;
  constexpr std::uint64_t kMaxBlockBytes = std::uint64_t{64} << 20;
  ReadOptions options;
  options.allow_missing_crs = true;
  options.max_block_bytes = kMaxBlockBytes;
  auto raster = open_raster(path.string(), options);
  if (raster.ok()) {
    const DemHeader& h = (*raster)->header();
    const Window corner{0, 0, h.width < 256 ? h.width : 256, h.height < 256 ? h.height : 256};
    (void)(*raster)->read_cells(corner, 1);
    const Window far{h.width - corner.width(), h.height - corner.height(), h.width, h.height};
    (void)(*raster)->read_cells(far, 1);
    if (static_cast<std::uint64_t>(h.width) * static_cast<std::uint64_t>(h.height) <= (1u << 20))
      (void)read_dem(path.string(), options);
  }
  // The same bytes as a source (one file): the plausible-range check and block grouping.
  SourceOptions source_options;
  source_options.allow_missing_crs = true;
  source_options.block_cells = 4096;
  source_options.max_block_bytes = kMaxBlockBytes;
  if (auto source = ElevationSource::open(path.string(), source_options); source.ok()) {
    const int w = (*source)->width() < 128 ? (*source)->width() : 128;
    const int hgt = (*source)->height() < 128 ? (*source)->height() : 128;
    BlockCache cache({.budget_bytes = 1 << 20, .io_threads = 1});
    (void)(*source)->read({0, 0, w, hgt}, &cache);
  }
  return 0;
}
