// RegionVisibility through a real horizond: box verdicts and the cells
// raster equal what the embedded engine gives on the same DEM, the raster is
// georeferenced in the dataset's grid, and every wrong field, and every
// window over the limits, is refused naming it before any work.
#include <gtest/gtest.h>

#include <random>
#include <string>
#include <vector>

#include "daemon_process.hpp"
#include "horizon/region/region.hpp"
#include "horizon/terrain/dem_reader.hpp"
#include "rpc_helpers.hpp"

namespace horizon::testing {
namespace {

// Ecuador (UTM 17S, 10 m cells, 383 x 415 = 158 945 cells).
constexpr double kX = 713877, kY = 9558936;

v1::Region region_around(double x, double y, double half, double z_min, double z_max) {
  v1::Region r;
  r.set_x_min(x - half);
  r.set_x_max(x + half);
  r.set_y_min(y - half);
  r.set_y_max(y + half);
  r.set_z_min(z_min);
  r.set_z_max(z_max);
  return r;
}

region::RegionSpec to_spec(const v1::Region& r) {
  region::RegionSpec s;
  s.x_min = r.x_min();
  s.x_max = r.x_max();
  s.y_min = r.y_min();
  s.y_max = r.y_max();
  s.z_min = r.z_min();
  s.z_max = r.z_max();
  return s;
}

class ServerRegion : public ::testing::Test {
 protected:
  void SetUp() override {
    DaemonOptions o;
    o.datasets = {{"ecuador", "ecuador_andes_utm17s_10m_383x415.tif"}};
    // The whole raster is over max_cells; a few hundred metres around the region is not.
    o.extra_json = R"("limits": {"max_boxes": 500, "max_cells": 100000}, "engine_threads": 1,)";
    daemon_ = std::make_unique<DaemonProcess>(o);
    ASSERT_TRUE(daemon_->ready()) << daemon_->error();
    visibility_ = v1::VisibilityService::NewStub(daemon_->channel());
    auto dem = terrain::read_dem(bundled_dem("ecuador_andes_utm17s_10m_383x415.tif"));
    ASSERT_TRUE(dem.ok()) << dem.error().message;
    dem_ = std::move(*dem);
  }

  grpc::Status call(const v1::RegionVisibilityRequest& request, v1::RegionVisibilityResponse& response) {
    return visibility_->RegionVisibility(context_with_deadline().get(), request, &response);
  }

  // Boxes on the ground within `reach` metres of (kX, kY), ids 500 + i.
  std::vector<visibility::BoxSpec> boxes(int count, double reach) const {
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> u(-1, 1), h(2, 25);
    const auto& t = dem_.georef.transform;
    std::vector<visibility::BoxSpec> out;
    for (int i = 0; i < count; ++i) {
      visibility::BoxSpec b;
      b.x_min = kX + reach * u(rng);
      b.x_max = b.x_min + 12;
      b.y_min = kY + reach * u(rng);
      b.y_max = b.y_min + 12;
      const int col = static_cast<int>((b.x_min - t.origin_x) / t.pixel_width);
      const int row = static_cast<int>((b.y_min - t.origin_y) / t.pixel_height);
      b.z_min = dem_.elevation.at(col, row);
      b.z_max = b.z_min + h(rng);
      out.push_back(b);
    }
    return out;
  }

  std::unique_ptr<DaemonProcess> daemon_;
  std::unique_ptr<v1::VisibilityService::Stub> visibility_;
  terrain::Dem dem_;
};

TEST_F(ServerRegion, BoxVerdictsEqualTheEngineInOrderWithTheirIds) {
  const std::vector<visibility::BoxSpec> spec = boxes(300, 1200);
  v1::RegionVisibilityRequest request;
  request.set_dataset("ecuador");
  *request.mutable_region() = region_around(kX, kY, 10, 30, 30);  // a drone's box
  for (std::size_t i = 0; i < spec.size(); ++i) {
    v1::Box* b = request.add_boxes();
    b->set_x_min(spec[i].x_min);
    b->set_x_max(spec[i].x_max);
    b->set_y_min(spec[i].y_min);
    b->set_y_max(spec[i].y_max);
    b->set_z_min(spec[i].z_min);
    b->set_z_max(spec[i].z_max);
    b->set_id(500 + i);
  }
  v1::RegionVisibilityResponse response;
  const grpc::Status s = call(request, response);
  ASSERT_TRUE(s.ok()) << s.error_message();

  region::RegionOptions options;
  options.threads = 1;
  auto want = region::classify_boxes(dem_, to_spec(request.region()), spec, options);
  ASSERT_TRUE(want.ok()) << want.error().message;
  ASSERT_EQ(response.boxes_size(), static_cast<int>(spec.size()));
  const v1::RegionVerdict as_proto[] = {v1::REGION_VERDICT_ALWAYS_HIDDEN, v1::REGION_VERDICT_ALWAYS_VISIBLE,
                                        v1::REGION_VERDICT_UNDETERMINED};
  for (int i = 0; i < response.boxes_size(); ++i) {
    EXPECT_EQ(response.boxes(i).id(), 500u + static_cast<unsigned>(i));
    EXPECT_EQ(response.boxes(i).verdict(), as_proto[static_cast<int>(want->verdicts[static_cast<std::size_t>(i)])])
        << "box " << i;
  }
  const v1::RegionStats& st = response.stats();
  EXPECT_EQ(st.items(), 300u);
  EXPECT_EQ(st.always_hidden(), want->stats.always_hidden);
  EXPECT_EQ(st.always_visible(), want->stats.always_visible);
  EXPECT_EQ(st.undetermined(), want->stats.undetermined);
  EXPECT_GT(st.always_hidden(), 0u);
  EXPECT_GT(st.always_visible(), 0u) << st.always_hidden() << " hidden, " << st.undetermined() << " undetermined";
  // The window read bounds the region and the boxes (2.4 km square), not the whole raster.
  const v1::Window& w = response.window();
  EXPECT_LT(static_cast<std::int64_t>(w.col1() - w.col0()) * (w.row1() - w.row0()), 70000);
  EXPECT_GT(w.col1() - w.col0(), 230);
}

TEST_F(ServerRegion, TheCellsRasterEqualsTheEngineAndIsGeoreferenced) {
  v1::RegionVisibilityRequest request;
  request.set_dataset("ecuador");
  *request.mutable_region() = region_around(kX, kY, 30, 2, 10);
  request.set_cells(true);
  request.set_max_distance(600);
  request.set_target_height(1.5);
  v1::RegionVisibilityResponse response;
  const grpc::Status s = call(request, response);
  ASSERT_TRUE(s.ok()) << s.error_message();

  region::RegionOptions options;
  options.threads = 1;
  options.max_distance = 600;
  options.target_height = 1.5;
  auto want = region::classify_cells(dem_, to_spec(request.region()), options);
  ASSERT_TRUE(want.ok()) << want.error().message;
  const v1::Window& w = response.window();
  const int width = w.col1() - w.col0(), height = w.row1() - w.row0();
  ASSERT_EQ(response.codes().size(), static_cast<std::size_t>(width) * static_cast<std::size_t>(height));
  // Georeferenced at the window's corner in the dataset's grid.
  const auto& t = dem_.georef.transform;
  EXPECT_DOUBLE_EQ(response.transform().origin_x(), t.origin_x + w.col0() * t.pixel_width);
  EXPECT_DOUBLE_EQ(response.transform().origin_y(), t.origin_y + w.row0() * t.pixel_height);
  EXPECT_DOUBLE_EQ(response.transform().pixel_width(), t.pixel_width);

  int answered = 0, hidden = 0;
  for (int r = 0; r < height; ++r)
    for (int c = 0; c < width; ++c) {
      const int col = w.col0() + c, row = w.row0() + r;
      const terrain::Window& ww = want->window;
      const bool inside = col >= ww.col0 && col < ww.col1 && row >= ww.row0 && row < ww.row1;
      const std::uint8_t expect = inside ? want->codes.at(col - ww.col0, row - ww.row0) : region::kNoAnswer;
      const auto got = static_cast<std::uint8_t>(response.codes()[static_cast<std::size_t>(r) * width + c]);
      ASSERT_EQ(got, expect) << "cell " << col << "," << row;
      answered += got != region::kNoAnswer;
      hidden += got == 0;
    }
  EXPECT_GT(answered, 8000);  // about pi 60^2 cells
  EXPECT_GT(hidden, 0);
  EXPECT_EQ(response.stats().items(), want->stats.items);
}

TEST_F(ServerRegion, WrongFieldsAndOversizedWindowsAreRefusedNamingThem) {
  const auto refused = [&](const v1::RegionVisibilityRequest& request, grpc::StatusCode code,
                           const std::string& field) {
    v1::RegionVisibilityResponse response;
    const grpc::Status s = call(request, response);
    EXPECT_EQ(s.error_code(), code) << field << ": " << s.error_message();
    EXPECT_EQ(violated_field(s), field) << s.error_message();
    EXPECT_NE(s.error_message().find(field), std::string::npos) << s.error_message();
    EXPECT_EQ(response.boxes_size(), 0);
    return s.error_message();
  };
  v1::RegionVisibilityRequest base;
  base.set_dataset("ecuador");
  *base.mutable_region() = region_around(kX, kY, 30, 2, 10);
  base.set_cells(true);
  base.set_max_distance(300);

  v1::RegionVisibilityRequest r = base;
  r.clear_region();
  refused(r, grpc::StatusCode::INVALID_ARGUMENT, "region");

  r = base;
  *r.mutable_region() = region_around(kX + 1e6, kY, 30, 2, 10);
  refused(r, grpc::StatusCode::OUT_OF_RANGE, "region");

  r = base;
  r.mutable_region()->set_z_min(20);  // above z_max
  EXPECT_EQ(refused(r, grpc::StatusCode::INVALID_ARGUMENT, "region.z_max").empty(), false);

  r = base;
  r.set_face_resolution(4);
  refused(r, grpc::StatusCode::INVALID_ARGUMENT, "face_resolution");

  r = base;
  r.set_footprint_splits(17);
  refused(r, grpc::StatusCode::INVALID_ARGUMENT, "footprint_splits");

  r = base;
  r.set_cells(false);
  refused(r, grpc::StatusCode::INVALID_ARGUMENT, "max_distance");  // distance is for cells

  r = base;
  r.set_cells(false);
  r.clear_max_distance();
  refused(r, grpc::StatusCode::INVALID_ARGUMENT, "boxes");  // nothing to classify

  r = base;
  v1::Box* far = r.add_boxes();
  far->set_x_min(kX);
  far->set_x_max(kX + 10);
  far->set_y_min(kY);
  far->set_y_max(kY + 10);
  refused(r, grpc::StatusCode::INVALID_ARGUMENT, "cells");  // boxes and cells both

  r.set_cells(false);
  r.clear_max_distance();
  far->set_x_min(kX + 1e6);
  far->set_x_max(kX + 1e6 + 10);
  refused(r, grpc::StatusCode::OUT_OF_RANGE, "boxes[0]");

  // The whole raster (158 945 cells) is over max_cells = 100 000: refused
  // from the header, naming what to shrink.
  r = base;
  r.clear_max_distance();
  const std::string message = refused(r, grpc::StatusCode::RESOURCE_EXHAUSTED, "max_distance");
  EXPECT_NE(message.find("158945"), std::string::npos) << message;
  EXPECT_NE(message.find("100000"), std::string::npos) << message;

  // Boxes at opposite corners span the raster too.
  r = base;
  r.set_cells(false);
  r.clear_max_distance();
  const auto& t = dem_.georef.transform;
  for (const auto& [col, row] : {std::pair{2, 2}, std::pair{dem_.width() - 3, dem_.height() - 3}}) {
    v1::Box* b = r.add_boxes();
    b->set_x_min(t.origin_x + col * t.pixel_width);
    b->set_x_max(b->x_min() + 5);
    b->set_y_max(t.origin_y + row * t.pixel_height);
    b->set_y_min(b->y_max() - 5);
    b->set_z_max(5000);
  }
  refused(r, grpc::StatusCode::RESOURCE_EXHAUSTED, "boxes");

  // More boxes than limits.max_boxes.
  r = base;
  r.set_cells(false);
  r.clear_max_distance();
  for (int i = 0; i < 501; ++i) {
    v1::Box* b = r.add_boxes();
    b->set_x_min(kX);
    b->set_x_max(kX + 5);
    b->set_y_min(kY);
    b->set_y_max(kY + 5);
  }
  refused(r, grpc::StatusCode::RESOURCE_EXHAUSTED, "boxes");
}

}  // namespace
}  // namespace horizon::testing
