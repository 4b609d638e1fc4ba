// dem.cpp — whole-grid statistics and the bilinear terrain surface.
//
// The terrain between cell centres is the bilinear surface through the four
// surrounding samples (DESIGN.md, "DEM"): with c0 = floor(col), fx = col - c0
// (and likewise r0, fy),
//   h = (1-fx)(1-fy) z(c0,r0) + fx(1-fy) z(c0+1,r0) + (1-fx)fy z(c0,r0+1) + fx fy z(c0+1,r0+1).
// A sample whose weight is exactly zero is not blended, so a point on a cell
// centre or on the line between two centres does not see a void beside it.
#include "horizon/terrain/dem.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace horizon::terrain {

ElevationStats elevation_stats(const Grid<float>& elevation) {
  ElevationStats stats;
  double lo = std::numeric_limits<double>::infinity();
  double hi = -std::numeric_limits<double>::infinity();
  for (const float v : elevation.values()) {
    if (std::isnan(v)) {
      ++stats.nodata_cells;
      continue;
    }
    ++stats.valid_cells;
    lo = std::min(lo, static_cast<double>(v));
    hi = std::max(hi, static_cast<double>(v));
  }
  if (stats.valid_cells > 0) {
    stats.min = lo;
    stats.max = hi;
  }
  return stats;
}

double sample_bilinear(const Grid<float>& elevation, double col, double row) {
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  const int w = elevation.width();
  const int h = elevation.height();
  // Outside the raster's outer extent (or not a number) there is no terrain.
  if (w == 0 || h == 0 || !(col >= -0.5 && col <= w - 0.5 && row >= -0.5 && row <= h - 0.5)) return kNaN;

  // The outer half-cell margin takes the border samples' values.
  col = std::clamp(col, 0.0, static_cast<double>(w - 1));
  row = std::clamp(row, 0.0, static_cast<double>(h - 1));
  const int c0 = std::min(static_cast<int>(col), w - 1);
  const int r0 = std::min(static_cast<int>(row), h - 1);
  const double fx = col - c0;
  const double fy = row - r0;
  const int c1 = fx > 0.0 ? c0 + 1 : c0;
  const int r1 = fy > 0.0 ? r0 + 1 : r0;

  const double z00 = elevation.at(c0, r0);
  if (c1 == c0 && r1 == r0) return z00;
  const double z10 = elevation.at(c1, r0);
  const double z01 = elevation.at(c0, r1);
  const double z11 = elevation.at(c1, r1);
  if (r1 == r0) return (1.0 - fx) * z00 + fx * z10;  // NaN propagates
  if (c1 == c0) return (1.0 - fy) * z00 + fy * z01;
  return (1.0 - fy) * ((1.0 - fx) * z00 + fx * z10) + fy * ((1.0 - fx) * z01 + fx * z11);
}

}  // namespace horizon::terrain
