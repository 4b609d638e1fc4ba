// horizon/terrain/dem.hpp — a digital elevation model held in memory.
//
// Elevations are metres, float32, sampled at cell centres; between samples the
// terrain is the bilinear surface through them. Cells the source marked as
// nodata (GDAL_NODATA value, SRTM voids) hold NaN. `nodata` remembers the
// source's code so outputs can write the same one.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "horizon/terrain/georef.hpp"
#include "horizon/terrain/grid.hpp"

namespace horizon::terrain {

struct Dem {
  Grid<float> elevation;          // metres; NaN = no data
  Georeference georef;
  std::optional<double> nodata;   // the source's nodata code, if it had one
  std::string source;             // path or description, used in error messages
  std::string format;             // e.g. "GeoTIFF Int16 (deflate, tiled 256x256)", "SRTM HGT 3 arc-second"

  int width() const { return elevation.width(); }
  int height() const { return elevation.height(); }
};

struct ElevationStats {
  double min = 0.0, max = 0.0;    // over valid cells; both 0 when there are none
  std::uint64_t valid_cells = 0;
  std::uint64_t nodata_cells = 0;
};

ElevationStats elevation_stats(const Grid<float>& elevation);

// Bilinear terrain height at continuous grid coordinates (col, row). Positions
// in the outer half-cell margin are clamped to the border samples; positions
// beyond the outer extent (or not finite) give NaN. Returns NaN if any of the
// (up to four) samples it blends with a non-zero weight is NaN.
double sample_bilinear(const Grid<float>& elevation, double col, double row);

}  // namespace horizon::terrain
