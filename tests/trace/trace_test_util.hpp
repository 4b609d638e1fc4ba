// Helpers for the trace tests: cameras placed directly in a DEM's grid.
#pragma once

#include <gtest/gtest.h>

#include "horizon/terrain/dem.hpp"
#include "horizon/trace/camera.hpp"

namespace horizon::trace::testing {

// A camera at grid point (col, row), `above` metres over the bilinear ground
// there, metres per cell from the DEM's transform (the synthetic DEMs have
// no CRS or a UTM one: square cells of |pixel_width| metres).
inline Camera camera_at(const terrain::Dem& dem, double col, double row, double above, CameraSpec spec) {
  geodesy::GridPoint eye;
  eye.col = col;
  eye.row = row;
  eye.ground = terrain::sample_bilinear(dem.elevation, col, row);
  eye.elevation = eye.ground + above;
  const double cell = std::abs(dem.georef.transform.pixel_width);
  auto camera = make_camera(spec, eye, cell, cell);
  EXPECT_TRUE(camera.ok()) << (camera.ok() ? "" : camera.error().message);
  return *camera;
}

inline CameraSpec spec_of(double yaw, double pitch, double hfov, int width, int height,
                          Projection projection = Projection::kPerspective) {
  CameraSpec s;
  s.yaw = yaw;
  s.pitch = pitch;
  s.hfov = hfov;
  s.width = width;
  s.height = height;
  s.projection = projection;
  return s;
}

}  // namespace horizon::trace::testing
