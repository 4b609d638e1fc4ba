// cog_layout.hpp — private: a tiled TIFF rewritten in the Cloud-Optimised
// GeoTIFF layout GDAL's COG driver writes (geotiff_options.hpp).
//
// libtiff writes each image's tiles and then its directory, image after image.
// A COG reader wants the opposite: every image file directory (IFD) at the
// front, so that one ranged read of the file's head finds every tile, then
// the tiles from the smallest overview to the full resolution. The rewrite
// copies every tag as it is (the GeoTIFF keys, the nodata, the colour map:
// nothing here knows them), and moves the bytes:
//
//   header | GDAL structural metadata | IFD 0, its values | IFD 1, its values
//   | ... | tiles of the last IFD | ... | tiles of IFD 0
//
// The metadata is GDAL's "ghost" header (LAYOUT=IFDS_BEFORE_DATA,
// BLOCK_ORDER=ROW_MAJOR, BLOCK_LEADER=SIZE_AS_UINT4,
// BLOCK_TRAILER=LAST_4_BYTES_REPEATED): each tile is preceded by its size as a
// little-endian uint32 and followed by a copy of its last four bytes, which
// GDAL reads to fetch a tile with one request and to check that the file was
// not edited since. Tiles keep their row-major order within an image.
// Classic TIFF and BigTIFF, little-endian (what this writer produces); a
// striped image or a big-endian file is refused.
#pragma once

#include <string>

#include "horizon/common/error.hpp"

namespace horizon::terrain::detail {

// Reads the TIFF at `in`, writes its COG form at `out` (an existing, empty
// file). Errors name `target`, the file the user asked for.
Status write_cog_layout(const std::string& in, const std::string& out, const std::string& target);

}  // namespace horizon::terrain::detail
