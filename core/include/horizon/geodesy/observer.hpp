// horizon/geodesy/observer.hpp — turning a user's viewpoint into grid terms.
//
// A viewpoint is given either in the DEM's own CRS or as WGS84 lon/lat, with a
// height above the ground under it or an absolute altitude (metres, same
// vertical datum as the DEM). Resolution checks, in this order, and names the
// field that is wrong: finite numbers (x/y, lon/lat, height), the DEM has a CRS
// (for lon/lat), the point lies inside the raster's outer extent (kOutOfRange),
// and the terrain under it is not a void (kDataError, for height above ground).
// The ground under a point is bilinear between cell centres unless the spec
// asks for its cell's value (GroundSample).
#pragma once

#include <string>

#include "horizon/common/error.hpp"
#include "horizon/terrain/dem.hpp"
#include "horizon/terrain/grid.hpp"

namespace horizon::geodesy {

enum class PointFrame { kDatasetCrs, kWgs84 };
enum class HeightMode { kAboveGround, kAbsolute };

// How the ground under a point is read from the elevations.
enum class GroundSample {
  // The surface between the four nearest cell centres, bilinear: the
  // terrain every sight line is tested against, so a point is never put
  // inside it. On a coarse DEM on a slope this can lie far from the value
  // of the cell the point falls in.
  kBilinear,
  // The value of the cell the point falls in, whatever its place in it:
  // gdal_viewshed's and GRASS r.viewshed's convention (they put the eye on
  // its cell's centre and that cell's value).
  kCell,
};

struct PointSpec {
  PointFrame frame = PointFrame::kDatasetCrs;
  double x = 0.0;  // dataset CRS x, or longitude in degrees for kWgs84
  double y = 0.0;  // dataset CRS y, or latitude in degrees for kWgs84
  double height = 0.0;  // metres: above ground, or absolute altitude
  HeightMode height_mode = HeightMode::kAboveGround;
  GroundSample ground = GroundSample::kBilinear;  // the ground a height above ground stands on
};

struct GridPoint {
  double col = 0.0, row = 0.0;   // continuous grid coordinates, cell centres at integers
  double x = 0.0, y = 0.0;       // dataset CRS coordinates
  double ground = 0.0;           // terrain height under the point as PointSpec::ground reads it, metres (NaN on a void)
  double elevation = 0.0;        // absolute elevation of the point itself, metres
};

// `what` names the point in messages ("observer", "target", "from", "to").
Result<GridPoint> resolve_point(const terrain::Dem& dem, const PointSpec& spec, const char* what);

// resolve_point() in two halves, for callers that read only part of a file:
// locate_point() does checks 1-3 against a raster's georeference and size
// alone (a header; no pixels; ground and elevation are left NaN), and
// place_on_ground() does check 4 and sets ground/elevation from `dem`'s
// elevations, where `point.col/row` are already in `dem`'s grid (shift a
// located point by a window's integer corner: the shift is exact in floating
// point, so a window read gives bit-identical geometry to a full read).
// `source` is the file named in messages.
Result<GridPoint> locate_point(const terrain::Georeference& georef, int width, int height, const PointSpec& spec,
                               const char* what, const std::string& source);
// `col_offset`/`row_offset`: where `dem`'s cell (0, 0) lies in the raster the
// caller names, so a message gives the cell in the user's grid.
Result<GridPoint> place_on_ground(const terrain::Dem& dem, GridPoint point, const PointSpec& spec, const char* what,
                                  int col_offset = 0, int row_offset = 0);

// The cells whose centres may lie within `radius_metres` of a located point
// (the bounding box of that ground disc, metric cell sizes taken at the point
// as visibility::make_view_frame takes them), grown by `margin` cells and
// clipped to width x height; always holds the cell nearest the point. With an
// infinite radius: the whole raster. Used to read only what a bounded viewshed
// needs.
terrain::Window cells_within(const terrain::Georeference& georef, int width, int height, const GridPoint& point,
                             double radius_metres, int margin);

}  // namespace horizon::geodesy
