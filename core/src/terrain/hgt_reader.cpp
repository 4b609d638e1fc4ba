// hgt_reader.cpp — SRTM ".hgt" height tiles.
//
// Format (NASA/USGS SRTM documentation, "SRTM Topography", 2003; also
// https://lpdaac.usgs.gov/documents/179/SRTM_User_Guide_V3.pdf, section 2.1):
//   * a headerless grid of big-endian signed 16-bit metres above the EGM96
//     geoid, rows north to south, columns west to east;
//   * 1201x1201 samples (3 arc-seconds) or 3601x3601 (1 arc-second) over one
//     1x1 degree tile; the first and last rows/columns lie exactly on whole
//     degrees, shared with the neighbouring tiles;
//   * the file name gives the south-west corner: N27E086.hgt covers
//     27..28 N, 86..87 E; S01W072.hgt covers 1..0 S, 72..71 W;
//   * -32768 marks a void.
//
// Because samples sit on whole degrees, the cells (which Horizon centres on
// samples) reach half a step past the tile: origin = (lon_west - step/2,
// lat_north + step/2), exactly as GDAL's SRTMHGT driver reports.
#include <sys/stat.h>

#include <cassert>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include "horizon/terrain/dem_reader.hpp"

namespace horizon::terrain {
namespace {

constexpr std::int16_t kVoid = -32768;

Error hgt_error(ErrorCode code, const std::string& path, const std::string& what) {
  return make_error(code, "dem '" + path + "': " + what, path);
}

struct TileCorner {
  int lat_south = 0;
  int lon_west = 0;
};

// Parses "N27E086" (any case) at the start of the file's base name.
bool parse_tile_name(const std::string& path, TileCorner& corner) {
  const std::size_t slash = path.find_last_of('/');
  const std::string base = slash == std::string::npos ? path : path.substr(slash + 1);
  if (base.size() < 7) return false;
  auto digits = [&base](std::size_t pos, std::size_t n, int& value) {
    value = 0;
    for (std::size_t i = pos; i < pos + n; ++i) {
      if (!std::isdigit(static_cast<unsigned char>(base[i]))) return false;
      value = value * 10 + (base[i] - '0');
    }
    return true;
  };
  const char ns = static_cast<char>(std::toupper(static_cast<unsigned char>(base[0])));
  const char ew = static_cast<char>(std::toupper(static_cast<unsigned char>(base[3])));
  int lat = 0, lon = 0;
  if ((ns != 'N' && ns != 'S') || (ew != 'E' && ew != 'W') || !digits(1, 2, lat) || !digits(4, 3, lon)) return false;
  // Whatever follows must not be another digit ("N27E0861.hgt" is not a tile).
  if (base.size() > 7 && std::isdigit(static_cast<unsigned char>(base[7]))) return false;
  corner.lat_south = ns == 'N' ? lat : -lat;
  corner.lon_west = ew == 'E' ? lon : -lon;
  return corner.lat_south >= -90 && corner.lat_south <= 89 && corner.lon_west >= -180 && corner.lon_west <= 179;
}

// Checks the name and size of an .hgt file; its header says the rest.
Result<DemHeader> hgt_header(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    if (errno == ENOENT || errno == ENOTDIR) return hgt_error(ErrorCode::kNotFound, path, "no such file");
    return hgt_error(ErrorCode::kIoError, path, std::string("cannot access: ") + std::strerror(errno));
  }
  if (S_ISDIR(st.st_mode)) return hgt_error(ErrorCode::kDataError, path, "not a raster (it is a directory)");

  TileCorner corner;
  if (!parse_tile_name(path, corner))
    return hgt_error(ErrorCode::kDataError, path,
                     "an SRTM .hgt file must be named after its south-west corner, like N27E086.hgt or S01W072.hgt");

  int n = 0;
  const auto size = static_cast<std::uint64_t>(st.st_size);
  if (size == 1201ULL * 1201ULL * 2ULL)
    n = 1201;
  else if (size == 3601ULL * 3601ULL * 2ULL)
    n = 3601;
  else
    return hgt_error(ErrorCode::kDataError, path,
                     "has " + std::to_string(size) +
                         " bytes; an SRTM .hgt tile has 2884802 (1201x1201, 3\") or 25934402 (3601x3601, 1\")");

  DemHeader h;
  h.width = h.height = n;
  const double step = 1.0 / (n - 1);
  h.georef.transform = GeoTransform{corner.lon_west - 0.5 * step, step, corner.lat_south + 1.0 + 0.5 * step, -step};
  h.georef.epsg = 4326;
  h.nodata = static_cast<double>(kVoid);
  h.source = path;
  h.format = std::string("SRTM HGT ") + (n == 1201 ? "3" : "1") + " arc-second (" + std::to_string(n) + "x" +
             std::to_string(n) + ")";
  // No internal blocks: rows are read directly, so a window reads its rows only.
  h.block_width = n;
  h.block_height = n;
  h.blocks_total = 1;
  h.rows_read_alone = true;  // raw rows at known offsets
  return h;
}

// The rows of a window are one contiguous run of the file: one read, then
// the window's columns converted from big-endian int16.
class HgtFile final : public RasterFile {
 public:
  explicit HgtFile(DemHeader header) : RasterFile(std::move(header)) {}

  Result<Grid<float>> read_cells(const Window& window, unsigned /*threads*/, ReadStats* stats) const override {
    const auto start = std::chrono::steady_clock::now();
    const DemHeader& h = header();
    const int n = h.width;
    assert(!window.empty() && window.col0 >= 0 && window.row0 >= 0 && window.col1 <= n && window.row1 <= n);
    const std::size_t row_bytes = static_cast<std::size_t>(n) * 2;
    std::vector<unsigned char> raw(row_bytes * static_cast<std::size_t>(window.height()));
    std::ifstream in(h.source, std::ios::binary);
    if (!in) return hgt_error(ErrorCode::kIoError, h.source, std::string("cannot open: ") + std::strerror(errno));
    in.seekg(static_cast<std::streamoff>(row_bytes * static_cast<std::size_t>(window.row0)));
    if (!in.read(reinterpret_cast<char*>(raw.data()), static_cast<std::streamsize>(raw.size())))
      return hgt_error(ErrorCode::kIoError, h.source,
                       "cannot read rows " + std::to_string(window.row0) + ".." + std::to_string(window.row1 - 1) +
                           " (the file is shorter than an .hgt tile, or unreadable)");
    Grid<float> cells(window.width(), window.height(), kUninitialized);
    for (int r = 0; r < window.height(); ++r) {
      const unsigned char* src =
          raw.data() + static_cast<std::size_t>(r) * row_bytes + 2 * static_cast<std::size_t>(window.col0);
      float* dst = cells.row(r);
      for (int c = 0; c < window.width(); ++c) {
        const auto v = static_cast<std::int16_t>(static_cast<std::uint16_t>((src[2 * c] << 8) | src[2 * c + 1]));
        dst[c] = v == kVoid ? std::numeric_limits<float>::quiet_NaN() : static_cast<float>(v);
      }
    }
    if (stats) {
      *stats = ReadStats{};
      stats->file_width = stats->file_height = n;
      stats->window = window;
      stats->block_width = stats->block_height = n;
      stats->blocks_total = stats->blocks_read = 1;
      stats->cells_decoded = window.cell_count();
      stats->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    }
    return cells;
  }
};

}  // namespace

Result<std::unique_ptr<RasterFile>> open_hgt(const std::string& path) {
  auto header = hgt_header(path);
  if (!header.ok()) return header.error();
  return std::unique_ptr<RasterFile>(std::make_unique<HgtFile>(std::move(*header)));
}

Result<Dem> read_hgt(const std::string& path) {
  auto file = open_hgt(path);
  if (!file.ok()) return file.error();
  const DemHeader& h = (*file)->header();
  auto cells = (*file)->read_cells(Window{0, 0, h.width, h.height}, 1);
  if (!cells.ok()) return cells.error();
  Dem dem;
  dem.elevation = std::move(*cells);
  dem.georef = h.georef;
  dem.nodata = h.nodata;
  dem.source = h.source;
  dem.format = h.format;
  return dem;
}

}  // namespace horizon::terrain
