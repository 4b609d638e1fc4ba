// Tests for mesh/mesh_model.hpp: a model of a DEM places viewpoints as
// geodesy::resolve_point does and maps them into the frame it was prepared
// in (the tangent plane of a geographic DEM); a model of a mesh file stands
// a height on its own surface and refuses what it cannot place; boxes are
// registered in the source's CRS; the bytes it reports cover what it holds.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "horizon/mesh/cull.hpp"
#include "horizon/mesh/mesh_model.hpp"
#include "horizon/terrain/dem_reader.hpp"
#include "test_support.hpp"

namespace horizon::mesh {
namespace {

MeshModelOptions small(std::uint32_t vertices) {
  MeshModelOptions o;
  o.greedy.max_vertices = vertices;
  o.prepare.crystals.seeds = 60;
  return o;
}

TEST(MeshModel, ADemsViewpointIsResolvedAndMappedIntoItsFrame) {
  auto dem = terrain::read_dem(testing::bundled_dem("rainier_summit_srtm3_400x400.tif"));  // geographic
  ASSERT_TRUE(dem.ok());
  geodesy::PointSpec spec;
  spec.frame = geodesy::PointFrame::kWgs84;
  spec.x = -121.76, spec.y = 46.85, spec.height = 10;
  auto reference = geodesy::resolve_point(*dem, spec, "observer");
  ASSERT_TRUE(reference.ok());
  auto model = MeshModel::from_dem(std::move(*dem), small(2000));
  ASSERT_TRUE(model.ok()) << model.error().message;
  EXPECT_TRUE(model->frame().geographic());
  ASSERT_NE(model->dem(), nullptr);
  ASSERT_TRUE(model->fit().has_value());
  EXPECT_EQ(model->prepared().tin.vertices.size(), 2000u);
  EXPECT_EQ(model->crs_vertices().size(), 2000u);
  // The CRS vertices are the DEM's cell centres (degrees), the prepared ones metres.
  EXPECT_LT(std::abs(model->crs_vertices()[0].x), 180.0);
  EXPECT_EQ(model->crs_vertices()[0].z, model->prepared().tin.vertices[0].z);

  auto eye = model->eye(spec);
  ASSERT_TRUE(eye.ok()) << eye.error().message;
  EXPECT_EQ(eye->crs.x, reference->x);
  EXPECT_EQ(eye->crs.y, reference->y);
  EXPECT_EQ(eye->crs.z, reference->elevation);
  EXPECT_EQ(eye->ground, reference->ground);
  const TinVertex local = model->frame().to_local(eye->crs);
  EXPECT_EQ(eye->local.x, local.x);
  EXPECT_EQ(eye->local.y, local.y);
  EXPECT_EQ(eye->local.z, reference->elevation);

  spec.x = 10;  // far off the DEM
  auto off = model->eye(spec);
  ASSERT_FALSE(off.ok());
  EXPECT_EQ(off.error().code, ErrorCode::kOutOfRange);

  // A box around the eye, in degrees: registered in the frame; it can be seen from the eye.
  visibility::BoxSpec box;
  box.x_min = -121.7605, box.x_max = -121.7595, box.y_min = 46.8495, box.y_max = 46.8505;
  box.z_min = reference->ground, box.z_max = reference->ground + 20;
  ASSERT_TRUE(model->register_boxes({&box, 1}).ok());
  ASSERT_NE(model->boxes(), nullptr);
  EXPECT_FALSE(model->boxes()->hidden(model->prepared(), 0, eye->local));
  std::uint64_t floor = memory_bytes(model->prepared()) + 400ull * 400ull * sizeof(float);
  EXPECT_GT(model->memory_bytes(), floor);

  box.frame = geodesy::PointFrame::kWgs84;
  const Status refused = model->register_boxes({&box, 1});
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().field, "boxes");
}

TEST(MeshModel, AMeshFilesViewpointStandsOnItsSurface) {
  testing::TempDir dir;
  const std::string path = dir.file("slope.obj");
  {
    // A plane z = x / 10 over 100 m x 100 m, 11 x 11 vertices.
    std::ofstream out(path);
    for (int j = 0; j <= 10; ++j)
      for (int i = 0; i <= 10; ++i) out << "v " << i * 10 << ' ' << j * 10 << ' ' << i << '\n';
    for (int j = 0; j < 10; ++j)
      for (int i = 0; i < 10; ++i) {
        const int a = j * 11 + i + 1;
        out << "f " << a << ' ' << a + 1 << ' ' << a + 12 << "\nf " << a << ' ' << a + 12 << ' ' << a + 11 << '\n';
      }
  }
  auto model = MeshModel::from_file(path, small(0));
  ASSERT_TRUE(model.ok()) << model.error().message;
  EXPECT_EQ(model->dem(), nullptr);
  EXPECT_FALSE(model->fit().has_value());
  geodesy::PointSpec spec;
  spec.x = 35, spec.y = 50, spec.height = 2;
  auto eye = model->eye(spec);
  ASSERT_TRUE(eye.ok()) << eye.error().message;
  EXPECT_NEAR(eye->ground, 3.5, 1e-12);
  EXPECT_NEAR(eye->local.z, 5.5, 1e-12);
  EXPECT_EQ(eye->local.x, 35.0);

  spec.height_mode = geodesy::HeightMode::kAbsolute;
  spec.height = 100;
  eye = model->eye(spec);
  ASSERT_TRUE(eye.ok());
  EXPECT_EQ(eye->local.z, 100.0);
  // From 100 m over a plane nothing is hidden.
  auto answer = cull(model->prepared(), {eye->local, {}, {}, CullMode::kApproximate});
  ASSERT_TRUE(answer.ok());
  EXPECT_EQ(answer->triangles_culled, 0u);

  spec.x = 500;  // off the mesh: an altitude still places it, a height above ground cannot
  EXPECT_TRUE(model->eye(spec).ok());
  spec.height_mode = geodesy::HeightMode::kAboveGround;
  auto off = model->eye(spec, "camera");
  ASSERT_FALSE(off.ok());
  EXPECT_EQ(off.error().code, ErrorCode::kOutOfRange);
  EXPECT_EQ(off.error().field, "camera");
  spec.frame = geodesy::PointFrame::kWgs84;
  auto wgs = model->eye(spec);
  ASSERT_FALSE(wgs.ok());
  EXPECT_EQ(wgs.error().code, ErrorCode::kInvalidArgument);
}

}  // namespace
}  // namespace horizon::mesh
