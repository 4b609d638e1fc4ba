// Helpers shared by the visibility tests.
#pragma once

#include <cmath>
#include <utility>

#include "test_support.hpp"

#include "horizon/geodesy/observer.hpp"
#include "horizon/terrain/dem.hpp"
#include "horizon/visibility/viewshed.hpp"

namespace horizon::testing {

// A DEM in plain metres (no CRS), so hand-computed distances are exact.
template <class F>
terrain::Dem grid_dem(int width, int height, F&& height_fn, double cell_size = 10.0) {
  return make_dem(width, height, std::forward<F>(height_fn), cell_size, /*epsg=*/0);
}

// An observer at grid position (col, row), `height` metres above the bilinear terrain.
inline geodesy::GridPoint eye_at(const terrain::Dem& dem, double col, double row, double height) {
  geodesy::GridPoint p;
  p.col = col;
  p.row = row;
  p.x = dem.georef.transform.x_at(col);
  p.y = dem.georef.transform.y_at(row);
  p.ground = terrain::sample_bilinear(dem.elevation, col, row);
  p.elevation = p.ground + height;
  return p;
}

// Options for exact hand-computed cases: no curvature, one algorithm.
inline visibility::ViewshedOptions flat_earth(visibility::Algorithm algorithm) {
  visibility::ViewshedOptions o;
  o.curvature_coefficient = 0.0;
  o.algorithm = algorithm;
  return o;
}

// OHF of DEM cell (col, row) in a result (window-relative storage).
inline float ohf_at(const visibility::ViewshedResult& r, int col, int row) {
  return r.ohf.at(col - r.frame.window.col0, row - r.frame.window.row0);
}

}  // namespace horizon::testing
