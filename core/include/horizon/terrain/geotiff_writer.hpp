// horizon/terrain/geotiff_writer.hpp — writing georeferenced result rasters.
//
// Output is a single-band GeoTIFF (by default deflate, predictor, 256x256
// tiles; GeoTiffOptions chooses the codec, blocks, BigTIFF, or a
// Cloud-Optimised GeoTIFF with overviews: geotiff_options.hpp) carrying
// the georeference (ModelPixelScale + ModelTiepoint, GeoKeys from the EPSG
// code, PixelIsArea) and a GDAL_NODATA tag, so gdalinfo and QGIS read extent,
// CRS and nodata correctly. Written with libtiff + libgeotiff because
// OpenImageIO 2.4 cannot write GeoTIFF tags.
//
// Atomic: data goes to "<path>.tmp-<pid>-<n>" in the same directory and is
// renamed over `path` only after a successful close; on any failure the
// temporary is removed and `path` is untouched.
//
// Output is deterministic: the same grid and georeference give the same bytes.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>

#include "horizon/common/error.hpp"
#include "horizon/terrain/georef.hpp"
#include "horizon/terrain/geotiff_options.hpp"
#include "horizon/terrain/grid.hpp"

namespace horizon::terrain {

// Float32 raster. NaN cells are written as `nodata` when given (and the tag set
// to it); with no nodata they stay NaN and the tag says "nan".
Status write_geotiff(const std::string& path, const Grid<float>& grid, const Georeference& georef,
                     std::optional<double> nodata, const GeoTiffOptions& options = {});

// UInt8 raster (e.g. a viewshed: 1 visible, 0 hidden, 255 nodata).
Status write_geotiff(const std::string& path, const Grid<std::uint8_t>& grid, const Georeference& georef,
                     std::optional<double> nodata, const GeoTiffOptions& options = {});

// The colour (R, G, B) of each of the 256 values of a UInt8 raster.
using ColourTable = std::array<std::array<std::uint8_t, 3>, 256>;

// A UInt8 raster with a colour table (TIFF's Palette photometric and its
// ColorMap tag): gdalinfo lists the "Color Table", and GIS software (QGIS,
// GDAL's tools) draws the codes in those colours without a style.
Status write_geotiff(const std::string& path, const Grid<std::uint8_t>& grid, const Georeference& georef,
                     std::optional<double> nodata, const ColourTable& colours, const GeoTiffOptions& options = {});

// A Float32 image with no georeference (a camera's depth image, its hits):
// one or more bands of one size, band after band, NaN for no value, the
// same tiling, compression and atomicity as the rasters above.
Status write_tiff_image(const std::string& path, std::span<const Grid<float>* const> bands);

// UInt32 raster (e.g. how many observers see each cell).
Status write_geotiff(const std::string& path, const Grid<std::uint32_t>& grid, const Georeference& georef,
                     std::optional<double> nodata, const GeoTiffOptions& options = {});

}  // namespace horizon::terrain
