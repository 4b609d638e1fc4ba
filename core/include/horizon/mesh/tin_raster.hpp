// horizon/mesh/tin_raster.hpp — which triangle of a TIN stands over each
// cell of a DEM's grid.
//
// A TIN built from a DEM (tin_from_dem.hpp) is drawn by a renderer, but its
// answers are read on the DEM's grid: `horizon mesh -o` writes each cell's
// triangle state as a raster, and `horizon bench --mesh` compares the cull
// with R3's viewshed of the DEM cell by cell. Both need the same mapping:
// the triangle (seen from above) that holds each cell centre.
//
// Frame: the vertices are in the DEM's CRS (x, y as the geotransform reads
// them; not a LocalFrame's metres), cell (col, row)'s centre is
// transform.x_at(col), transform.y_at(row). A centre is in a triangle when
// its three barycentric weights, taken in grid coordinates, are each at
// least -1e-12: a centre on an edge or a vertex is in every triangle that
// meets there, and the mapping gives it the last of them by index, so each
// cell has one triangle or none (kNoTriangle: outside the TIN, or in a hole).
// z is not read.
//
// Cost: O(sum over triangles of the cells in each one's bounding box), one
// pass; no allocation beyond the output.
#pragma once

#include <cstdint>
#include <vector>

#include "horizon/mesh/tin.hpp"
#include "horizon/terrain/georef.hpp"
#include "horizon/terrain/grid.hpp"

namespace horizon::mesh {

inline constexpr std::uint32_t kNoTriangle = 0xFFFF'FFFFu;

// A width x height grid holding, at each cell, the index in `triangles` of
// the triangle over its centre, or kNoTriangle. Every index in `triangles`
// must name a vertex of `crs_vertices` (a checked TIN's do); a triangle with
// no area holds no centre.
terrain::Grid<std::uint32_t> cell_triangles(const terrain::GeoTransform& transform, int width, int height,
                                            const std::vector<TinVertex>& crs_vertices,
                                            const std::vector<TinTriangle>& triangles);

}  // namespace horizon::mesh
