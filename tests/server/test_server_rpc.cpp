// The daemon through its gRPC API: every error of the error model with its
// details, streamed rasters equal to the engine's, cancellation inside a
// computation and mid-stream, deadlines, SIGHUP reload and SIGTERM drain.
#include <gtest/gtest.h>

#include <signal.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <future>
#include <map>
#include <optional>
#include <sstream>
#include <thread>

#include "daemon_process.hpp"
#include "horizon/geodesy/observer.hpp"
#include "horizon/terrain/dem_reader.hpp"
#include "horizon/terrain/geotiff_writer.hpp"
#include "horizon/visibility/viewshed.hpp"
#include "horizon/visibility/viewshed_outputs.hpp"
#include "rpc_helpers.hpp"

namespace horizon::testing {
namespace {

// Rainier (EPSG:4326, 3" cells): a viewpoint near the summit.
constexpr double kRainierLon = -121.7604, kRainierLat = 46.8529;
// Ecuador (UTM 17S, 10 m cells, 383x415): a centre point; R3 over it all takes seconds.
constexpr double kEcuadorX = 713877, kEcuadorY = 9558936;

// "big": 2000x2000 synthetic cells (UTM 33N, 10 m), so that a computation
// can outlast a deadline, a cancel, a reload and a shutdown; R3 over 1.5 km
// of it (90 000 targets x 150 crossings... times 25) takes seconds.
class ServerRpc : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    data_ = new TempDir();
    namespace fs = std::filesystem;
    for (const char* f :
         {"rainier_summit_srtm3_400x400.tif", "ecuador_andes_utm17s_10m_383x415.tif", "zion_canyon_srtm3_465x457.tif"})
      fs::copy_file(bundled_dem(f), data_->path() / f);
    const terrain::Dem big = make_dem(2000, 2000, [](int c, int r) {
      return 500.0 + 200.0 * std::sin(c * 0.013) * std::cos(r * 0.017) + 30.0 * std::sin(c * 0.21 + r * 0.17);
    });
    ASSERT_TRUE(terrain::write_geotiff(data_->file("big.tif"), big.elevation, big.georef, std::nullopt).ok());
  }
  static void TearDownTestSuite() {
    delete data_;
    data_ = nullptr;
  }
  static TempDir* data_;

  void SetUp() override {
    DaemonOptions o;
    o.data_root = data_->path().string();
    o.datasets = {{"rainier", "rainier_summit_srtm3_400x400.tif"},
                  {"ecuador", "ecuador_andes_utm17s_10m_383x415.tif"},
                  {"big", "big.tif"}};
    o.extra_json = R"("limits": {"max_boxes": 1000, "max_cells": 3000000, "max_lines": 50}, "engine_threads": 1,)";
    daemon_ = std::make_unique<DaemonProcess>(o);
    ASSERT_TRUE(daemon_->ready()) << daemon_->error();
    datasets_ = v1::DatasetService::NewStub(daemon_->channel());
    visibility_ = v1::VisibilityService::NewStub(daemon_->channel());
  }

  v1::ViewshedRequest rainier_viewshed(double max_distance) const {
    v1::ViewshedRequest r;
    r.set_dataset("rainier");
    *r.mutable_observer() = point(kRainierLon, kRainierLat, 2.0, v1::FRAME_WGS84);
    r.mutable_options()->set_max_distance(max_distance);
    return r;
  }
  // A viewshed that computes for seconds: R3 over 2.2 million cells of "big".
  v1::ViewshedRequest slow_viewshed(double max_distance = 7400) const {
    v1::ViewshedRequest r;
    r.set_dataset("big");
    *r.mutable_observer() = point(500000 + 10000.5, 5000000 - 10000.5);  // the centre
    r.mutable_options()->set_algorithm(v1::ALGORITHM_R3);
    r.mutable_options()->set_max_distance(max_distance);
    return r;
  }
  // Drains a stream; returns its status.
  grpc::Status run_viewshed(const v1::ViewshedRequest& request, std::vector<v1::ViewshedResponse>* out = nullptr,
                            std::chrono::milliseconds deadline = std::chrono::seconds(30)) {
    auto context = context_with_deadline(deadline);
    auto reader = visibility_->ComputeViewshed(context.get(), request);
    v1::ViewshedResponse message;
    while (reader->Read(&message))
      if (out) out->push_back(message);
    return reader->Finish();
  }
  // The request log line of the last call of `method`.
  std::string last_log_line(const std::string& method) const {
    const auto lines = daemon_->request_lines();
    for (auto it = lines.rbegin(); it != lines.rend(); ++it)
      if (it->find("\"method\":\"" + method + "\"") != std::string::npos) return *it;
    return "";
  }

  std::unique_ptr<DaemonProcess> daemon_;
  std::unique_ptr<v1::DatasetService::Stub> datasets_;
  std::unique_ptr<v1::VisibilityService::Stub> visibility_;
};

TempDir* ServerRpc::data_ = nullptr;

// rainier_viewshed(max_distance)'s answer from the engine in this process,
// on the same file: its OHF and its DEM (for the georeference).
struct EngineAnswer {
  terrain::Dem dem;
  visibility::ViewshedResult result;
};
Result<EngineAnswer> engine_rainier(double max_distance) {
  auto dem = terrain::read_dem(bundled_dem("rainier_summit_srtm3_400x400.tif"));
  if (!dem.ok()) return dem.error();
  geodesy::PointSpec spec{geodesy::PointFrame::kWgs84, kRainierLon, kRainierLat, 2.0,
                          geodesy::HeightMode::kAboveGround};
  auto eye = geodesy::resolve_point(*dem, spec, "observer");
  if (!eye.ok()) return eye.error();
  visibility::ViewshedOptions options;
  options.max_distance = max_distance;
  options.threads = 1;
  auto result = visibility::compute_viewshed(*dem, *eye, options);
  if (!result.ok()) return result.error();
  return EngineAnswer{std::move(*dem), std::move(*result)};
}

TEST_F(ServerRpc, StreamedRasterEqualsTheEngineAndIsGeoreferenced) {
  v1::ViewshedRequest request = rainier_viewshed(5000);
  request.set_raster(v1::RASTER_KIND_OHF);
  request.set_include_raster(true);
  request.set_max_chunk_bytes(4096);  // many chunks
  std::vector<v1::ViewshedResponse> messages;
  ASSERT_TRUE(run_viewshed(request, &messages).ok());
  ASSERT_GE(messages.size(), 4u);
  ASSERT_TRUE(messages.front().has_header());
  ASSERT_TRUE(messages.back().has_summary());
  const v1::ViewshedHeader& h = messages.front().header();
  EXPECT_EQ(h.sample_type(), v1::SAMPLE_TYPE_FLOAT32);
  EXPECT_EQ(h.epsg(), 4326);
  EXPECT_EQ(h.algorithm(), "fast");
  std::string raster;
  int next_row = 0;
  for (const auto& m : messages)
    if (m.has_raster_chunk()) {
      EXPECT_EQ(m.raster_chunk().row0(), next_row);
      EXPECT_LE(m.raster_chunk().data().size(), 4096u);
      next_row += m.raster_chunk().rows();
      raster += m.raster_chunk().data();
    }
  EXPECT_EQ(next_row, h.height());

  // The engine, in this process, on the same file.
  auto engine = engine_rainier(5000);
  ASSERT_TRUE(engine.ok()) << engine.error().message;
  const terrain::Dem* const dem = &engine->dem;
  const visibility::ViewshedResult* const result = &engine->result;
  const auto ohf = visibility::ohf_raster(*result);
  ASSERT_EQ(h.width(), ohf.width());
  ASSERT_EQ(h.height(), ohf.height());
  ASSERT_EQ(raster.size(), ohf.size() * sizeof(float));
  EXPECT_EQ(std::memcmp(raster.data(), ohf.data(), raster.size()), 0);
  const auto georef = visibility::window_georef(*dem, *result);
  EXPECT_DOUBLE_EQ(h.transform().origin_x(), georef.transform.origin_x);
  EXPECT_DOUBLE_EQ(h.transform().origin_y(), georef.transform.origin_y);
  EXPECT_EQ(h.window().col0(), result->frame.window.col0);
  const auto mask = visibility::visibility_mask(*result, 0);
  std::uint64_t visible = 0;
  for (auto v : mask.values()) visible += v == visibility::kVisible;
  EXPECT_EQ(messages.back().summary().visible_cells(), visible);
  EXPECT_NE(last_log_line("ComputeViewshed").find("\"status\":\"OK\""), std::string::npos);
}

// The code rasters come from the mask the sweep makes (no OHF): the same
// bytes and counts as the engine's codes of an ordinary run, call after
// call (the worker's kept mask refilled), visible and boolean alike.
TEST_F(ServerRpc, StreamedCodeRastersEqualTheEnginesCodes) {
  auto engine = engine_rainier(5000);
  ASSERT_TRUE(engine.ok()) << engine.error().message;
  const visibility::ViewshedResult* const result = &engine->result;
  visibility::AnswerCounts counts;
  for (const auto kind : {v1::RASTER_KIND_VISIBLE, v1::RASTER_KIND_BOOLEAN, v1::RASTER_KIND_VISIBLE}) {
    const visibility::ValueCodes codes =
        kind == v1::RASTER_KIND_BOOLEAN ? visibility::kBooleanCodes : visibility::ValueCodes{};
    const auto want = visibility::visibility_codes(*result, 0.0, codes, 1, &counts);
    ASSERT_GT(counts.out_of_range, 0u);
    v1::ViewshedRequest request = rainier_viewshed(5000);
    request.set_raster(kind);
    request.set_include_raster(true);
    std::vector<v1::ViewshedResponse> messages;
    ASSERT_TRUE(run_viewshed(request, &messages).ok());
    const v1::ViewshedHeader& h = messages.front().header();
    EXPECT_EQ(h.sample_type(), v1::SAMPLE_TYPE_UINT8);
    ASSERT_EQ(h.width(), want.width());
    ASSERT_EQ(h.height(), want.height());
    std::string raster;
    for (const auto& m : messages)
      if (m.has_raster_chunk()) raster += m.raster_chunk().data();
    ASSERT_EQ(raster.size(), want.size());
    EXPECT_EQ(std::memcmp(raster.data(), want.data(), raster.size()), 0) << v1::RasterKind_Name(kind);
    EXPECT_EQ(messages.back().summary().visible_cells(), counts.visible);
    EXPECT_EQ(messages.back().summary().hidden_cells(), counts.hidden);
  }
}

// include_progress: progress messages before the header, the first at once,
// the fractions in [0, 1] and never decreasing, then the usual stream; none
// unless asked for.
TEST_F(ServerRpc, ProgressMessagesPrecedeTheHeaderWhenAskedFor) {
  v1::ViewshedRequest slow = slow_viewshed(3000);  // R3 over ~350 000 cells: well over 250 ms
  slow.set_include_progress(true);
  std::vector<v1::ViewshedResponse> messages;
  ASSERT_TRUE(run_viewshed(slow, &messages).ok());
  std::size_t header = 0;
  while (header < messages.size() && messages[header].has_progress()) ++header;
  ASSERT_GE(header, 2u) << "the first at once, then more while R3 runs";
  ASSERT_LT(header, messages.size());
  EXPECT_TRUE(messages[header].has_header());
  EXPECT_TRUE(messages.back().has_summary());
  double last = -1.0;
  for (std::size_t i = 0; i < header; ++i) {
    const v1::ViewshedProgress& p = messages[i].progress();
    EXPECT_GE(p.fraction(), last);
    EXPECT_LE(p.fraction(), 1.0);
    EXPECT_GE(p.seconds(), 0.0);
    last = p.fraction();
  }
  for (std::size_t i = header; i < messages.size(); ++i) EXPECT_FALSE(messages[i].has_progress()) << i;
  messages.clear();
  ASSERT_TRUE(run_viewshed(rainier_viewshed(3000), &messages).ok());
  for (const auto& m : messages) EXPECT_FALSE(m.has_progress());
}

TEST_F(ServerRpc, InvalidArgumentNamesTheField) {
  struct Case {
    std::function<void(v1::ViewshedRequest&)> edit;
    std::string field;
  };
  const std::vector<Case> cases = {
      {[](auto& r) { r.mutable_observer()->set_height(-1); }, "observer.height"},
      {[](auto& r) { r.mutable_options()->set_max_distance(-5); }, "options.max_distance"},
      {[](auto& r) { r.mutable_options()->set_curvature(5); }, "options.curvature"},
      {[](auto& r) { r.mutable_options()->set_ray_spacing(9); }, "options.ray_spacing"},
      {[](auto& r) { r.mutable_options()->set_target_height(-2); }, "options.target_height"},
      {[](auto& r) { r.mutable_options()->set_algorithm(static_cast<v1::Algorithm>(42)); }, "options.algorithm"},
      {[](auto& r) { r.mutable_observer()->set_y(91); }, "observer.y"},
      {[](auto& r) { r.clear_observer(); }, "observer"},
      {[](auto& r) { r.set_dataset(""); }, "dataset"},
  };
  for (const Case& c : cases) {
    v1::ViewshedRequest request = rainier_viewshed(3000);
    c.edit(request);
    const grpc::Status s = run_viewshed(request);
    EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << c.field << ": " << s.error_message();
    EXPECT_EQ(violated_field(s), c.field) << s.error_message();
  }

  v1::CullBoxesRequest cull;
  cull.set_dataset("rainier");
  *cull.mutable_observer() = point(kRainierLon, kRainierLat, 2, v1::FRAME_WGS84);
  for (int i = 0; i < 2; ++i) {
    v1::Box* b = cull.add_boxes();
    b->set_frame(v1::FRAME_WGS84);
    b->set_x_min(-121.75);
    b->set_x_max(-121.74);
    b->set_y_min(46.84);
    b->set_y_max(46.845);
    b->set_z_min(i ? 3000 : 10);
    b->set_z_max(20);
  }
  v1::CullBoxesResponse cull_response;
  grpc::Status s = visibility_->CullBoxes(context_with_deadline().get(), cull, &cull_response);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(violated_field(s), "boxes[1].z_max");

  v1::LineOfSightRequest los;
  los.set_dataset("rainier");
  v1::LineOfSightResponse los_response;
  s = visibility_->LineOfSight(context_with_deadline().get(), los, &los_response);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(violated_field(s), "lines");

  v1::ListDatasetsRequest list;
  list.set_page_token("not-a-token");
  v1::ListDatasetsResponse list_response;
  s = datasets_->ListDatasets(context_with_deadline().get(), list, &list_response);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(violated_field(s), "page_token");
}

TEST_F(ServerRpc, NotFoundOutOfRangeAndResourceExhausted) {
  v1::GetDatasetRequest get;
  get.set_name("atlantis");
  v1::Dataset dataset;
  grpc::Status s = datasets_->GetDataset(context_with_deadline().get(), get, &dataset);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::NOT_FOUND);
  v1::ViewshedRequest unknown = rainier_viewshed(1000);
  unknown.set_dataset("atlantis");
  EXPECT_EQ(run_viewshed(unknown).error_code(), grpc::StatusCode::NOT_FOUND);

  v1::ViewshedRequest outside = rainier_viewshed(1000);
  outside.mutable_observer()->set_x(10.0);
  s = run_viewshed(outside);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::OUT_OF_RANGE) << s.error_message();
  EXPECT_EQ(violated_field(s), "observer");

  v1::CullBoxesRequest cull;
  cull.set_dataset("ecuador");
  *cull.mutable_observer() = point(kEcuadorX, kEcuadorY);
  v1::Box* far = cull.add_boxes();
  far->set_x_min(kEcuadorX + 50000);
  far->set_x_max(kEcuadorX + 50010);
  far->set_y_min(kEcuadorY);
  far->set_y_max(kEcuadorY + 10);
  far->set_z_max(5000);
  // A box off the map is answered, not refused: the call succeeds.
  v1::CullBoxesResponse response;
  s = visibility_->CullBoxes(context_with_deadline().get(), cull, &response);
  ASSERT_TRUE(s.ok()) << s.error_message();
  ASSERT_EQ(response.boxes_size(), 1);
  EXPECT_EQ(response.boxes(0).state(), v1::BOX_STATE_OUT_OF_RANGE);
  EXPECT_TRUE(response.boxes(0).visible());  // nothing is said of it: never culled
  EXPECT_EQ(response.out_of_range_count(), 1u);

  // Past the configured limits: 1000 boxes, 100 000 cells, 50 lines.
  cull.clear_boxes();
  for (int i = 0; i < 1001; ++i) {
    v1::Box* b = cull.add_boxes();
    b->set_x_min(kEcuadorX);
    b->set_x_max(kEcuadorX + 5);
    b->set_y_min(kEcuadorY);
    b->set_y_max(kEcuadorY + 5);
    b->set_z_max(5000);
  }
  s = visibility_->CullBoxes(context_with_deadline().get(), cull, &response);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_EQ(violated_field(s), "boxes");
  v1::ViewshedRequest whole = slow_viewshed();
  whole.mutable_options()->clear_max_distance();  // all 4 million cells of "big"
  s = run_viewshed(whole);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_EQ(violated_field(s), "options.max_distance");
  v1::LineOfSightRequest los;
  los.set_dataset("rainier");
  for (int i = 0; i < 51; ++i) {
    v1::SightLine* l = los.add_lines();
    *l->mutable_from() = point(kRainierLon, kRainierLat, 2, v1::FRAME_WGS84);
    *l->mutable_to() = point(kRainierLon + 0.01, kRainierLat, 2, v1::FRAME_WGS84);
  }
  v1::LineOfSightResponse los_response;
  s = visibility_->LineOfSight(context_with_deadline().get(), los, &los_response);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  // Every error is logged as a warning with its code, none as an error.
  EXPECT_EQ(daemon_->log().find("\"level\":\"error\""), std::string::npos) << daemon_->log();
  EXPECT_NE(last_log_line("LineOfSight").find("RESOURCE_EXHAUSTED"), std::string::npos);
}

// ray_spacing is in its documented range (0, 4] at 1e-6 and 1e-4, yet the
// sweep would need 10^9 or 10^8 rays: both are refused from the plan, before
// anything is allocated, naming the field and what it costs, and the daemon
// answers the next request as before.
TEST_F(ServerRpc, ATinyRaySpacingIsRefusedFromThePlan) {
  v1::ViewshedRequest r = slow_viewshed();
  r.mutable_options()->set_algorithm(v1::ALGORITHM_FAST);
  r.mutable_options()->set_ray_spacing(1e-6);
  grpc::Status s = run_viewshed(r, nullptr, std::chrono::seconds(20));
  EXPECT_EQ(s.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << s.error_message();
  EXPECT_EQ(violated_field(s), "options.ray_spacing");
  EXPECT_NE(s.error_message().find("rays a sector"), std::string::npos) << s.error_message();
  r.mutable_options()->set_ray_spacing(1e-4);  // a sweep could run it; the memory budget cannot hold it
  s = run_viewshed(r, nullptr, std::chrono::seconds(20));
  EXPECT_EQ(s.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << s.error_message();
  EXPECT_EQ(violated_field(s), "memory_budget_mb");
  EXPECT_NE(s.error_message().find("sweep rays at options.ray_spacing = 0.0001"), std::string::npos)
      << s.error_message();
  r.mutable_options()->set_ray_spacing(1.0);
  std::vector<v1::ViewshedResponse> out;
  s = run_viewshed(r, &out);
  EXPECT_TRUE(s.ok()) << s.error_message();
  EXPECT_FALSE(out.empty());
}

TEST_F(ServerRpc, LineOfSightBatchAnswersInOrder) {
  v1::LineOfSightRequest los;
  los.set_dataset("rainier");
  for (int i = 0; i < 20; ++i) {
    v1::SightLine* l = los.add_lines();
    *l->mutable_from() = point(kRainierLon, kRainierLat, 2, v1::FRAME_WGS84);
    *l->mutable_to() = point(kRainierLon + 0.003 * (i - 10), kRainierLat - 0.02, 2500, v1::FRAME_WGS84);
    l->mutable_to()->set_height_mode(v1::HEIGHT_MODE_ABSOLUTE);  // some targets lie on voids
  }
  los.set_include_profile(true);
  v1::LineOfSightResponse response;
  const grpc::Status status = visibility_->LineOfSight(context_with_deadline().get(), los, &response);
  ASSERT_TRUE(status.ok()) << status.error_message();
  ASSERT_EQ(response.results_size(), 20);
  for (int i = 0; i < 20; ++i) {
    const auto& r = response.results(i);
    EXPECT_NEAR(*(r.to().has_lon() ? std::optional(r.to().lon()) : std::nullopt), kRainierLon + 0.003 * (i - 10), 1e-9);
    EXPECT_GT(r.profile_size(), 0);
    EXPECT_EQ(r.visible(), !r.has_first_block());
  }
}

TEST_F(ServerRpc, CullAnswersEachBoxsStateBesideVisible) {
  // A row of boxes rising eastwards from the summit: the low ones hidden, the
  // high ones seen, some buried ones over the crop's voids undetermined; ids
  // 1000 + i echoed, and box 100 off the map.
  v1::CullBoxesRequest cull;
  cull.set_dataset("rainier");
  *cull.mutable_observer() = point(kRainierLon, kRainierLat, 2, v1::FRAME_WGS84);
  cull.set_conservative(true);
  for (int i = 0; i < 100; ++i) {
    v1::Box* b = cull.add_boxes();
    b->set_frame(v1::FRAME_WGS84);
    b->set_x_min(-121.85 + 0.002 * i);
    b->set_x_max(-121.85 + 0.002 * i + 0.0005);
    b->set_y_min(46.80);
    b->set_y_max(46.8005);
    b->set_z_min(0);
    b->set_z_max(1500 + 30 * i);
    b->set_id(1000 + i);
  }
  v1::Box* off = cull.add_boxes();
  *off = cull.boxes(0);
  off->set_x_min(-100.0);
  off->set_x_max(-99.99);
  off->set_id(7);

  const auto states = [&](const v1::CullBoxesRequest& request, std::map<int, int>& count) {
    v1::CullBoxesResponse response;
    const grpc::Status s = visibility_->CullBoxes(context_with_deadline().get(), request, &response);
    ASSERT_TRUE(s.ok()) << s.error_message();
    ASSERT_EQ(response.boxes_size(), 101);
    for (int i = 0; i < response.boxes_size(); ++i) {
      const v1::BoxVisibility& b = response.boxes(i);
      EXPECT_EQ(b.id(), i < 100 ? 1000u + i : 7u);
      EXPECT_NE(b.state(), v1::BOX_STATE_UNSPECIFIED) << "box " << i;
      EXPECT_EQ(b.visible(), b.state() != v1::BOX_STATE_HIDDEN) << "box " << i;  // only hidden boxes may be culled
      EXPECT_EQ(b.state() == v1::BOX_STATE_OUT_OF_RANGE, i == 100) << "box " << i;
      ++count[b.state()];
    }
    EXPECT_EQ(response.out_of_range_count(), 1u);
    EXPECT_EQ(static_cast<int>(response.visible_count()), 101 - count[v1::BOX_STATE_HIDDEN]);
  };
  std::map<int, int> transparent;
  states(cull, transparent);
  EXPECT_GT(transparent[v1::BOX_STATE_VISIBLE], 0);
  EXPECT_GT(transparent[v1::BOX_STATE_HIDDEN], 0);
  EXPECT_GT(transparent[v1::BOX_STATE_UNDETERMINED], 0);

  // Voids filled as terrain: every box on the map is decided.
  cull.set_nodata(v1::NODATA_POLICY_FILL);
  cull.set_nodata_fill_height(4000);
  std::map<int, int> filled;
  states(cull, filled);
  EXPECT_EQ(filled[v1::BOX_STATE_UNDETERMINED], 0);
  EXPECT_EQ(filled[v1::BOX_STATE_VISIBLE] + filled[v1::BOX_STATE_HIDDEN], 100);

  // An unknown policy is refused, naming the field.
  cull.set_nodata(static_cast<v1::NodataPolicy>(42));
  v1::CullBoxesResponse response;
  const grpc::Status bad = visibility_->CullBoxes(context_with_deadline().get(), cull, &response);
  EXPECT_EQ(bad.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(violated_field(bad), "nodata");
}

TEST_F(ServerRpc, DeadlineAndCancellationStopTheComputation) {
  // Deadline: the engine stops soon after it passes.
  const auto started = std::chrono::steady_clock::now();
  grpc::Status s = run_viewshed(slow_viewshed(), nullptr, std::chrono::milliseconds(150));
  EXPECT_EQ(s.error_code(), grpc::StatusCode::DEADLINE_EXCEEDED);
  ASSERT_TRUE(daemon_->wait_for_log("\"status\":\"DEADLINE_EXCEEDED\""));
  EXPECT_LT(std::chrono::steady_clock::now() - started, std::chrono::seconds(3));

  // Client cancels while the daemon computes: after the first progress
  // message, which the computation sends as it begins (counted in flight
  // only, the call may still wait for a worker, and a cancel then drops it
  // before it starts).
  grpc::ClientContext context;
  v1::ViewshedRequest slow = slow_viewshed();
  slow.set_include_progress(true);
  auto reader = visibility_->ComputeViewshed(&context, slow);
  v1::ViewshedResponse message;
  ASSERT_TRUE(reader->Read(&message));
  ASSERT_TRUE(message.has_progress());
  context.TryCancel();
  while (reader->Read(&message)) {
  }
  EXPECT_EQ(reader->Finish().error_code(), grpc::StatusCode::CANCELLED);
  ASSERT_TRUE(daemon_->wait_for_log("\"status\":\"CANCELLED\"", std::chrono::seconds(3)))
      << "the computation was not stopped: " << daemon_->log();
  const std::string line = last_log_line("ComputeViewshed");
  EXPECT_NE(line.find("\"algorithm\":\"r3\""), std::string::npos) << line;

  // The daemon is fine afterwards.
  EXPECT_TRUE(run_viewshed(rainier_viewshed(2000)).ok());
}

// Both workers busy; calls whose deadlines pass while they wait in the
// queue must give their max_pending slots back then, not when a worker
// reaches them seconds later (1 ms deadlines from one client used to fill it).
TEST_F(ServerRpc, CallsWhoseDeadlinePassesInTheQueueFreeTheirSlotsAtOnce) {
  std::vector<std::unique_ptr<grpc::ClientContext>> busy;
  std::vector<std::unique_ptr<grpc::ClientReader<v1::ViewshedResponse>>> readers;
  for (int i = 0; i < 2; ++i) {  // the fixture's two workers
    busy.push_back(std::make_unique<grpc::ClientContext>());
    readers.push_back(visibility_->ComputeViewshed(busy.back().get(), slow_viewshed(5500)));  // ~3 s each
  }
  ASSERT_TRUE(daemon_->wait_for_in_flight(2)) << daemon_->metrics();
  std::vector<std::future<grpc::StatusCode>> queued;
  for (int i = 0; i < 8; ++i)
    queued.push_back(std::async(std::launch::async, [&] {
      v1::LineOfSightRequest request;
      request.set_dataset("rainier");
      auto* line = request.add_lines();
      *line->mutable_from() = point(kRainierLon, kRainierLat, 2, v1::FRAME_WGS84);
      *line->mutable_to() = point(kRainierLon + 0.01, kRainierLat, 2, v1::FRAME_WGS84);
      v1::LineOfSightResponse response;
      return visibility_->LineOfSight(context_with_deadline(std::chrono::milliseconds(50)).get(), request, &response)
          .error_code();
    }));
  for (auto& q : queued) EXPECT_EQ(q.get(), grpc::StatusCode::DEADLINE_EXCEEDED);
  // Only the two computations hold slots again. The wait allows for a
  // loaded machine; the computations are cancelled, not finished, after it
  // (asserted below), so no worker reached the queued calls meanwhile.
  const auto until = std::chrono::steady_clock::now() + std::chrono::milliseconds(1500);
  double in_flight = -1;
  while (std::chrono::steady_clock::now() < until) {
    in_flight = metric(daemon_->metrics(), "horizon_requests_in_flight");
    if (in_flight == 2) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  EXPECT_EQ(in_flight, 2) << daemon_->metrics();
  for (auto& c : busy) c->TryCancel();
  for (auto& r : readers) {
    v1::ViewshedResponse message;
    while (r->Read(&message)) {
    }
    EXPECT_EQ(r->Finish().error_code(), grpc::StatusCode::CANCELLED);
  }
}

// A dataset name far longer than any configured one is refused without
// being echoed, and the log line stays short.
TEST_F(ServerRpc, AHugeDatasetNameIsRefusedAndNotEchoed) {
  v1::ViewshedRequest request = rainier_viewshed(1000);
  request.set_dataset(std::string(1 << 20, 'n'));
  const grpc::Status s = run_viewshed(request);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(violated_field(s), "dataset");
  EXPECT_LT(s.error_message().size(), 200u) << s.error_message().substr(0, 200);
  ASSERT_TRUE(daemon_->wait_for_log("at most 128 bytes"));
  const std::string line = last_log_line("ComputeViewshed");
  EXPECT_LT(line.size(), 4096u);
}

TEST_F(ServerRpc, ClientCancellingMidStreamEndsTheCall) {
  // 2.2 million float cells in 4 KiB messages: far more than gRPC buffers unread.
  v1::ViewshedRequest request = slow_viewshed();
  request.mutable_options()->set_algorithm(v1::ALGORITHM_FAST);
  request.set_raster(v1::RASTER_KIND_OHF);
  request.set_include_raster(true);
  request.set_include_geotiff(true);
  request.set_max_chunk_bytes(4096);
  grpc::ClientContext context;
  auto reader = visibility_->ComputeViewshed(&context, request);
  v1::ViewshedResponse message;
  ASSERT_TRUE(reader->Read(&message));
  ASSERT_TRUE(message.has_header());
  ASSERT_TRUE(reader->Read(&message));
  ASSERT_TRUE(message.has_raster_chunk());
  context.TryCancel();
  int after = 0;
  while (reader->Read(&message)) ++after;
  EXPECT_EQ(reader->Finish().error_code(), grpc::StatusCode::CANCELLED);
  ASSERT_TRUE(daemon_->wait_for_log("\"status\":\"CANCELLED\"", std::chrono::seconds(5))) << daemon_->log();
  EXPECT_NE(last_log_line("ComputeViewshed").find("CANCELLED"), std::string::npos);
  EXPECT_TRUE(run_viewshed(rainier_viewshed(2000)).ok());
}

TEST_F(ServerRpc, SighupReloadsDatasetsWithoutDroppingACall) {
  // A call in flight across the reload.
  auto slow = std::async(std::launch::async, [&] {
    return run_viewshed(slow_viewshed(3500)).error_code();  // about a second
  });
  ASSERT_TRUE(daemon_->wait_for_in_flight(1)) << daemon_->metrics();
  std::string config;
  {
    std::ifstream in(daemon_->config_path());
    std::ostringstream text;
    text << in.rdbuf();
    config = text.str();
  }
  const auto at = config.find("\"datasets\": {");
  ASSERT_NE(at, std::string::npos);
  config.insert(at + 13, "\"zion\": \"zion_canyon_srtm3_465x457.tif\", ");
  // And a key a reload cannot apply: the log says it needs a restart.
  const auto budget = config.find("\"memory_budget_mb\": ");
  ASSERT_NE(budget, std::string::npos);
  config.insert(budget + 20, "1");  // 256 -> 1256
  write_file(daemon_->config_path(), config);
  daemon_->signal(SIGHUP);
  ASSERT_TRUE(daemon_->wait_for_log("datasets_reloaded")) << daemon_->log();
  ASSERT_TRUE(daemon_->wait_for_log("\"event\":\"reload_needs_restart\",\"keys\":\"memory_budget_mb"))
      << daemon_->log();
  v1::GetDatasetRequest get;
  get.set_name("zion");
  v1::Dataset zion;
  ASSERT_TRUE(datasets_->GetDataset(context_with_deadline().get(), get, &zion).ok());
  EXPECT_EQ(zion.width(), 465);
  EXPECT_EQ(slow.get(), grpc::StatusCode::OK);
}

// /healthz on the metrics listener says horizon_serving 1 while the daemon
// serves and 0 from the moment it drains, while its last calls finish: what
// a load balancer's HTTP check (HAProxy's) takes it out of rotation on.
TEST_F(ServerRpc, HealthzSaysServingUntilTheDaemonDrains) {
  const std::string serving = daemon_->metrics_page("/healthz");
  EXPECT_NE(serving.find("200 OK"), std::string::npos) << serving;
  EXPECT_NE(serving.find("\nhorizon_serving 1"), std::string::npos) << serving;
  EXPECT_EQ(serving.find("horizon_requests_total"), std::string::npos) << "/healthz is the serving gauge alone";
  EXPECT_EQ(metric(daemon_->metrics(), "horizon_serving"), 1);

  auto slow = std::async(std::launch::async, [&] {
    return run_viewshed(slow_viewshed(3500)).error_code();  // about a second
  });
  ASSERT_TRUE(daemon_->wait_for_in_flight(1)) << daemon_->metrics();
  ASSERT_EQ(::kill(daemon_->pid(), SIGTERM), 0);
  std::string draining;
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (std::chrono::steady_clock::now() < until) {
    draining = daemon_->metrics_page("/healthz");
    if (draining.find("\nhorizon_serving 0") != std::string::npos) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  EXPECT_NE(draining.find("\nhorizon_serving 0"), std::string::npos) << draining;
  EXPECT_EQ(slow.get(), grpc::StatusCode::OK);  // the call in flight still finished
  EXPECT_EQ(daemon_->signal(SIGTERM), 0);
}

TEST_F(ServerRpc, SigtermDrainsCallsInFlightThenExitsZero) {
  auto slow = std::async(std::launch::async, [&] {
    return run_viewshed(slow_viewshed(3500)).error_code();  // about a second
  });
  ASSERT_TRUE(daemon_->wait_for_in_flight(1)) << daemon_->metrics();
  EXPECT_EQ(daemon_->signal(SIGTERM), 0);
  EXPECT_EQ(slow.get(), grpc::StatusCode::OK);
  const std::string log = daemon_->log();
  EXPECT_NE(log.find("\"event\":\"draining\""), std::string::npos);
  EXPECT_NE(log.find("\"event\":\"stopped\""), std::string::npos);
  EXPECT_EQ(log.find("\"level\":\"error\""), std::string::npos) << log;
}

}  // namespace
}  // namespace horizon::testing
