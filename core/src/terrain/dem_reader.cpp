// dem_reader.cpp — read_dem: pick the right reader for a file.
//
// The choice rests on content first and on the name second, because names
// lie (a ".tif" that is really a PNG, a download saved without extension):
//   * TIFF magic "II*\0" / "MM\0*" (TIFF 6.0, section 2) or BigTIFF
//     "II+\0" / "MM\0+"                          -> read_geotiff
//   * PNG signature 89 50 4E 47 0D 0A 1A 0A (RFC 2083, section 3.1)
//                                                 -> read_terrain_rgb
//   * extension ".hgt" (any case; the format has no header)  -> read_hgt
// Anything else is "not a raster", with the formats we do read in the message.
#include <sys/stat.h>

#include <algorithm>
#include <array>
#include <cassert>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <string>
#include <utility>

#include "horizon/terrain/dem_reader.hpp"

namespace horizon::terrain {
namespace {

Error dem_error(ErrorCode code, const std::string& path, const std::string& what) {
  return make_error(code, "dem '" + path + "': " + what, path);
}

bool has_extension(const std::string& path, const char* ext) {
  const std::size_t n = std::strlen(ext);
  if (path.size() < n) return false;
  for (std::size_t i = 0; i < n; ++i)
    if (std::tolower(static_cast<unsigned char>(path[path.size() - n + i])) != ext[i]) return false;
  return true;
}

enum class Format { kGeoTiff, kTerrainRgb, kHgt };

// Checks the path and the band, then sniffs the format (see the top of the file).
Result<Format> sniff(const std::string& path, const ReadOptions& options) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    if (errno == ENOENT || errno == ENOTDIR) return dem_error(ErrorCode::kNotFound, path, "no such file");
    return dem_error(ErrorCode::kIoError, path, std::string("cannot access: ") + std::strerror(errno));
  }
  if (S_ISDIR(st.st_mode)) return dem_error(ErrorCode::kDataError, path, "not a raster (it is a directory)");
  if (!S_ISREG(st.st_mode)) return dem_error(ErrorCode::kDataError, path, "not a raster (not a regular file)");
  if (options.band < 0)
    return make_error(ErrorCode::kInvalidArgument,
                      "dem '" + path + "': band " + std::to_string(options.band) + " is invalid (bands count from 1)",
                      "band");

  std::array<unsigned char, 8> magic{};
  std::size_t got = 0;
  if (std::FILE* f = std::fopen(path.c_str(), "rb")) {
    got = std::fread(magic.data(), 1, magic.size(), f);
    std::fclose(f);
  } else {
    return dem_error(ErrorCode::kIoError, path, std::string("cannot open: ") + std::strerror(errno));
  }

  const bool tiff =
      got >= 4 && ((magic[0] == 'I' && magic[1] == 'I' && (magic[2] == 42 || magic[2] == 43) && magic[3] == 0) ||
                   (magic[0] == 'M' && magic[1] == 'M' && magic[2] == 0 && (magic[3] == 42 || magic[3] == 43)));
  static constexpr unsigned char kPng[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  const bool png = got == 8 && std::memcmp(magic.data(), kPng, 8) == 0;

  if (tiff) return Format::kGeoTiff;
  if (png) {
    if (options.band > 1)
      return make_error(ErrorCode::kInvalidArgument,
                        "dem '" + path + "': a terrain-RGB tile encodes one height band; band " +
                            std::to_string(options.band) + " does not exist",
                        "band");
    return Format::kTerrainRgb;
  }
  if (has_extension(path, ".hgt")) {
    if (options.band > 1)
      return make_error(ErrorCode::kInvalidArgument,
                        "dem '" + path + "': band " + std::to_string(options.band) + " requested, file has 1", "band");
    return Format::kHgt;
  }
  return dem_error(ErrorCode::kDataError, path,
                   "not a raster Horizon reads (supported: GeoTIFF/BigTIFF, SRTM .hgt, terrain-RGB PNG)");
}

// A format without internal blocks: read whole, then keep the window.
Result<Dem> read_whole(const std::string& path, Format format, const ReadOptions& options, ReadStats* stats) {
  const auto start = std::chrono::steady_clock::now();
  auto dem = format == Format::kHgt ? read_hgt(path) : read_terrain_rgb(path, options);
  if (!dem.ok()) return dem.error();
  const int width = dem->width(), height = dem->height();
  Window window{0, 0, width, height};
  if (options.window) {
    auto clipped = clip_read_window(*options.window, width, height, path);
    if (!clipped.ok()) return clipped.error();
    window = *clipped;
    if (!(window == Window{0, 0, width, height})) {
      Grid<float> cropped(window.width(), window.height());
      for (int r = window.row0; r < window.row1; ++r)
        std::copy_n(dem->elevation.row(r) + window.col0, window.width(), cropped.row(r - window.row0));
      dem->elevation = std::move(cropped);
      dem->georef.transform = dem->georef.transform.shifted(window.col0, window.row0);
    }
  }
  if (stats) {
    *stats = ReadStats{};
    stats->file_width = width;
    stats->file_height = height;
    stats->window = window;
    stats->block_width = width;
    stats->block_height = height;
    stats->blocks_total = 1;
    stats->blocks_read = 1;
    stats->cells_decoded = static_cast<std::uint64_t>(width) * static_cast<std::uint64_t>(height);
    stats->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }
  return dem;
}

// The header of a format without internal blocks: one block, the whole raster
// (as read_whole's stats count it).
DemHeader header_of_whole(const Dem& dem) {
  DemHeader h;
  h.width = dem.width();
  h.height = dem.height();
  h.georef = dem.georef;
  h.nodata = dem.nodata;
  h.source = dem.source;
  h.format = dem.format;
  h.block_width = h.width;
  h.block_height = h.height;
  h.blocks_total = 1;
  h.rows_read_alone = true;  // held decoded (DecodedFile)
  return h;
}

// A small raster held decoded (terrain-RGB tiles: 256x256 cells).
class DecodedFile final : public RasterFile {
 public:
  DecodedFile(DemHeader header, Grid<float> cells) : RasterFile(std::move(header)), cells_(std::move(cells)) {}

  Result<Grid<float>> read_cells(const Window& window, unsigned /*threads*/, ReadStats* stats) const override {
    assert(!window.empty() && window.col0 >= 0 && window.row0 >= 0 && window.col1 <= cells_.width() &&
           window.row1 <= cells_.height());
    Grid<float> out(window.width(), window.height(), kUninitialized);
    for (int r = window.row0; r < window.row1; ++r)
      std::copy_n(cells_.row(r) + window.col0, window.width(), out.row(r - window.row0));
    if (stats) {
      *stats = ReadStats{};
      stats->file_width = cells_.width();
      stats->file_height = cells_.height();
      stats->window = window;
      stats->block_width = cells_.width();
      stats->block_height = cells_.height();
      stats->blocks_total = stats->blocks_read = 1;
      stats->cells_decoded = window.cell_count();
    }
    return out;
  }

 private:
  Grid<float> cells_;
};

}  // namespace

Result<std::unique_ptr<RasterFile>> open_raster(const std::string& path, const ReadOptions& options) {
  auto format = sniff(path, options);
  if (!format.ok()) return format.error();
  if (*format == Format::kGeoTiff) return open_geotiff(path, options);
  if (*format == Format::kHgt) return open_hgt(path);
  auto dem = read_terrain_rgb(path, options);
  if (!dem.ok()) return dem.error();
  return std::unique_ptr<RasterFile>(std::make_unique<DecodedFile>(header_of_whole(*dem), std::move(dem->elevation)));
}

Result<Window> clip_read_window(const Window& window, int width, int height, const std::string& path) {
  const Window clipped{std::max(window.col0, 0), std::max(window.row0, 0), std::min(window.col1, width),
                       std::min(window.row1, height)};
  if (clipped.empty())
    return make_error(ErrorCode::kOutOfRange,
                      "dem '" + path + "': window cols [" + std::to_string(window.col0) + ", " +
                          std::to_string(window.col1) + ") rows [" + std::to_string(window.row0) + ", " +
                          std::to_string(window.row1) + ") has no cell inside the " + std::to_string(width) + "x" +
                          std::to_string(height) + " raster",
                      "window");
  return clipped;
}

Result<Dem> read_dem(const std::string& path, const ReadOptions& options, ReadStats* stats) {
  auto format = sniff(path, options);
  if (!format.ok()) return format.error();
  if (*format == Format::kGeoTiff) return read_geotiff(path, options, stats);
  return read_whole(path, *format, options, stats);
}

Result<DemHeader> read_dem_header(const std::string& path, const ReadOptions& options) {
  auto format = sniff(path, options);
  if (!format.ok()) return format.error();
  if (*format == Format::kGeoTiff) return read_geotiff_header(path, options);
  ReadOptions whole = options;
  whole.window.reset();
  auto dem = read_whole(path, *format, whole, nullptr);
  if (!dem.ok()) return dem.error();
  return header_of_whole(*dem);
}

}  // namespace horizon::terrain
