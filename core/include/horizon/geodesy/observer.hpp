// horizon/geodesy/observer.hpp — turning a user's viewpoint into grid terms.
//
// A viewpoint is given either in the DEM's own CRS or as WGS84 lon/lat, with a
// height above the ground under it or an absolute altitude (metres, same
// vertical datum as the DEM). Resolution checks, in this order, and names the
// field that is wrong: finite numbers (x/y, lon/lat, height), the DEM has a CRS
// (for lon/lat), the point lies inside the raster's outer extent (kOutOfRange),
// and the terrain under it is not a void (kDataError, for height above ground).
#pragma once

#include "horizon/common/error.hpp"
#include "horizon/terrain/dem.hpp"

namespace horizon::geodesy {

enum class PointFrame { kDatasetCrs, kWgs84 };
enum class HeightMode { kAboveGround, kAbsolute };

struct PointSpec {
  PointFrame frame = PointFrame::kDatasetCrs;
  double x = 0.0;  // dataset CRS x, or longitude in degrees for kWgs84
  double y = 0.0;  // dataset CRS y, or latitude in degrees for kWgs84
  double height = 0.0;  // metres: above ground, or absolute altitude
  HeightMode height_mode = HeightMode::kAboveGround;
};

struct GridPoint {
  double col = 0.0, row = 0.0;   // continuous grid coordinates, cell centres at integers
  double x = 0.0, y = 0.0;       // dataset CRS coordinates
  double ground = 0.0;           // bilinear terrain height under the point, metres (NaN if on a void and absolute)
  double elevation = 0.0;        // absolute elevation of the point itself, metres
};

// `what` names the point in messages ("observer", "target", "from", "to").
Result<GridPoint> resolve_point(const terrain::Dem& dem, const PointSpec& spec, const char* what);

}  // namespace horizon::geodesy
