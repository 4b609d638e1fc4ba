// terrain_rgb_reader.cpp — Mapbox terrain-RGB tiles (PNG) as DEMs.
//
// Formats and specifications:
//   * Mapbox Terrain-RGB v1 (https://docs.mapbox.com/data/tilesets/reference/mapbox-terrain-rgb-v1/):
//     height = -10000 + (R * 65536 + G * 256 + B) * 0.1 metres, 8-bit RGB.
//   * OSM "slippy map" tile numbering (https://wiki.openstreetmap.org/wiki/Slippy_map_tilenames):
//     zoom z splits the web Mercator square (EPSG:3857, half-width
//     pi * 6378137 m) into 2^z x 2^z tiles, x growing east, y growing south.
//     Tile (z, x, y) therefore spans
//       x: -pi R + x * T .. -pi R + (x + 1) * T,  y: pi R - y * T .. pi R - (y + 1) * T,
//     with T = 2 pi R / 2^z, and each of its W pixels is T / W metres wide.
//     "@2x" tiles carry 512 pixels over the same ground.
//
// Pixels are decoded by OpenImageIO. A fully transparent pixel (alpha 0, in
// RGBA tiles) has no height and becomes NaN.
#include <sys/stat.h>


#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include "horizon/geodesy/crs.hpp"
#include "horizon/imageio/imageio.hpp"
#include "horizon/terrain/dem_reader.hpp"

namespace horizon::terrain {
namespace {

constexpr int kMaxZoom = 30;

Error rgb_error(ErrorCode code, const std::string& path, const std::string& what) {
  return make_error(code, "dem '" + path + "': " + what, path);
}

bool parse_int(const std::string& s, int& value) {
  if (s.empty()) return false;
  const auto res = std::from_chars(s.data(), s.data() + s.size(), value);
  return res.ec == std::errc() && res.ptr == s.data() + s.size();
}

// ".../z/x/y.png" or ".../z/x/y@2x.png" (any extension) -> TileId.
std::optional<TileId> tile_from_path(const std::string& path) {
  std::vector<std::string> parts;
  std::size_t start = 0;
  for (std::size_t i = 0; i <= path.size(); ++i) {
    if (i == path.size() || path[i] == '/') {
      parts.push_back(path.substr(start, i - start));
      start = i + 1;
    }
  }
  if (parts.size() < 3) return std::nullopt;
  std::string last = parts.back();
  const std::size_t dot = last.find('.');
  if (dot != std::string::npos) last.resize(dot);
  const std::size_t at = last.find('@');
  if (at != std::string::npos) last.resize(at);
  TileId id;
  if (!parse_int(parts[parts.size() - 3], id.z) || !parse_int(parts[parts.size() - 2], id.x) || !parse_int(last, id.y))
    return std::nullopt;
  return id;
}

}  // namespace

Result<Dem> read_terrain_rgb(const std::string& path, const ReadOptions& options) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    if (errno == ENOENT || errno == ENOTDIR) return rgb_error(ErrorCode::kNotFound, path, "no such file");
    return rgb_error(ErrorCode::kIoError, path, std::string("cannot access: ") + std::strerror(errno));
  }
  if (S_ISDIR(st.st_mode)) return rgb_error(ErrorCode::kDataError, path, "not a raster (it is a directory)");

  std::optional<TileId> tile = options.tile ? options.tile : tile_from_path(path);
  if (!tile)
    return make_error(ErrorCode::kInvalidArgument,
                      "dem '" + path +
                          "': a terrain-RGB tile is placed by its zoom and column/row in the path; keep it "
                          "at a path ending in z/x/y.png (e.g. tiles/12/3641/1613.png)",
                      "tile");
  if (tile->z < 0 || tile->z > kMaxZoom || tile->x < 0 || tile->y < 0 || tile->x >= (1LL << tile->z) ||
      tile->y >= (1LL << tile->z))
    return make_error(ErrorCode::kInvalidArgument,
                      "dem '" + path + "': tile " + std::to_string(tile->z) + "/" + std::to_string(tile->x) + "/" +
                          std::to_string(tile->y) + " does not exist (need 0 <= z <= 30 and 0 <= x, y < 2^z)",
                      "tile");

  auto image = imageio::read_image8(path);
  if (!image.ok()) {
    if (image.error().code != ErrorCode::kDataError) return image.error();  // the plugin did not load
    return rgb_error(ErrorCode::kDataError, path,
                     image.error().message.substr(image.error().message.find("': ") + 3));
  }
  const std::string& format_name = image->format;
  const int width = image->width, height = image->height, channels = image->channels;
  if (channels != 3 && channels != 4)
    return rgb_error(ErrorCode::kDataError, path,
                     "a terrain-RGB tile has 3 or 4 channels (RGB[A]); this image has " + std::to_string(channels));
  if (width > 65536 || height > 65536) return rgb_error(ErrorCode::kDataError, path, "has an implausible tile size");
  const std::vector<std::uint8_t>& rgb = image->pixels;

  Dem dem;
  dem.elevation = Grid<float>(width, height);
  float* dst = dem.elevation.data();
  for (std::size_t i = 0, n = dem.elevation.size(); i < n; ++i) {
    const std::uint8_t* p = rgb.data() + i * channels;
    if (channels == 4 && p[3] == 0) {
      dst[i] = std::numeric_limits<float>::quiet_NaN();
      continue;
    }
    const std::uint32_t code = (std::uint32_t{p[0]} << 16) | (std::uint32_t{p[1]} << 8) | p[2];
    // Computed in double: code * 0.1 in float would lose the decimetre.
    dst[i] = static_cast<float>(-10000.0 + code * 0.1);
  }

  const double half_world = std::numbers::pi * geodesy::kEarthRadiusMetres;
  const double tile_size = 2.0 * half_world / std::ldexp(1.0, tile->z);
  dem.georef.transform = GeoTransform{-half_world + tile->x * tile_size, tile_size / width,
                                      half_world - tile->y * tile_size, -tile_size / height};
  dem.georef.epsg = 3857;
  dem.source = path;
  dem.format = "Mapbox terrain-RGB " + format_name + " z" + std::to_string(tile->z) + "/x" + std::to_string(tile->x) +
               "/y" + std::to_string(tile->y) + " (" + std::to_string(width) + "x" + std::to_string(height) +
               ")";
  return dem;
}

}  // namespace horizon::terrain
