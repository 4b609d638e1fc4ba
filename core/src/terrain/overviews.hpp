// overviews.hpp — private: the reduced-resolution copies a COG carries
// (geotiff_options.hpp), built as GDAL builds them: each level half the size
// of the one above (odd sizes rounded up), computed from it, down to the
// first level that fits in one tile.
//
// Each overview cell summarises the 2 x 2 cells above it (fewer on an odd
// edge). Missing cells (NaN, or the nodata value) take no part:
//   kNearest  the block's north-west cell, whatever it holds
//   kMode     the value most of the block's present cells hold; a tie goes to
//             the first in row order (north-west, north-east, south-west,
//             south-east); missing when none is present. For codes: a
//             visibility raster's overview is still 1, 0 and 255, never 0.5.
//   kAverage  the mean of the present cells (rounded to the nearest integer
//             for integer rasters); missing when none is present.
// A missing overview cell is NaN for float rasters (the writer then stores
// the nodata value), the nodata value for integer ones.
#pragma once

#include <optional>
#include <vector>

#include "horizon/terrain/geotiff_options.hpp"
#include "horizon/terrain/grid.hpp"

namespace horizon::terrain::detail {

// The levels below `full` for tiles of `tile` x `tile` cells (empty when
// `full` already fits in one). `resampling` must not be kDefault.
template <class T>
std::vector<Grid<T>> build_overviews(const Grid<T>& full, int tile, OverviewResampling resampling,
                                     std::optional<double> nodata);

}  // namespace horizon::terrain::detail
