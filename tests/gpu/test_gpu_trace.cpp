// The GL form of the camera trace (core/src/trace/trace_gl.cpp) against the
// CPU form on the same frames: the paper's line strips, pair-level passes
// and trace pass on llvmpipe (or whatever device EGL gives).
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

#include "horizon/gpu/context_pool.hpp"
#include "horizon/terrain/dem_reader.hpp"
#include "horizon/trace/trace.hpp"
#include "test_support.hpp"

namespace horizon::trace {
namespace {

gpu::ContextPool& pool() {
  static auto created = gpu::ContextPool::create({.contexts = 1});
  if (!created.ok()) ADD_FAILURE() << created.error().message;
  return **created;
}

Camera camera_over(const terrain::Dem& dem, double col, double row, double above, double yaw, double pitch, double hfov,
                   int width, int height, Projection projection = Projection::kPerspective) {
  CameraSpec spec;
  spec.position.x = dem.georef.transform.x_at(col);
  spec.position.y = dem.georef.transform.y_at(row);
  spec.position.height = above;
  spec.yaw = yaw;
  spec.pitch = pitch;
  spec.hfov = hfov;
  spec.width = width;
  spec.height = height;
  spec.projection = projection;
  auto camera = resolve_camera(dem, spec);
  EXPECT_TRUE(camera.ok()) << (camera.ok() ? "" : camera.error().message);
  return *camera;
}

struct Agreement {
  std::uint64_t pixels = 0, same_sky = 0, same_line = 0, close = 0;
};

Agreement compare(const TraceImage& gl, const TraceImage& cpu) {
  Agreement a;
  for (std::size_t i = 0; i < cpu.distance.size(); ++i) {
    ++a.pixels;
    a.same_sky += std::isinf(gl.distance[i]) == std::isinf(cpu.distance[i]);
    if (gl.line[i] == cpu.line[i] && gl.axis[i] == cpu.axis[i]) {
      ++a.same_line;
      a.close += cpu.line[i] < 0 || std::abs(gl.distance[i] - cpu.distance[i]) <= 1e-3 * cpu.distance[i] + 1e-3;
    }
  }
  return a;
}

void expect_agrees(const terrain::Dem& dem, const Camera& camera, const TraceOptions& options,
                   const std::string& what) {
  auto lease = pool().borrow();
  ASSERT_TRUE(lease.ok());
  const terrain::HeightView view(dem.elevation);
  auto gl = trace_frame(view, camera, options, nullptr, &*lease);
  ASSERT_TRUE(gl.ok()) << gl.error().message;
  EXPECT_EQ(gl->stats.backend, "gpu") << what << ": " << gl->stats.gpu_fallback;
  auto cpu = trace_frame(view, camera, options);
  ASSERT_TRUE(cpu.ok());
  EXPECT_EQ(gl->stats.crossings, cpu->stats.crossings) << what;
  EXPECT_EQ(gl->stats.reads_per_pixel, cpu->stats.reads_per_pixel) << what;
  const Agreement a = compare(gl->image, cpu->image);
  // The stated tolerance on any device: a ray that grazes a crossing may
  // stop one line apart where a device's float arithmetic differs from the
  // CPU's (a division done as a reciprocal, say); every other pixel is the
  // CPU's answer to 1e-3 of its distance.
  EXPECT_GE(a.same_sky, a.pixels - a.pixels / 500) << what;
  EXPECT_GE(a.same_line, a.pixels - a.pixels / 100) << what;
  EXPECT_EQ(a.close, a.same_line) << what;
  // On Mesa's llvmpipe (IEEE float, `precise` honoured) the shaders do the
  // CPU's operations in its order: every pixel is the CPU's, bit for bit.
  if (lease->device().software) {
    std::size_t same = 0;
    for (std::size_t i = 0; i < cpu->image.distance.size(); ++i)
      same += std::memcmp(&gl->image.distance[i], &cpu->image.distance[i], sizeof(float)) == 0 &&
              gl->image.line[i] == cpu->image.line[i] && gl->image.axis[i] == cpu->image.axis[i];
    EXPECT_EQ(same, cpu->image.distance.size()) << what;
  }
}

TEST(TraceGl, TracesAsTheCpuDoesOnRandomTerrain) {
  terrain::Dem rough = horizon::testing::make_random_terrain(230, 190, 17, 400.0, 30.0);
  rough.georef.transform = {500000.0, 30.0, 5000000.0, -30.0};
  TraceOptions options;
  options.near = 10.0;
  for (double yaw : {0.0, 37.0, 100.0, 200.0, 290.0})
    expect_agrees(rough, camera_over(rough, 110.3, 95.6, 40.0, yaw, -5.0, 120.0, 97, 61), options,
                  "yaw " + std::to_string(yaw));
}

TEST(TraceGl, TracesAsTheCpuDoesOnARealDemWithVoids) {
  auto dem = terrain::read_dem(horizon::testing::bundled_dem("rainier_summit_srtm3_400x400.tif"));
  ASSERT_TRUE(dem.ok());
  TraceOptions options;
  expect_agrees(*dem, camera_over(*dem, 50.0, 350.0, 800.0, 40.0, -3.0, 60.0, 160, 90), options, "transparent voids");
  options.nodata = visibility::NodataPolicy::kFill;
  options.nodata_fill_height = 2000.0;
  expect_agrees(*dem, camera_over(*dem, 50.0, 350.0, 800.0, 40.0, -3.0, 60.0, 160, 90), options, "filled voids");
}

TEST(TraceGl, WhatTheGlFormDoesNotDoIsTracedOnTheCpuAndSaysWhy) {
  terrain::Dem rough = horizon::testing::make_random_terrain(120, 120, 2, 300.0, 30.0);
  auto lease = pool().borrow();
  ASSERT_TRUE(lease.ok());
  const terrain::HeightView view(rough.elevation);
  TraceOptions options;
  const Camera panorama = camera_over(rough, 60, 60, 20, 0, 0, 360, 90, 20, Projection::kCylindrical);
  auto r = trace_frame(view, panorama, options, nullptr, &*lease);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r->stats.backend, "cpu");
  EXPECT_NE(r->stats.gpu_fallback.find("cylindrical"), std::string::npos) << r->stats.gpu_fallback;
  EXPECT_EQ(r->image.line, trace_frame(view, panorama, options)->image.line);
  options.column_crossings = true;
  const Camera pinhole = camera_over(rough, 60, 60, 20, 0, 0, 60, 40, 20);
  r = trace_frame(view, pinhole, options, nullptr, &*lease);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r->stats.backend, "cpu");
  EXPECT_NE(r->stats.gpu_fallback.find("columns"), std::string::npos) << r->stats.gpu_fallback;
  EXPECT_FALSE(lease->failed());
}

}  // namespace
}  // namespace horizon::trace
