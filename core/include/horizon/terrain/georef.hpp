// horizon/terrain/georef.hpp — where a grid lies on the Earth.
//
// GeoTransform follows GDAL's convention: the *outer corner* of cell (c, r) is
//   x = origin_x + c * pixel_width,  y = origin_y + r * pixel_height
// (pixel_height is negative for north-up rasters). Rotated/sheared transforms
// are rejected when a DEM is read, so none are represented here. A file whose
// GeoTIFF says PixelIsPoint is shifted by half a cell on read, so the transform
// always describes cell corners ("Area").
//
// The CRS is an EPSG code, or a definition where a code alone does not say
// it (a user-defined or compound CRS); horizon::geodesy::Crs::of() does its
// maths.
#pragma once

#include <cmath>
#include <string>

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
  // EPSG code of the horizontal CRS (4326, 32633, 27700, ...); 0 when the
  // CRS has none (one defined by its parameters) or there is no CRS.
  int epsg = 0;
  // The CRS's full definition when `epsg` alone does not say it: a compound
  // CRS ("EPSG:27700+5701"), or one defined by its parameters (WKT2, as
  // built from a GeoTIFF's user-defined keys). Empty otherwise; when set, it
  // is what Crs::of() reads.
  std::string crs{};
  // Set only when a file names a CRS Horizon cannot use and was read anyway
  // (ReadOptions::allow_missing_crs): what that CRS is and what is not
  // supported. `epsg` and `crs` are then empty.
  std::string crs_problem{};

  // Without a CRS a DEM is a plain grid: it can be read but not georeferenced.
  bool has_crs() const { return epsg != 0 || !crs.empty(); }
  // Same CRS, as a file states it (code and definition text).
  bool same_crs(const Georeference& other) const { return epsg == other.epsg && crs == other.crs; }
};

}  // namespace horizon::terrain
