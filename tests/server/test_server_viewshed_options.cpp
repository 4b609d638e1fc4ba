// ComputeViewshed's field of view, refraction, observer ground, value codes,
// r.viewshed's rasters and GeoTIFF layouts through the API: each streamed
// raster equal to the engine's own for the same options, and each refusal
// naming the request's field.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "daemon_process.hpp"
#include "horizon/terrain/dem_reader.hpp"
#include "horizon/terrain/source.hpp"
#include "horizon/visibility/plan.hpp"
#include "horizon/visibility/viewshed_outputs.hpp"
#include "rpc_helpers.hpp"
#include "test_support.hpp"

namespace horizon::testing {
namespace {

const char* kAndes = "ecuador_andes_utm17s_10m_383x415.tif";
// Near the north-west corner of cell (189, 249), on a steep slope: the
// bilinear ground there is some 14 m below the cell's value.
constexpr double kX = 713853.227, kY = 9558521.26;

struct Stream {
  grpc::Status status;
  v1::ViewshedHeader header;
  v1::ViewshedSummary summary;
  std::string raster, geotiff;
};

class ServerViewshedOptions : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    data_ = new TempDir();
    std::filesystem::copy_file(bundled_dem(kAndes), data_->path() / kAndes);
  }
  static void TearDownTestSuite() {
    delete data_;
    data_ = nullptr;
  }
  static TempDir* data_;

  void SetUp() override {
    DaemonOptions o;
    o.data_root = data_->path().string();
    o.datasets = {{"andes", kAndes}};
    daemon_ = std::make_unique<DaemonProcess>(o);
    ASSERT_TRUE(daemon_->ready()) << daemon_->error();
    visibility_ = v1::VisibilityService::NewStub(daemon_->channel());
  }

  static v1::ViewshedRequest request(double max_distance = 1500) {
    v1::ViewshedRequest r;
    r.set_dataset("andes");
    *r.mutable_observer() = point(kX, kY, 5.0);
    r.mutable_options()->set_max_distance(max_distance);
    r.set_include_raster(true);
    return r;
  }

  Stream run(const v1::ViewshedRequest& r) {
    Stream s;
    auto context = context_with_deadline();
    auto reader = visibility_->ComputeViewshed(context.get(), r);
    v1::ViewshedResponse m;
    while (reader->Read(&m)) {
      if (m.has_header()) s.header = m.header();
      if (m.has_summary()) s.summary = m.summary();
      if (m.has_raster_chunk()) s.raster += m.raster_chunk().data();
      if (m.has_file_chunk()) s.geotiff += m.file_chunk().data();
    }
    s.status = reader->Finish();
    return s;
  }

  // The engine's run of the same query on the same file.
  static visibility::ViewshedRun engine(const visibility::ViewshedOptions& options,
                                        geodesy::GroundSample ground = geodesy::GroundSample::kBilinear) {
    auto source = terrain::ElevationSource::open(bundled_dem(kAndes));
    geodesy::PointSpec eye;
    eye.x = kX;
    eye.y = kY;
    eye.height = 5.0;
    eye.ground = ground;
    auto plan = visibility::plan_viewshed(**source, {eye, options});
    EXPECT_TRUE(plan.ok());
    auto run = visibility::run_viewshed(*plan, **source, nullptr);
    EXPECT_TRUE(run.ok());
    return std::move(*run);
  }

  std::unique_ptr<DaemonProcess> daemon_;
  std::unique_ptr<v1::VisibilityService::Stub> visibility_;
};

TempDir* ServerViewshedOptions::data_ = nullptr;

std::vector<float> floats(const std::string& bytes) {
  std::vector<float> v(bytes.size() / 4);
  std::memcpy(v.data(), bytes.data(), v.size() * 4);
  return v;
}

TEST_F(ServerViewshedOptions, FieldOfViewAndCodesEqualTheEngines) {
  v1::ViewshedRequest r = request();
  v1::ViewshedOptions& o = *r.mutable_options();
  o.set_azimuth_start(300);
  o.set_azimuth_end(60);
  o.set_min_distance(200);
  o.set_pitch_max(10);
  r.mutable_codes()->set_visible(7);
  r.mutable_codes()->set_hidden(3);
  r.mutable_codes()->set_out_of_range(9);
  r.set_output_nodata(200);
  const Stream s = run(r);
  ASSERT_TRUE(s.status.ok()) << s.status.error_message();
  EXPECT_DOUBLE_EQ(s.header.nodata(), 200);

  visibility::ViewshedOptions options;
  options.max_distance = 1500;
  options.field_of_view = {.azimuth_start = 300, .azimuth_end = 60, .min_distance = 200, .pitch_max = 10};
  options.visibility_only = true;
  const auto want = visibility::visibility_codes(engine(options).result, 0.0,
                                                 {.visible = 7, .hidden = 3, .out_of_range = 9, .nodata = 200});
  ASSERT_EQ(s.raster.size(), want.size());
  EXPECT_EQ(std::memcmp(s.raster.data(), want.data(), want.size()), 0);
  std::size_t n[256] = {};
  for (unsigned char c : s.raster) ++n[c];
  EXPECT_GT(n[7], 100u);
  EXPECT_GT(n[3], 100u);
  EXPECT_GT(n[9], n[7] + n[3]) << "most of the window is outside a 120-degree wedge";
  EXPECT_EQ(n[7] + n[3] + n[9] + n[200], s.raster.size());
  // The summary counts visible and hidden cells of the field of view only.
  EXPECT_EQ(s.summary.visible_cells(), n[7]);
  EXPECT_EQ(s.summary.hidden_cells(), n[3]);
}

TEST_F(ServerViewshedOptions, RViewshedRastersEqualTheEngines) {
  visibility::ViewshedOptions options;
  options.max_distance = 1500;
  options.visibility_only = true;
  const visibility::ViewshedRun run_ = engine(options);
  for (auto [kind, output] : {std::pair{v1::RASTER_KIND_VERTICAL_ANGLE, visibility::ViewshedOutput::kVerticalAngle},
                              {v1::RASTER_KIND_ELEVATION_DIFFERENCE, visibility::ViewshedOutput::kElevationDifference}}) {
    v1::ViewshedRequest r = request();
    r.set_raster(kind);
    r.set_output_nodata(-9999);
    const Stream s = run(r);
    ASSERT_TRUE(s.status.ok()) << s.status.error_message();
    EXPECT_EQ(s.header.sample_type(), v1::SAMPLE_TYPE_FLOAT32);
    EXPECT_DOUBLE_EQ(s.header.nodata(), -9999);
    const auto got = floats(s.raster);
    const auto want = visibility::float_raster(run_.result, output, 0.0);
    ASSERT_EQ(got.size(), want.size());
    for (std::size_t i = 0; i < got.size(); ++i) {
      const float w = want.values()[i];
      ASSERT_TRUE(got[i] == w || (std::isnan(got[i]) && std::isnan(w))) << i;  // the stream keeps NaN
    }
  }
  v1::ViewshedRequest b = request();
  b.set_raster(v1::RASTER_KIND_BOOLEAN);
  const Stream s = run(b);
  ASSERT_TRUE(s.status.ok()) << s.status.error_message();
  const auto want = visibility::visibility_codes(run_.result, 0.0, visibility::kBooleanCodes);
  EXPECT_EQ(s.raster, std::string(reinterpret_cast<const char*>(want.data()), want.size()));
}

TEST_F(ServerViewshedOptions, RefractionIsOneMinusCurvatureAndMaxDistanceZeroIsNoLimit) {
  v1::ViewshedRequest a = request(800), b = request(800);
  a.mutable_options()->set_refraction(0.25);
  b.mutable_options()->set_curvature(0.75);
  const Stream sa = run(a), sb = run(b);
  ASSERT_TRUE(sa.status.ok() && sb.status.ok());
  EXPECT_EQ(sa.raster, sb.raster);
  v1::ViewshedRequest whole = request(0);
  const Stream w = run(whole);
  ASSERT_TRUE(w.status.ok()) << w.status.error_message();
  EXPECT_EQ(w.header.width(), 383);
  EXPECT_EQ(w.header.height(), 415);
}

TEST_F(ServerViewshedOptions, CellGroundPutsTheEyeOnItsCellsValue) {
  v1::ViewshedRequest r = request();
  r.mutable_observer()->set_ground(v1::GROUND_SAMPLE_CELL);
  const Stream cell = run(r);
  const Stream bilinear = run(request());
  ASSERT_TRUE(cell.status.ok() && bilinear.status.ok());
  visibility::ViewshedOptions options;
  options.max_distance = 1500;
  const visibility::ViewshedRun want = engine(options, geodesy::GroundSample::kCell);
  const geodesy::GridPoint eye = want.observer_in_source();
  EXPECT_DOUBLE_EQ(cell.header.observer().ground(), eye.ground);
  EXPECT_DOUBLE_EQ(cell.header.observer().elevation(), eye.ground + 5.0);
  auto dem = terrain::read_dem(bundled_dem(kAndes));
  ASSERT_TRUE(dem.ok());
  EXPECT_NEAR(cell.header.observer().col(), 188.55, 1e-4);
  EXPECT_DOUBLE_EQ(cell.header.observer().ground(), dem->elevation.at(189, 249));
  EXPECT_DOUBLE_EQ(bilinear.header.observer().ground(),
                   terrain::sample_bilinear(dem->elevation, bilinear.header.observer().col(),
                                            bilinear.header.observer().row()));
  EXPECT_GT(cell.header.observer().ground() - bilinear.header.observer().ground(), 10.0);
}

TEST_F(ServerViewshedOptions, CogBytesAndCreationOptionErrors) {
  v1::ViewshedRequest r = request();
  r.set_include_raster(false);
  r.set_include_geotiff(true);
  r.set_geotiff_format(v1::GEOTIFF_FORMAT_COG);
  r.add_creation_options("COMPRESS=ZSTD");
  const Stream s = run(r);
  ASSERT_TRUE(s.status.ok()) << s.status.error_message();
  EXPECT_EQ(s.geotiff.compare(8, 30, "GDAL_STRUCTURAL_METADATA_SIZE="), 0);

  struct Bad {
    std::function<void(v1::ViewshedRequest&)> set;
    const char* field;
  };
  const std::vector<Bad> bad = {
      {[](auto& q) { q.add_creation_options("COMPRESS=JPEG"); }, "creation_options"},
      {[](auto& q) {
         q.add_creation_options("TILED=NO");
         q.set_geotiff_format(v1::GEOTIFF_FORMAT_COG);
       },
       "creation_options"},
      {[](auto& q) { q.mutable_codes()->set_visible(0); }, "codes.visible"},
      {[](auto& q) { q.mutable_codes()->set_hidden(256); }, "codes.hidden"},
      {[](auto& q) { q.set_output_nodata(1.5); }, "output_nodata"},
      {[](auto& q) {
         q.set_raster(v1::RASTER_KIND_OHF);
         q.mutable_codes()->set_visible(9);
       },
       "codes"},
      {[](auto& q) {
         q.mutable_options()->set_refraction(0.1);
         q.mutable_options()->set_curvature(0.9);
       },
       "options.refraction"},
      {[](auto& q) { q.mutable_options()->set_refraction(1.5); }, "options.refraction"},
      {[](auto& q) { q.mutable_options()->set_azimuth_end(400); }, "options.azimuth_end"},
      {[](auto& q) { q.mutable_options()->set_min_distance(2000); }, "options.min_distance"},
      {[](auto& q) { q.mutable_options()->set_pitch_min(-95); }, "options.pitch_min"},
      {[](auto& q) { q.mutable_observer()->set_ground(static_cast<v1::GroundSample>(7)); }, "observer.ground"},
  };
  for (const Bad& b : bad) {
    v1::ViewshedRequest q = request();
    b.set(q);
    const Stream e = run(q);
    EXPECT_EQ(e.status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << b.field << ": " << e.status.error_message();
    EXPECT_EQ(violated_field(e.status), b.field) << e.status.error_message();
  }
}

}  // namespace
}  // namespace horizon::testing
