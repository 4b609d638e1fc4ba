// mesh/tin_raster.cpp — each cell centre's triangle (tin_raster.hpp).
//
// Every triangle is taken to grid coordinates (col, row of its corners) and
// the cell centres in its bounding box tested with barycentric weights
// there; a later triangle overwrites an earlier one on a shared edge. The
// signed area divides, so either winding reads the same (north-up grids
// flip y, and a TIN read from disk need not be counter-clockwise).
#include "horizon/mesh/tin_raster.hpp"

#include <algorithm>
#include <cmath>

namespace horizon::mesh {

terrain::Grid<std::uint32_t> cell_triangles(const terrain::GeoTransform& transform, int width, int height,
                                            const std::vector<TinVertex>& crs_vertices,
                                            const std::vector<TinTriangle>& triangles) {
  terrain::Grid<std::uint32_t> grid(width, height, kNoTriangle);
  if (width <= 0 || height <= 0) return grid;
  for (std::size_t i = 0; i < triangles.size(); ++i) {
    const TinTriangle& tri = triangles[i];
    const TinVertex& a = crs_vertices[tri[0]];
    const TinVertex& b = crs_vertices[tri[1]];
    const TinVertex& c = crs_vertices[tri[2]];
    const double cols[3] = {transform.col_at(a.x), transform.col_at(b.x), transform.col_at(c.x)};
    const double rows[3] = {transform.row_at(a.y), transform.row_at(b.y), transform.row_at(c.y)};
    const double area = (cols[1] - cols[0]) * (rows[2] - rows[0]) - (rows[1] - rows[0]) * (cols[2] - cols[0]);
    if (!(area != 0.0) || !std::isfinite(area)) continue;  // no area: it holds no centre
    // The bounding box in whole cells, clipped to the grid (as doubles first:
    // a corner far off the grid must not overflow an int).
    const double lo_col = std::max(0.0, std::floor(std::min({cols[0], cols[1], cols[2]})));
    const double hi_col = std::min(width - 1.0, std::ceil(std::max({cols[0], cols[1], cols[2]})));
    const double lo_row = std::max(0.0, std::floor(std::min({rows[0], rows[1], rows[2]})));
    const double hi_row = std::min(height - 1.0, std::ceil(std::max({rows[0], rows[1], rows[2]})));
    if (!(lo_col <= hi_col) || !(lo_row <= hi_row)) continue;  // off the grid
    const int c0 = static_cast<int>(lo_col), c1 = static_cast<int>(hi_col);
    const int r0 = static_cast<int>(lo_row), r1 = static_cast<int>(hi_row);
    const std::uint32_t index = static_cast<std::uint32_t>(i);
    for (int r = r0; r <= r1; ++r)
      for (int col = c0; col <= c1; ++col) {
        bool inside = true;
        for (int e = 0; e < 3 && inside; ++e) {
          const int p = (e + 1) % 3, q = (e + 2) % 3;
          const double w = ((cols[q] - cols[p]) * (r - rows[p]) - (rows[q] - rows[p]) * (col - cols[p])) / area;
          inside = w >= -1e-12;
        }
        if (inside) grid.at(col, r) = index;
      }
  }
  return grid;
}

}  // namespace horizon::mesh
