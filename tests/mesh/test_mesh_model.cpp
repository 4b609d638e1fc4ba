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

  // A box in the crop's lowest valley, in WGS 84 (the DEM's CRS is
  // geographic too) and in the CRS: the same answer from eyes all over it,
  // hidden from some. One off the DEM is refused naming it.
  const terrain::Dem& d = *model->dem();
  int low_c = 0, low_r = 0;
  for (int r = 0; r < d.height(); ++r)
    for (int c = 0; c < d.width(); ++c)
      if (std::isfinite(d.elevation.at(c, r)) &&
          (!std::isfinite(d.elevation.at(low_c, low_r)) || d.elevation.at(c, r) < d.elevation.at(low_c, low_r)))
        low_c = c, low_r = r;
  const terrain::GeoTransform& t = d.georef.transform;
  const double lon = t.origin_x + (low_c + 0.5) * t.pixel_width, lat = t.origin_y + (low_r + 0.5) * t.pixel_height;
  visibility::BoxSpec valley{geodesy::PointFrame::kDatasetCrs,
                             lon - 0.0004,
                             lat - 0.0004,
                             lon + 0.0004,
                             lat + 0.0004,
                             d.elevation.at(low_c, low_r),
                             d.elevation.at(low_c, low_r) + 5.0};
  std::vector<visibility::BoxSpec> both = {valley, valley};
  both[1].frame = geodesy::PointFrame::kWgs84;
  ASSERT_TRUE(model->register_boxes(both).ok());
  int hidden = 0, eyes = 0;
  for (double x = -121.92; x < -121.60; x += 0.02)
    for (double y = 46.67; y < 47.0; y += 0.02) {
      spec.x = x, spec.y = y, spec.height = 2;
      auto from = model->eye(spec);
      if (!from.ok()) continue;  // on a void
      const bool h = model->boxes()->hidden(model->prepared(), 1, from->local);
      EXPECT_EQ(model->boxes()->hidden(model->prepared(), 0, from->local), h);
      hidden += h ? 1 : 0;
      ++eyes;
    }
  EXPECT_GT(hidden, 0);  // the comparison is not between answers that are all "seen"
  EXPECT_GT(eyes, 200);
  both[1].x_min = 10, both[1].x_max = 11;
  const Status refused = model->register_boxes(both);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().field, "boxes");
  EXPECT_NE(refused.error().message.find("box 1"), std::string::npos) << refused.error().message;
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
  visibility::BoxSpec box{geodesy::PointFrame::kWgs84, 1, 1, 2, 2, 0, 1};
  const Status refused = model->register_boxes({&box, 1});
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().field, "boxes");
}

// The hook a server reserves memory in sees the TIN before any preparing,
// and its refusal stops the model there; the bound grows with the knobs
// and the threads that cost memory.
TEST(MeshModel, BeforePrepareSeesTheTinAndMayRefuse) {
  auto dem = terrain::read_dem(testing::bundled_dem("ecuador_andes_utm17s_10m_383x415.tif"));
  ASSERT_TRUE(dem.ok());
  MeshModelOptions options = small(1500);
  std::size_t seen = 0;
  options.before_prepare = [&](const Tin& tin) {
    seen = tin.vertices.size();
    return Status(make_error(ErrorCode::kResourceExhausted, "no room", "budget"));
  };
  auto refused = MeshModel::from_dem(*dem, options);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().code, ErrorCode::kResourceExhausted);
  EXPECT_EQ(refused.error().field, "budget");
  EXPECT_EQ(seen, 1500u);

  options.before_prepare = [&](const Tin&) { return Status::Ok(); };
  auto model = MeshModel::from_dem(*dem, options);
  ASSERT_TRUE(model.ok()) << model.error().message;
  const std::uint64_t bound = preparation_bytes(1500, options.prepare, 2);
  EXPECT_GT(bound, model->memory_bytes());  // the peak holds at least what is kept
  PrepareOptions wider = options.prepare;
  wider.horizons.sectors = 32;
  EXPECT_GT(preparation_bytes(1500, wider, 2), bound);
  EXPECT_GT(preparation_bytes(1500, options.prepare, 4), bound);
  // Linear in the vertices beyond the groups' part.
  EXPECT_EQ(preparation_bytes(3000, options.prepare, 2) - bound, bound - preparation_bytes(0, options.prepare, 2));
}

}  // namespace
}  // namespace horizon::mesh
