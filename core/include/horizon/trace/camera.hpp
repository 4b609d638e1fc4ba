// horizon/trace/camera.hpp — a camera over a DEM: where it stands, where it
// looks, and which ray each pixel is.
//
// The camera keeps vertical world lines vertical on screen (no roll), as the
// silhouette-partitioning trace needs (trace.hpp): every screen column is
// then one vertical half-plane through the eye at one azimuth, and every
// pixel of that column a ray in it, climbing `slope` metres per ground metre.
// Pitch is a shift of the principal point, not a rotation: the centre pixel
// looks `pitch` degrees up, and the image plane stays vertical (a view
// camera's "rise"), so buildings do not lean.
//
// Frames and units:
//   * yaw: the centre column's azimuth in degrees, clockwise from grid north
//     (the raster's up direction, decreasing rows; true north on north-up
//     rasters in geographic CRSs, grid north in projected ones);
//   * pixels: the image's column x (left to right) and row j (top to bottom),
//     centres at x + 0.5, j + 0.5, as image files store them;
//   * distances: metres on the ground from the eye, cell sizes taken at the
//     eye (visibility::metric_cell_size) as every viewshed does.
//
// Projections:
//   * kPerspective, a pinhole: x = cx + f tan(azimuth - yaw), so the
//     horizontal field of view is below 180 degrees (at most 170 here);
//   * kCylindrical, a panorama: x = cx + f (azimuth - yaw) in radians, up to
//     360 degrees; rows are linear in the ray's slope, like the pinhole.
// In both a pixel's ray climbs (y_up - cy) / f_col metres per ground metre,
// y_up = height - (j + 0.5) and f_col the column's distance from the eye to
// the image plane in pixels (f / cos(azimuth - yaw) for the pinhole, f for
// the panorama).
#pragma once

#include <vector>

#include "horizon/common/error.hpp"
#include "horizon/geodesy/observer.hpp"
#include "horizon/terrain/dem.hpp"

namespace horizon::trace {

enum class Projection { kPerspective, kCylindrical };

// What a user gives.
struct CameraSpec {
  geodesy::PointSpec position;    // the eye: dataset CRS or WGS84, height above ground or altitude
  double yaw = 0.0;               // degrees clockwise from grid north, any finite value
  double pitch = 0.0;             // degrees up of the centre pixel, [-80, 80]
  double hfov = 60.0;             // degrees: (0, 170] perspective, (0, 360] cylindrical
  int width = 512, height = 512;  // pixels, each [1, kMaxSide]
  Projection projection = Projection::kPerspective;
};

inline constexpr int kMaxSide = 8192;

// "perspective", "cylindrical".
const char* projection_name(Projection projection);

// The field's name, not the camera's: "yaw", "pitch", "hfov", "width",
// "height". Checks everything but the position.
Status validate_camera(const CameraSpec& spec);

// A camera resolved against a raster: the eye in its grid, and the
// per-column rays. Cheap to copy per frame (two vectors of `width`).
struct Camera {
  CameraSpec spec;
  geodesy::GridPoint eye;                             // in the raster's grid; eye.elevation is absolute metres
  double metres_per_col = 1.0, metres_per_row = 1.0;  // at the eye
  double focal = 1.0;                                 // f, pixels
  double cx = 0.0, cy = 0.0;                          // principal point, pixels from the left and from the bottom
  // Per screen column x: its azimuth in radians (clockwise from grid north,
  // not wrapped) and f_col in pixels.
  std::vector<double> azimuth;
  std::vector<double> focal_col;
  // Per screen column: the ground distance at which the near plane cuts it
  // (near / cos(azimuth - yaw) for the pinhole, near for the panorama).
  double near_distance(int x, double near) const;

  // The ray's climb, metres per ground metre, of pixel (x, j).
  double slope(int x, int j) const;
};

// Builds the per-column tables for a camera whose eye is already placed on
// `eye` (geodesy::resolve_point, or a plan's read window). Validates the
// spec (validate_camera). `metres_*` as visibility::metric_cell_size gives
// them at the eye.
Result<Camera> make_camera(const CameraSpec& spec, const geodesy::GridPoint& eye, double metres_per_col,
                           double metres_per_row);

// resolve_point + metric_cell_size + make_camera on a whole DEM.
Result<Camera> resolve_camera(const terrain::Dem& dem, const CameraSpec& spec);

}  // namespace horizon::trace
