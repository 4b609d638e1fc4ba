// ComputeViewshed with many observers through a real horizond: the streamed
// count raster equals the embedded engine's on the same DEM, cell for cell,
// in the same place; the any/all rasters and the per-observer summary agree
// with it; the GeoTIFF carries the counts; and every wrong site, and every
// union window over the limits, is refused naming it before any work.
#include <gtest/gtest.h>

#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "daemon_process.hpp"
#include "horizon/terrain/dem_reader.hpp"
#include "horizon/visibility/many_observers.hpp"
#include "horizon/visibility/viewshed.hpp"
#include "rpc_helpers.hpp"

namespace horizon::testing {
namespace {

// Ecuador (UTM 17S, 10 m cells, 383 x 415 = 158 945 cells): three towers
// 540 m to 1.1 km apart.
constexpr double kSites[][2] = {{713877, 9558936}, {714300, 9558500}, {713500, 9559300}};
constexpr double kReach = 900;

class ServerMany : public ::testing::Test {
 protected:
  void SetUp() override {
    DaemonOptions o;
    o.datasets = {{"ecuador", "ecuador_andes_utm17s_10m_383x415.tif"},
                  {"everest", "everest_summit_voids_srtm3_300x300.tif"}};
    // The whole raster is over max_cells; the towers' windows are not.
    o.extra_json = R"("limits": {"max_observers": 5, "max_cells": 100000}, "engine_threads": 2,)";
    daemon_ = std::make_unique<DaemonProcess>(o);
    ASSERT_TRUE(daemon_->ready()) << daemon_->error();
    visibility_ = v1::VisibilityService::NewStub(daemon_->channel());
    auto dem = terrain::read_dem(bundled_dem("ecuador_andes_utm17s_10m_383x415.tif"));
    ASSERT_TRUE(dem.ok()) << dem.error().message;
    dem_ = std::move(*dem);
  }

  v1::ViewshedRequest towers() const {
    v1::ViewshedRequest r;
    r.set_dataset("ecuador");
    for (const auto& [x, y] : kSites) {
      v1::ObserverSite* s = r.add_observers();
      *s->mutable_point() = point(x, y, 10);
      s->set_max_distance(kReach);
    }
    r.mutable_options()->set_target_height(2);
    return r;
  }

  // The embedded engine on the whole DEM, the same sites and options.
  visibility::ManyObserversResult embedded() const {
    std::vector<visibility::ObserverSite> sites;
    for (const auto& [x, y] : kSites)
      sites.push_back({.point = {geodesy::PointFrame::kDatasetCrs, x, y, 10, geodesy::HeightMode::kAboveGround},
                       .max_distance = kReach});
    visibility::ManyObserversOptions options;
    options.viewshed.target_height = 2;
    options.threads = 1;
    auto plan = visibility::plan_many_observers(dem_, sites, options);
    EXPECT_TRUE(plan.ok()) << plan.error().message;
    auto res = visibility::compute_many_observers(dem_, *plan);
    EXPECT_TRUE(res.ok()) << res.error().message;
    return std::move(*res);
  }

  grpc::Status run(const v1::ViewshedRequest& request, std::vector<v1::ViewshedResponse>* out = nullptr) {
    auto context = context_with_deadline();
    auto reader = visibility_->ComputeViewshed(context.get(), request);
    v1::ViewshedResponse message;
    while (reader->Read(&message))
      if (out) out->push_back(message);
    return reader->Finish();
  }

  static std::string raster_of(const std::vector<v1::ViewshedResponse>& messages) {
    std::string raster;
    for (const auto& m : messages)
      if (m.has_raster_chunk()) raster += m.raster_chunk().data();
    return raster;
  }

  std::unique_ptr<DaemonProcess> daemon_;
  std::unique_ptr<v1::VisibilityService::Stub> visibility_;
  terrain::Dem dem_;
};

TEST_F(ServerMany, TheCountRasterEqualsTheEngineCellForCellInTheSamePlace) {
  v1::ViewshedRequest request = towers();
  request.set_include_raster(true);
  request.set_include_geotiff(true);
  request.set_max_chunk_bytes(4096);
  std::vector<v1::ViewshedResponse> messages;
  const grpc::Status s = run(request, &messages);
  ASSERT_TRUE(s.ok()) << s.error_message();
  ASSERT_TRUE(messages.front().has_header());
  ASSERT_TRUE(messages.back().has_summary());
  const v1::ViewshedHeader& h = messages.front().header();
  EXPECT_EQ(h.sample_type(), v1::SAMPLE_TYPE_UINT32);
  EXPECT_EQ(h.nodata(), double{visibility::kNoCount});

  const visibility::ManyObserversResult want = embedded();
  const auto count = visibility::observer_count(want);
  ASSERT_EQ(h.width(), count.width());
  ASSERT_EQ(h.height(), count.height());
  EXPECT_EQ(h.window().col0(), want.window.col0);
  EXPECT_EQ(h.window().row0(), want.window.row0);
  const auto& t = dem_.georef.transform;
  EXPECT_DOUBLE_EQ(h.transform().origin_x(), t.origin_x + want.window.col0 * t.pixel_width);
  EXPECT_DOUBLE_EQ(h.transform().origin_y(), t.origin_y + want.window.row0 * t.pixel_height);
  const std::string raster = raster_of(messages);
  ASSERT_EQ(raster.size(), count.size() * sizeof(std::uint32_t));
  std::vector<std::uint32_t> got(count.size());
  std::memcpy(got.data(), raster.data(), raster.size());
  std::uint64_t by_two = 0, by_three = 0, none = 0;
  for (std::size_t i = 0; i < got.size(); ++i) {
    ASSERT_EQ(got[i], count.values()[i]) << "cell " << i % count.width() << "," << i / count.width();
    by_two += got[i] == 2;
    by_three += got[i] == 3;
    none += got[i] == visibility::kNoCount;
  }
  // The reaches overlap and the corners of the union are beyond every reach.
  EXPECT_GT(by_two, 0u);
  EXPECT_GT(by_three, 0u);
  EXPECT_GT(none, 0u);

  // The summary: seen by any / by all / each observer's own figures.
  const v1::ViewshedSummary& sum = messages.back().summary();
  const auto any = visibility::seen_from_any(want);
  std::uint64_t seen = 0, hidden = 0;
  for (auto v : any.values()) {
    seen += v == visibility::kVisible;
    hidden += v == visibility::kHidden;
  }
  EXPECT_EQ(sum.visible_cells(), seen);
  EXPECT_EQ(sum.hidden_cells(), hidden);
  EXPECT_EQ(sum.seen_by_all_cells(), by_three);
  ASSERT_EQ(sum.observers_size(), 3);
  std::uint64_t sum_visible = 0;
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(sum.observers(i).visible_cells(), want.observers[static_cast<std::size_t>(i)].cells_visible);
    EXPECT_EQ(sum.observers(i).answered_cells(), want.observers[static_cast<std::size_t>(i)].cells_answered);
    EXPECT_NEAR(sum.observers(i).point().x(), kSites[i][0], 10);
    sum_visible += sum.observers(i).visible_cells();
  }
  std::uint64_t total = 0;  // the counts add up to the observers' visible cells
  for (auto v : got)
    if (v != visibility::kNoCount) total += v;
  EXPECT_EQ(total, sum_visible);

  // The GeoTIFF holds the same counts.
  std::string tiff;
  for (const auto& m : messages)
    if (m.has_file_chunk() && m.file_chunk().kind() == v1::FileChunk::KIND_GEOTIFF) tiff += m.file_chunk().data();
  ASSERT_GT(tiff.size(), 8u);
  TempDir dir;
  const std::string path = (dir.path() / "count.tif").string();
  {
    std::ofstream f(path, std::ios::binary);
    f.write(tiff.data(), static_cast<std::streamsize>(tiff.size()));
  }
  auto back = terrain::read_dem(path);
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(back->width(), count.width());
  EXPECT_DOUBLE_EQ(back->georef.transform.origin_x, h.transform().origin_x());
  EXPECT_FLOAT_EQ(back->elevation.at(want.window.width() / 2, want.window.height() / 2),
                  static_cast<float>(count.at(want.window.width() / 2, want.window.height() / 2)));
}

TEST_F(ServerMany, AnyAndAllAreTheCountThresholded) {
  v1::ViewshedRequest request = towers();
  request.set_include_raster(true);
  std::vector<v1::ViewshedResponse> count_stream;
  ASSERT_TRUE(run(request, &count_stream).ok());
  std::vector<std::uint32_t> count(raster_of(count_stream).size() / 4);
  std::memcpy(count.data(), raster_of(count_stream).data(), count.size() * 4);
  for (const auto mode : {v1::ACCUMULATION_ANY, v1::ACCUMULATION_ALL}) {
    request.set_accumulate(mode);
    std::vector<v1::ViewshedResponse> messages;
    const grpc::Status s = run(request, &messages);
    ASSERT_TRUE(s.ok()) << s.error_message();
    EXPECT_EQ(messages.front().header().sample_type(), v1::SAMPLE_TYPE_UINT8);
    const std::string mask = raster_of(messages);
    ASSERT_EQ(mask.size(), count.size());
    for (std::size_t i = 0; i < count.size(); ++i) {
      const auto got = static_cast<std::uint8_t>(mask[i]);
      if (count[i] == visibility::kNoCount) {
        ASSERT_EQ(got, visibility::kNoAnswer) << i;
      } else {
        const bool seen = mode == v1::ACCUMULATION_ANY ? count[i] > 0 : count[i] == 3;
        ASSERT_EQ(got, seen ? visibility::kVisible : visibility::kHidden) << i;
      }
    }
  }
}

TEST_F(ServerMany, WrongSitesAndOversizedWindowsAreRefusedNamingThem) {
  const auto refused = [&](const v1::ViewshedRequest& request, grpc::StatusCode code, const std::string& field) {
    std::vector<v1::ViewshedResponse> messages;
    const grpc::Status s = run(request, &messages);
    EXPECT_EQ(s.error_code(), code) << field << ": " << s.error_message();
    EXPECT_EQ(violated_field(s), field) << s.error_message();
    // The message names the field as the request does (shared options as the engine does).
    const std::string named = field.starts_with("options.") ? field.substr(8) : field;
    EXPECT_NE(s.error_message().find(named), std::string::npos) << s.error_message();
    EXPECT_TRUE(messages.empty());
    return s.error_message();
  };
  v1::ViewshedRequest r = towers();
  r.mutable_observers(1)->mutable_point()->set_x(kSites[1][0] + 1e6);
  refused(r, grpc::StatusCode::OUT_OF_RANGE, "observers[1].point");

  r = towers();
  r.mutable_observers(2)->clear_point();
  refused(r, grpc::StatusCode::INVALID_ARGUMENT, "observers[2].point");

  r = towers();
  r.mutable_observers(0)->set_max_distance(-5);
  refused(r, grpc::StatusCode::INVALID_ARGUMENT, "observers[0].max_distance");

  r = towers();
  *r.mutable_observer() = point(kSites[0][0], kSites[0][1]);
  refused(r, grpc::StatusCode::INVALID_ARGUMENT, "observer");

  r = towers();
  r.set_raster(v1::RASTER_KIND_OHF);
  refused(r, grpc::StatusCode::INVALID_ARGUMENT, "raster");

  r = towers();
  r.set_accumulate(static_cast<v1::Accumulation>(7));
  refused(r, grpc::StatusCode::INVALID_ARGUMENT, "accumulate");

  r = towers();
  r.mutable_options()->set_target_height(-1);
  refused(r, grpc::StatusCode::INVALID_ARGUMENT, "options.target_height");

  // More than limits.max_observers = 5.
  r = towers();
  for (int i = 0; i < 3; ++i) *r.add_observers() = r.observers(0);
  const std::string many = refused(r, grpc::StatusCode::RESOURCE_EXHAUSTED, "observers");
  EXPECT_NE(many.find("6 observers"), std::string::npos) << many;

  // Two towers at opposite corners: their windows' union spans the raster
  // (158 945 cells, over max_cells = 100 000), refused from the header.
  r = towers();
  r.clear_observers();
  const auto& t = dem_.georef.transform;
  for (const auto& [col, row] : {std::pair{20, 20}, std::pair{dem_.width() - 20, dem_.height() - 20}}) {
    v1::ObserverSite* s = r.add_observers();
    *s->mutable_point() = point(t.origin_x + col * t.pixel_width, t.origin_y + row * t.pixel_height, 10);
    s->set_max_distance(400);
  }
  const std::string span = refused(r, grpc::StatusCode::RESOURCE_EXHAUSTED, "observers");
  EXPECT_NE(span.find("100000"), std::string::npos) << span;

  // A site 10 m above a void (the Everest crop's cell col 237, row 150):
  // named by its cell in the dataset's grid, not in the window read for it.
  r.clear_observers();
  r.set_dataset("everest");
  for (const auto& [lon, lat] : {std::pair{86.86, 27.95}, std::pair{86.9483333333333, 27.875}}) {
    v1::ObserverSite* s = r.add_observers();
    *s->mutable_point() = point(lon, lat, 10);
    s->set_max_distance(1500);
  }
  const std::string hole = refused(r, grpc::StatusCode::FAILED_PRECONDITION, "observers[1].point");
  EXPECT_NE(hole.find("col 237.00, row 150.00"), std::string::npos) << hole;
  EXPECT_EQ(hole.find("/"), std::string::npos) << "no server path: " << hole;
}

}  // namespace
}  // namespace horizon::testing
