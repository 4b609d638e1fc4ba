// horizon/terrain/dem_reader.hpp — reading DEMs from files.
//
// Formats (chosen by content/extension, not trusted blindly):
//   * GeoTIFF / BigTIFF / COG: Int16, UInt16, Int32, Float32, Float64 (and
//     UInt8, so the engine's own viewshed rasters read back); striped
//     or tiled; any compression libtiff handles. Pixels come through
//     OpenImageIO; georeferencing (ModelPixelScale + ModelTiepoint or
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
#pragma once

#include <optional>
#include <string>

#include "horizon/common/error.hpp"
#include "horizon/terrain/dem.hpp"

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
};

// Reads any supported format.
Result<Dem> read_dem(const std::string& path, const ReadOptions& options = {});

// Format-specific entry points (read_dem dispatches to these).
Result<Dem> read_geotiff(const std::string& path, const ReadOptions& options);
Result<Dem> read_hgt(const std::string& path);
Result<Dem> read_terrain_rgb(const std::string& path, const ReadOptions& options);

}  // namespace horizon::terrain
