// horizon/terrain/georef.hpp — where a grid lies on the Earth.
//
// GeoTransform follows GDAL's convention: the *outer corner* of cell (c, r) is
//   x = origin_x + c * pixel_width,  y = origin_y + r * pixel_height
// (pixel_height is negative for north-up rasters). Rotated/sheared transforms
// are rejected when a DEM is read, so none are represented here. A file whose
// GeoTIFF says PixelIsPoint is shifted by half a cell on read, so the transform
// always describes cell corners ("Area").
//
// The horizontal CRS is an EPSG code; horizon::geodesy::Crs does its maths.
#pragma once

#include <cmath>

namespace horizon::terrain {

struct GeoTransform {
  double origin_x = 0.0;      // x of the outer corner of cell (0, 0), CRS units
  double pixel_width = 1.0;   // CRS units per column, > 0
  double origin_y = 0.0;      // y of the outer corner of cell (0, 0), CRS units
  double pixel_height = -1.0; // CRS units per row, < 0 for north-up

  // CRS coordinates of the centre of cell (col, row); fractional cells allowed.
  double x_at(double col) const { return origin_x + (col + 0.5) * pixel_width; }
  double y_at(double row) const { return origin_y + (row + 0.5) * pixel_height; }
  // Continuous grid coordinates (cell centres at integers) of a CRS point.
  double col_at(double x) const { return (x - origin_x) / pixel_width - 0.5; }
  double row_at(double y) const { return (y - origin_y) / pixel_height - 0.5; }

  // The transform of the sub-grid whose cell (0, 0) is this grid's (col0, row0).
  GeoTransform shifted(int col0, int row0) const {
    return {origin_x + col0 * pixel_width, pixel_width, origin_y + row0 * pixel_height, pixel_height};
  }
  friend bool operator==(const GeoTransform&, const GeoTransform&) = default;
};

struct Georeference {
  GeoTransform transform;
  int epsg = 0;  // horizontal CRS; 0 means "none": such a DEM can be read but not georeferenced
};

}  // namespace horizon::terrain
