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

#include <array>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <string>

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

}  // namespace

Result<Dem> read_dem(const std::string& path, const ReadOptions& options) {
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

  if (tiff) return read_geotiff(path, options);
  if (png) {
    if (options.band > 1)
      return make_error(ErrorCode::kInvalidArgument,
                        "dem '" + path + "': a terrain-RGB tile encodes one height band; band " +
                            std::to_string(options.band) + " does not exist",
                        "band");
    return read_terrain_rgb(path, options);
  }
  if (has_extension(path, ".hgt")) {
    if (options.band > 1)
      return make_error(ErrorCode::kInvalidArgument,
                        "dem '" + path + "': band " + std::to_string(options.band) + " requested, file has 1", "band");
    return read_hgt(path);
  }
  return dem_error(ErrorCode::kDataError, path,
                   "not a raster Horizon reads (supported: GeoTIFF/BigTIFF, SRTM .hgt, terrain-RGB PNG)");
}

}  // namespace horizon::terrain
