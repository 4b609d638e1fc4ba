// TraceService.TraceCamera against a real daemon: the streamed channels
// equal the engine's, box answers keep their ids, edits stay in their
// request, every wrong field is named, every limit refuses before a block is
// read, and deadlines and cancels end the call.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "daemon_process.hpp"
#include "horizon/terrain/dem_reader.hpp"
#include "horizon/terrain/geotiff_writer.hpp"
#include "horizon/terrain/source.hpp"
#include "horizon/trace/products.hpp"
#include "horizon/trace/trace_plan.hpp"
#include "horizon/v1/trace.grpc.pb.h"
#include "rpc_helpers.hpp"

namespace horizon::testing {
namespace {

const std::string kRainier = "rainier_summit_srtm3_400x400.tif";  // EPSG:4326, 3" cells

// "big": 2000 x 2000 synthetic cells (UTM 33N, 10 m), more than the fixture's limits.max_cells.
class ServerTrace : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    data_ = new TempDir();
    std::filesystem::copy_file(bundled_dem(kRainier), data_->path() / kRainier);
    const terrain::Dem big = make_dem(2000, 2000, [](int c, int r) {
      return 500.0 + 200.0 * std::sin(c * 0.013) * std::cos(r * 0.017) + 30.0 * std::sin(c * 0.21 + r * 0.17);
    });
    ASSERT_TRUE(terrain::write_geotiff(data_->file("big.tif"), big.elevation, big.georef, std::nullopt).ok());
    DaemonOptions o;
    o.data_root = data_->path().string();
    o.datasets = {{"rainier", kRainier}, {"big", "big.tif"}};
    o.memory_budget_mb = 256;  // 104 MiB left beside the block cache
    o.extra_json =
        R"("limits": {"max_boxes": 100, "max_cells": 3000000, "max_trace_pixels": 4194304}, "engine_threads": 1,)";
    daemon_ = new DaemonProcess(o);
  }
  static void TearDownTestSuite() {
    delete daemon_;
    daemon_ = nullptr;
    delete data_;
    data_ = nullptr;
  }
  void SetUp() override {
    ASSERT_TRUE(daemon_->ready()) << daemon_->error();
    stub_ = v1::TraceService::NewStub(daemon_->channel());
  }

  // The CLI test's camera: south-west of the summit, 800 m up, looking north-east.
  static v1::TraceRequest rainier_frame(int width = 320, int height = 180) {
    v1::TraceRequest r;
    r.set_dataset("rainier");
    v1::Camera& c = *r.mutable_camera();
    *c.mutable_position() = point(-121.90, 46.70, 800.0, v1::FRAME_WGS84);
    c.set_yaw(40);
    c.set_pitch(-3);
    c.set_hfov(60);
    c.set_width(width);
    c.set_height(height);
    return r;
  }
  static trace::CameraSpec rainier_spec(int width = 320, int height = 180) {
    trace::CameraSpec c;
    c.position = {geodesy::PointFrame::kWgs84, -121.90, 46.70, 800.0, geodesy::HeightMode::kAboveGround};
    c.yaw = 40;
    c.pitch = -3;
    c.hfov = 60;
    c.width = width;
    c.height = height;
    return c;
  }
  static v1::Box box(double x0, double y0, double x1, double y1, double z0, double z1, std::uint64_t id) {
    v1::Box b;
    b.set_frame(v1::FRAME_WGS84);
    b.set_x_min(x0);
    b.set_y_min(y0);
    b.set_x_max(x1);
    b.set_y_max(y1);
    b.set_z_min(z0);
    b.set_z_max(z1);
    b.set_id(id);
    return b;
  }

  // Drains a stream; returns its status.
  grpc::Status run(const v1::TraceRequest& request, std::vector<v1::TraceResponse>* out = nullptr,
                   std::chrono::milliseconds deadline = std::chrono::seconds(30)) {
    auto context = context_with_deadline(deadline);
    auto reader = stub_->TraceCamera(context.get(), request);
    v1::TraceResponse message;
    while (reader->Read(&message))
      if (out) out->push_back(message);
    return reader->Finish();
  }
  std::string last_log_line() const {
    const auto lines = daemon_->request_lines();
    for (auto it = lines.rbegin(); it != lines.rend(); ++it)
      if (it->find("\"method\":\"TraceCamera\"") != std::string::npos) return *it;
    return "";
  }
  // Blocks the daemon's cache has been asked for, by any request.
  double blocks_asked() const {
    const std::string text = daemon_->metrics();
    double n = 0;
    for (const char* result : {"hit", "join", "miss"})
      n += std::max(0.0, metric(text, std::string("horizon_block_cache_requests_total{result=\"") + result + "\"}"));
    return n;
  }

  static TempDir* data_;
  static DaemonProcess* daemon_;
  std::unique_ptr<v1::TraceService::Stub> stub_;
};
TempDir* ServerTrace::data_ = nullptr;
DaemonProcess* ServerTrace::daemon_ = nullptr;

// The same frame traced here, reading the file directly.
trace::TraceRun engine_run(const trace::TraceQuery& query) {
  auto source = terrain::ElevationSource::open(bundled_dem(kRainier));
  EXPECT_TRUE(source.ok());
  auto plan = trace::plan_trace(**source, query, 1);
  EXPECT_TRUE(plan.ok()) << plan.error().message;
  auto run = trace::run_trace(*plan, **source, nullptr);
  EXPECT_TRUE(run.ok()) << run.error().message;
  return std::move(*run);
}

TEST_F(ServerTrace, ChannelsEqualTheEngineRowByRow) {
  v1::TraceRequest request = rainier_frame();
  for (v1::TraceChannel c :
       {v1::TRACE_CHANNEL_SHADED_RGB, v1::TRACE_CHANNEL_DEPTH, v1::TRACE_CHANNEL_HIT_CELL, v1::TRACE_CHANNEL_HIT_XYZ})
    request.add_channels(c);
  request.set_include_footprint(true);
  request.set_max_chunk_bytes(4096);  // many chunks
  std::vector<v1::TraceResponse> messages;
  const grpc::Status s = run(request, &messages);
  ASSERT_TRUE(s.ok()) << s.error_message();
  ASSERT_FALSE(messages.empty());
  ASSERT_TRUE(messages.front().has_header());
  const v1::TraceHeader& h = messages.front().header();
  EXPECT_EQ(h.width(), 320);
  EXPECT_EQ(h.height(), 180);
  ASSERT_EQ(h.channels_size(), 4);
  EXPECT_EQ(h.channels(0), v1::TRACE_CHANNEL_SHADED_RGB);  // the request's order

  // Rows in order, channel after channel, each chunk within the limit.
  std::map<int, std::string> data;
  std::vector<int> order;
  std::string footprint;
  int next_row = 0;
  for (std::size_t i = 1; i < messages.size(); ++i) {
    const v1::TraceResponse& m = messages[i];
    if (m.has_rows()) {
      if (order.empty() || order.back() != m.rows().channel()) {
        if (!order.empty()) {
          EXPECT_EQ(next_row, 180);
        }
        order.push_back(m.rows().channel());
        next_row = 0;
      }
      EXPECT_EQ(m.rows().row0(), next_row);
      // At most max_chunk_bytes, or one row when a row is longer (HIT_XYZ: 6400 bytes).
      EXPECT_LE(m.rows().data().size(), std::max<std::size_t>(4096, 320 * (m.rows().channel() == 3 ? 20 : 8)));
      next_row += m.rows().rows();
      data[m.rows().channel()] += m.rows().data();
    } else {
      ASSERT_TRUE(m.has_file_chunk()) << i;
      EXPECT_EQ(m.file_chunk().offset(), footprint.size());
      footprint += m.file_chunk().data();
    }
  }
  EXPECT_EQ(order, (std::vector<int>{v1::TRACE_CHANNEL_SHADED_RGB, v1::TRACE_CHANNEL_DEPTH, v1::TRACE_CHANNEL_HIT_CELL,
                                     v1::TRACE_CHANNEL_HIT_XYZ}));
  EXPECT_EQ(next_row, 180);

  trace::TraceQuery query;
  query.camera = rainier_spec();
  query.options.threads = 1;
  const trace::TraceRun engine = engine_run(query);
  const std::size_t pixels = 320 * 180;
  const terrain::Grid<float> depth = trace::depth_image(engine.frame);
  ASSERT_EQ(data[v1::TRACE_CHANNEL_DEPTH].size(), pixels * 4);
  EXPECT_EQ(std::memcmp(data[v1::TRACE_CHANNEL_DEPTH].data(), depth.data(), pixels * 4), 0);
  const std::vector<std::uint8_t> rgb = trace::shaded_view(engine.frame, engine.view());
  ASSERT_EQ(data[v1::TRACE_CHANNEL_SHADED_RGB].size(), rgb.size());
  EXPECT_EQ(std::memcmp(data[v1::TRACE_CHANNEL_SHADED_RGB].data(), rgb.data(), rgb.size()), 0);
  const trace::HitImages hits = trace::hit_images(engine.frame, engine.window.col0, engine.window.row0);
  const std::string& cells = data[v1::TRACE_CHANNEL_HIT_CELL];
  const std::string& xyz = data[v1::TRACE_CHANNEL_HIT_XYZ];
  ASSERT_EQ(cells.size(), pixels * 8);
  ASSERT_EQ(xyz.size(), pixels * 20);
  const terrain::GeoTransform& t = engine.georef.transform;
  std::uint64_t sky = 0;
  for (std::size_t i = 0; i < pixels; ++i) {
    const int x = static_cast<int>(i % 320), j = static_cast<int>(i / 320);
    float col, row, elevation;
    double cx, cy;
    std::memcpy(&col, cells.data() + 8 * i, 4);
    std::memcpy(&row, cells.data() + 8 * i + 4, 4);
    std::memcpy(&cx, xyz.data() + 20 * i, 8);
    std::memcpy(&cy, xyz.data() + 20 * i + 8, 8);
    std::memcpy(&elevation, xyz.data() + 20 * i + 16, 4);
    if (std::isnan(depth.at(x, j))) {
      ++sky;
      ASSERT_TRUE(std::isnan(col) && std::isnan(row) && std::isnan(cx) && std::isnan(cy) && std::isnan(elevation));
      continue;
    }
    ASSERT_EQ(col, hits.col.at(x, j)) << x << "," << j;
    ASSERT_EQ(row, hits.row.at(x, j));
    ASSERT_EQ(elevation, hits.elevation.at(x, j));
    const trace::Hit hit = engine.frame.hit(x, j);
    ASSERT_EQ(cx, t.x_at(hit.col));
    ASSERT_EQ(cy, t.y_at(hit.row));
  }
  EXPECT_EQ(sky, h.stats().sky_pixels());
  EXPECT_GT(sky, 1000u);
  EXPECT_LT(sky, pixels / 2);

  // The header: the eye as placed, the window read and its georeference, the work.
  EXPECT_NEAR(h.camera().elevation(), engine.eye.elevation, 1e-9);
  EXPECT_NEAR(h.camera().ground() + 800.0, h.camera().elevation(), 1e-9);
  EXPECT_NEAR(h.camera().lon(), -121.90, 1e-9);
  EXPECT_EQ(h.read_window().col0(), engine.window.col0);
  EXPECT_EQ(h.read_window().row1(), engine.window.row1);
  EXPECT_DOUBLE_EQ(h.read_transform().origin_x(), t.origin_x);
  EXPECT_DOUBLE_EQ(h.read_transform().origin_y(), t.origin_y);
  EXPECT_EQ(h.epsg(), 4326);
  EXPECT_EQ(h.dem_cells(), 400u * 400u);
  EXPECT_EQ(h.stats().pixels(), pixels);
  EXPECT_EQ(h.stats().crossings(), engine.frame.stats.crossings);
  EXPECT_EQ(h.stats().backend(), "cpu");
  EXPECT_EQ(h.edited_cells(), 0u);

  // The footprint: a GeoTIFF over the cells read, as the CLI's --footprint.
  const std::string path = data_->file("footprint.tif");
  write_file(path, footprint);
  auto seen = terrain::read_dem(path);
  ASSERT_TRUE(seen.ok()) << seen.error().message;
  EXPECT_EQ(seen->width(), engine.window.width());
  EXPECT_EQ(seen->nodata, 255.0);
  const terrain::Grid<std::uint8_t> expected = trace::footprint(engine.frame, engine.view());
  std::uint64_t ones = 0;
  for (int r = 0; r < expected.height(); ++r)
    for (int c = 0; c < expected.width(); ++c) {
      if (expected.at(c, r) == 255) {
        ASSERT_TRUE(std::isnan(seen->elevation.at(c, r)));  // read back as a void
      } else {
        ASSERT_EQ(seen->elevation.at(c, r), static_cast<float>(expected.at(c, r)));
      }
      ones += expected.at(c, r) == 1;
    }
  EXPECT_GT(ones, 1000u);
  const std::string line = last_log_line();
  EXPECT_NE(line.find("\"status\":\"OK\""), std::string::npos) << line;
  EXPECT_NE(line.find("\"cells\":" + std::to_string(engine.window.cell_count())), std::string::npos) << line;
}

TEST_F(ServerTrace, BoxAnswersComeBackInOrderWithTheirIds) {
  v1::TraceRequest request = rainier_frame();
  // On the summit dome (seen), under the ground (never seen), off the dataset (no pixels).
  *request.add_boxes() = box(-121.765, 46.848, -121.755, 46.856, 4300, 4500, 17);
  *request.add_boxes() = box(-121.80, 46.75, -121.79, 46.76, 0, 10, 23);
  *request.add_boxes() = box(-80.0, 46.75, -79.99, 46.76, 0, 10, 99);
  *request.add_boxes() = box(-121.765, 46.848, -121.755, 46.856, 4300, 4500, 17);  // a duplicate id is fine
  std::vector<v1::TraceResponse> messages;
  const grpc::Status s = run(request, &messages);
  ASSERT_TRUE(s.ok()) << s.error_message();
  ASSERT_EQ(messages.size(), 1u);  // no channels: the header alone
  const v1::TraceHeader& h = messages.front().header();
  ASSERT_EQ(h.boxes_size(), 4);
  EXPECT_EQ(h.boxes(0).id(), 17u);
  EXPECT_EQ(h.boxes(1).id(), 23u);
  EXPECT_EQ(h.boxes(2).id(), 99u);
  EXPECT_EQ(h.boxes(3).id(), 17u);

  trace::TraceQuery query;
  query.camera = rainier_spec();
  query.options.threads = 1;
  for (const v1::Box& b : request.boxes())
    query.boxes.push_back(
        {geodesy::PointFrame::kWgs84, b.x_min(), b.y_min(), b.x_max(), b.y_max(), b.z_min(), b.z_max()});
  const trace::TraceRun engine = engine_run(query);
  for (int i = 0; i < 4; ++i) {
    EXPECT_EQ(h.boxes(i).pixels(), engine.boxes[static_cast<std::size_t>(i)].pixels) << i;
    EXPECT_EQ(h.boxes(i).visible_pixels(), engine.boxes[static_cast<std::size_t>(i)].visible) << i;
  }
  EXPECT_GT(h.boxes(0).visible_pixels(), h.boxes(0).pixels() / 2);
  EXPECT_GT(h.boxes(1).pixels(), 0u);
  EXPECT_EQ(h.boxes(1).visible_pixels(), 0u);
  EXPECT_EQ(h.boxes(2).pixels(), 0u);
  EXPECT_NE(last_log_line().find("\"boxes\":4"), std::string::npos) << last_log_line();
}

// A wall raised across the view hides the summit box, in that request only:
// the next request, through the same block cache, sees the terrain as it is.
TEST_F(ServerTrace, EditsChangeTheirRequestOnly) {
  v1::TraceRequest request = rainier_frame();
  *request.add_boxes() = box(-121.765, 46.848, -121.755, 46.856, 4300, 4500, 1);
  std::vector<v1::TraceResponse> before, walled, by_cells, after;
  ASSERT_TRUE(run(request, &before).ok());
  ASSERT_GT(before.front().header().boxes(0).visible_pixels(), 0u);

  v1::TraceRequest wall = request;
  v1::HeightEdit& e = *wall.add_edits();
  e.mutable_rect()->set_x_min(-121.89);
  e.mutable_rect()->set_y_min(46.72);
  e.mutable_rect()->set_x_max(-121.86);
  e.mutable_rect()->set_y_max(46.73);
  e.set_mode(v1::EDIT_MODE_RAISE);
  e.add_heights(3000);
  grpc::Status s = run(wall, &walled);
  ASSERT_TRUE(s.ok()) << s.error_message();
  const v1::TraceHeader& w = walled.front().header();
  EXPECT_EQ(w.boxes(0).visible_pixels(), 0u);
  EXPECT_GT(w.edited_cells(), 10u);
  EXPECT_EQ(w.stats().crossings(), before.front().header().stats().crossings());  // nothing rebuilt

  // The same cells as a grid window, set to one height a cell.
  const terrain::GeoTransform t{-121.92708333333333, 1.0 / 1200, 47.000416666666666, -1.0 / 1200};
  const int c0 = static_cast<int>(std::ceil(t.col_at(-121.89))),
            c1 = static_cast<int>(std::floor(t.col_at(-121.86))) + 1;
  const int r0 = static_cast<int>(std::ceil(t.row_at(46.73))), r1 = static_cast<int>(std::floor(t.row_at(46.72))) + 1;
  v1::TraceRequest cells = request;
  v1::HeightEdit& ce = *cells.add_edits();
  ce.mutable_cells()->set_col0(c0);
  ce.mutable_cells()->set_row0(r0);
  ce.mutable_cells()->set_col1(c1);
  ce.mutable_cells()->set_row1(r1);
  for (int i = 0; i < (c1 - c0) * (r1 - r0); ++i) ce.add_heights(5000.0f + static_cast<float>(i % 7));
  s = run(cells, &by_cells);
  ASSERT_TRUE(s.ok()) << s.error_message();
  EXPECT_EQ(by_cells.front().header().edited_cells(), static_cast<std::uint64_t>((c1 - c0) * (r1 - r0)));
  EXPECT_EQ(by_cells.front().header().boxes(0).visible_pixels(), 0u);

  ASSERT_TRUE(run(request, &after).ok());
  EXPECT_EQ(after.front().header().boxes(0).visible_pixels(), before.front().header().boxes(0).visible_pixels());
  EXPECT_EQ(after.front().header().stats().sky_pixels(), before.front().header().stats().sky_pixels());
  EXPECT_EQ(after.front().header().edited_cells(), 0u);
}

TEST_F(ServerTrace, WrongFieldsAreRefusedNamingThem) {
  struct Case {
    std::function<void(v1::TraceRequest&)> edit;
    grpc::StatusCode code;
    std::string field;
  };
  const auto edit_rect = [](v1::TraceRequest& r, double x0, double y0, double x1, double y1) {
    v1::HeightEdit& e = *r.add_edits();
    e.mutable_rect()->set_x_min(x0);
    e.mutable_rect()->set_y_min(y0);
    e.mutable_rect()->set_x_max(x1);
    e.mutable_rect()->set_y_max(y1);
    e.add_heights(10);
  };
  const auto edit_cells = [](v1::TraceRequest& r, int c0, int r0, int c1, int r1, int heights) {
    v1::HeightEdit& e = *r.add_edits();
    e.mutable_cells()->set_col0(c0);
    e.mutable_cells()->set_row0(r0);
    e.mutable_cells()->set_col1(c1);
    e.mutable_cells()->set_row1(r1);
    for (int i = 0; i < heights; ++i) e.add_heights(1.0f);
  };
  using grpc::StatusCode;
  const Case cases[] = {
      {[](v1::TraceRequest& r) { r.clear_camera(); }, StatusCode::INVALID_ARGUMENT, "camera"},
      {[](v1::TraceRequest& r) { r.mutable_camera()->clear_position(); }, StatusCode::INVALID_ARGUMENT,
       "camera.position"},
      {[](v1::TraceRequest& r) { r.mutable_camera()->set_hfov(175); }, StatusCode::INVALID_ARGUMENT, "camera.hfov"},
      {[](v1::TraceRequest& r) { r.mutable_camera()->set_hfov(0); }, StatusCode::INVALID_ARGUMENT, "camera.hfov"},
      {[](v1::TraceRequest& r) { r.mutable_camera()->set_width(0); }, StatusCode::INVALID_ARGUMENT, "camera.width"},
      {[](v1::TraceRequest& r) { r.mutable_camera()->set_height(9000); }, StatusCode::INVALID_ARGUMENT,
       "camera.height"},
      {[](v1::TraceRequest& r) { r.mutable_camera()->set_pitch(85); }, StatusCode::INVALID_ARGUMENT, "camera.pitch"},
      {[](v1::TraceRequest& r) { r.mutable_camera()->set_yaw(NAN); }, StatusCode::INVALID_ARGUMENT, "camera.yaw"},
      {[](v1::TraceRequest& r) { r.mutable_camera()->set_projection(static_cast<v1::Projection>(9)); },
       StatusCode::INVALID_ARGUMENT, "camera.projection"},
      {[](v1::TraceRequest& r) { r.mutable_camera()->mutable_position()->set_height(-1); },
       StatusCode::INVALID_ARGUMENT, "camera.position.height"},
      {[](v1::TraceRequest& r) { r.mutable_camera()->mutable_position()->set_y(95); }, StatusCode::INVALID_ARGUMENT,
       "camera.position.y"},
      {[](v1::TraceRequest& r) { r.mutable_camera()->mutable_position()->set_x(-100); }, StatusCode::OUT_OF_RANGE,
       "camera.position"},
      {[](v1::TraceRequest& r) { r.set_dataset("atlantis"); }, StatusCode::NOT_FOUND, ""},
      {[](v1::TraceRequest& r) { r.set_dataset(""); }, StatusCode::INVALID_ARGUMENT, "dataset"},
      {[](v1::TraceRequest& r) { r.mutable_options()->set_near(-1); }, StatusCode::INVALID_ARGUMENT, "options.near"},
      {[](v1::TraceRequest& r) { r.mutable_options()->set_max_distance(0); }, StatusCode::INVALID_ARGUMENT,
       "options.max_distance"},
      {[](v1::TraceRequest& r) { r.mutable_options()->set_curvature(3); }, StatusCode::INVALID_ARGUMENT,
       "options.curvature"},
      {[](v1::TraceRequest& r) { r.mutable_options()->set_nodata(static_cast<v1::NodataPolicy>(7)); },
       StatusCode::INVALID_ARGUMENT, "options.nodata"},
      {[](v1::TraceRequest& r) { r.mutable_options()->set_backend(static_cast<v1::Backend>(7)); },
       StatusCode::INVALID_ARGUMENT, "options.backend"},
      {[](v1::TraceRequest& r) { *r.add_boxes() = box(-121.8, 46.8, -121.79, 46.81, 2000, 1000, 3); },
       StatusCode::INVALID_ARGUMENT, "boxes[0].z_max"},
      {[](v1::TraceRequest& r) {
         *r.add_boxes() = box(-121.8, 46.8, -121.79, 46.81, 1000, 2000, 3);
         r.mutable_boxes(0)->set_frame(static_cast<v1::Frame>(5));
       },
       StatusCode::INVALID_ARGUMENT, "boxes[0].frame"},
      {[&](v1::TraceRequest& r) { edit_rect(r, -100.0, 46.8, -99.9, 46.9); }, StatusCode::OUT_OF_RANGE,
       "edits[0].rect"},
      {[&](v1::TraceRequest& r) { edit_rect(r, -121.8, 46.8, -121.9, 46.9); }, StatusCode::INVALID_ARGUMENT,
       "edits[0].rect.x_max"},
      {[&](v1::TraceRequest& r) { edit_rect(r, -121.8, NAN, -121.7, 46.9); }, StatusCode::INVALID_ARGUMENT,
       "edits[0].rect.y_min"},
      {[&](v1::TraceRequest& r) {
         edit_cells(r, 0, 0, 2, 2, 1);
         edit_cells(r, 390, 390, 401, 395, 1);
       },
       StatusCode::OUT_OF_RANGE, "edits[1].cells"},
      {[&](v1::TraceRequest& r) { edit_cells(r, 10, 10, 12, 12, 3); }, StatusCode::INVALID_ARGUMENT,
       "edits[0].heights"},
      {[&](v1::TraceRequest& r) { edit_cells(r, 10, 10, 12, 12, 0); }, StatusCode::INVALID_ARGUMENT,
       "edits[0].heights"},
      {[](v1::TraceRequest& r) { r.add_edits()->add_heights(1); }, StatusCode::INVALID_ARGUMENT, "edits[0].rect"},
      {[&](v1::TraceRequest& r) {
         edit_cells(r, 10, 10, 12, 12, 1);
         r.mutable_edits(0)->set_mode(static_cast<v1::EditMode>(8));
       },
       StatusCode::INVALID_ARGUMENT, "edits[0].mode"},
      {[](v1::TraceRequest& r) {
         r.add_channels(v1::TRACE_CHANNEL_DEPTH);
         r.add_channels(v1::TRACE_CHANNEL_DEPTH);
       },
       StatusCode::INVALID_ARGUMENT, "channels[1]"},
      {[](v1::TraceRequest& r) { r.add_channels(v1::TRACE_CHANNEL_UNSPECIFIED); }, StatusCode::INVALID_ARGUMENT,
       "channels[0]"},
      {[](v1::TraceRequest& r) { r.add_channels(static_cast<v1::TraceChannel>(42)); }, StatusCode::INVALID_ARGUMENT,
       "channels[0]"},
      {[](v1::TraceRequest& r) { r.set_max_chunk_bytes(-1); }, StatusCode::INVALID_ARGUMENT, "max_chunk_bytes"},
  };
  const double asked = blocks_asked();
  for (const Case& c : cases) {
    v1::TraceRequest request = rainier_frame();
    c.edit(request);
    const grpc::Status s = run(request);
    EXPECT_EQ(s.error_code(), c.code) << c.field << ": " << s.error_message();
    EXPECT_EQ(violated_field(s), c.field) << s.error_message();
    // The message names the field too.
    EXPECT_NE(s.error_message().find(c.field), std::string::npos) << s.error_message();
  }
  EXPECT_EQ(blocks_asked(), asked) << "a refused request read blocks";
  // Refusals are the client's: warnings, never the daemon's errors.
  EXPECT_EQ(daemon_->log().find("\"level\":\"error\""), std::string::npos) << daemon_->log();
}

// Every limit is checked from the request and the plan, before a block is
// read; the refusal names the parameter, what it would cost and the limit.
TEST_F(ServerTrace, PastALimitIsRefusedBeforeAnyWork) {
  struct Case {
    std::function<void(v1::TraceRequest&)> edit;
    std::string field;
    std::vector<std::string> says;
  };
  const Case cases[] = {
      // 2049 x 2048 pixels, one past limits.max_trace_pixels.
      {[](v1::TraceRequest& r) {
         r.mutable_camera()->set_width(2049);
         r.mutable_camera()->set_height(2048);
       },
       "camera",
       {"4196352 pixels", "limits.max_trace_pixels = 4194304"}},
      // Within the pixel limit, but every channel of 4 M pixels: hundreds of MiB.
      {[](v1::TraceRequest& r) {
         r.mutable_camera()->set_width(2048);
         r.mutable_camera()->set_height(2048);
         for (int c = 1; c <= 4; ++c) r.add_channels(static_cast<v1::TraceChannel>(c));
         r.set_include_footprint(true);
       },
       "memory_budget_mb",
       {"this trace (2048x2048 pixels", "MiB of working memory"}},
      // A panorama over all 4 M cells of "big", past limits.max_cells.
      {[](v1::TraceRequest& r) {
         r.set_dataset("big");
         *r.mutable_camera()->mutable_position() = point(510000, 4990000, 10.0);
         r.mutable_camera()->set_projection(v1::PROJECTION_CYLINDRICAL);
         r.mutable_camera()->set_hfov(360);
       },
       "options.max_distance",
       {"4000000 cells", "limits.max_cells = 3000000"}},
      {[](v1::TraceRequest& r) {
         for (int i = 0; i < 101; ++i) *r.add_boxes() = box(-121.8, 46.8, -121.79, 46.81, 1000, 2000, 0);
       },
       "boxes",
       {"101 boxes", "limits.max_boxes = 100"}},
      // Five edits of all of "big": 20 M cells, past the engine's 16 M.
      {[](v1::TraceRequest& r) {
         r.set_dataset("big");
         *r.mutable_camera()->mutable_position() = point(510000, 4990000, 10.0);
         for (int i = 0; i < 5; ++i) {
           v1::HeightEdit& e = *r.add_edits();
           e.mutable_cells()->set_col1(2000);
           e.mutable_cells()->set_row1(2000);
           e.add_heights(0);
         }
       },
       "edits",
       {"cells or more, over the limit of 16777216"}},
  };
  const double asked = blocks_asked();
  for (const Case& c : cases) {
    v1::TraceRequest request = rainier_frame();
    c.edit(request);
    const grpc::Status s = run(request);
    EXPECT_EQ(s.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << c.field << ": " << s.error_message();
    EXPECT_EQ(violated_field(s), c.field) << s.error_message();
    for (const std::string& text : c.says)
      EXPECT_NE(s.error_message().find(text), std::string::npos) << s.error_message();
    EXPECT_NE(last_log_line().find("RESOURCE_EXHAUSTED"), std::string::npos) << last_log_line();
  }
  EXPECT_EQ(blocks_asked(), asked) << "a refused request read blocks";
  // Nothing is left reserved, and the daemon answers as before.
  EXPECT_TRUE(daemon_->memory_returned()) << daemon_->metrics();
  EXPECT_TRUE(run(rainier_frame()).ok());
}

// BACKEND_GPU borrows one of the daemon's GL contexts for the frame: on
// Mesa's llvmpipe every pixel is the CPU's, bit for bit (trace.hpp). A
// daemon without a context answers on the CPU and says why.
TEST_F(ServerTrace, TheGpuBackendAnswersAsTheCpu) {
  v1::TraceRequest request = rainier_frame();
  request.add_channels(v1::TRACE_CHANNEL_DEPTH);
  request.mutable_options()->set_backend(v1::BACKEND_CPU);
  std::vector<v1::TraceResponse> cpu, gpu;
  ASSERT_TRUE(run(request, &cpu).ok());
  request.mutable_options()->set_backend(v1::BACKEND_GPU);
  const grpc::Status s = run(request, &gpu);
  ASSERT_TRUE(s.ok()) << s.error_message();
  const v1::TraceStats& st = gpu.front().header().stats();
  EXPECT_EQ(cpu.front().header().stats().backend(), "cpu");
  if (st.backend() != "gpu") {
    EXPECT_FALSE(st.gpu_fallback().empty());
    EXPECT_NE(last_log_line().find("\"level\":\"warn\""), std::string::npos) << last_log_line();
    GTEST_SKIP() << "no GPU context answered: " << st.gpu_fallback();
  }
  EXPECT_TRUE(st.gpu_fallback().empty()) << st.gpu_fallback();
  EXPECT_NE(last_log_line().find("\"backend\":\"gpu\""), std::string::npos) << last_log_line();
  std::string a, b;
  for (const auto& m : cpu)
    if (m.has_rows()) a += m.rows().data();
  for (const auto& m : gpu)
    if (m.has_rows()) b += m.rows().data();
  ASSERT_EQ(a.size(), 320u * 180u * 4u);
  EXPECT_TRUE(a == b) << "the GPU's depth differs from the CPU's";
  EXPECT_EQ(st.sky_pixels(), cpu.front().header().stats().sky_pixels());
}

TEST_F(ServerTrace, DeadlinesAndCancelsEndTheCall) {
  // A frame whose rows (46 MB in 4 KiB messages) take far longer to send
  // than the deadline a client reading them gave: the call ends at it.
  v1::TraceRequest request = rainier_frame(1200, 1200);
  for (v1::TraceChannel c : {v1::TRACE_CHANNEL_DEPTH, v1::TRACE_CHANNEL_HIT_CELL, v1::TRACE_CHANNEL_HIT_XYZ})
    request.add_channels(c);
  request.set_max_chunk_bytes(4096);
  std::vector<v1::TraceResponse> read;
  EXPECT_EQ(run(request, &read, std::chrono::milliseconds(50)).error_code(), grpc::StatusCode::DEADLINE_EXCEEDED);
  EXPECT_LT(read.size(), 3601u);  // the header and 1 200 rows a channel
  ASSERT_TRUE(daemon_->wait_for_log("\"status\":\"DEADLINE_EXCEEDED\"", std::chrono::seconds(15))) << daemon_->log();
  EXPECT_NE(last_log_line().find("\"dataset\":\"rainier\""), std::string::npos) << last_log_line();

  // A deadline gone before the call is admitted takes no slot.
  EXPECT_EQ(run(rainier_frame(), nullptr, std::chrono::milliseconds(0)).error_code(),
            grpc::StatusCode::DEADLINE_EXCEEDED);

  // The client cancels after the first rows.
  grpc::ClientContext context;
  auto reader = stub_->TraceCamera(&context, request);
  v1::TraceResponse message;
  ASSERT_TRUE(reader->Read(&message));
  ASSERT_TRUE(message.has_header());
  ASSERT_TRUE(reader->Read(&message));
  ASSERT_TRUE(message.has_rows());
  context.TryCancel();
  while (reader->Read(&message)) {
  }
  EXPECT_EQ(reader->Finish().error_code(), grpc::StatusCode::CANCELLED);
  ASSERT_TRUE(daemon_->wait_for_log("\"status\":\"CANCELLED\"", std::chrono::seconds(15))) << daemon_->log();
  EXPECT_NE(last_log_line().find("CANCELLED"), std::string::npos) << last_log_line();

  // Nothing is held afterwards, and the daemon answers as before.
  EXPECT_TRUE(daemon_->memory_returned()) << daemon_->metrics();
  EXPECT_TRUE(run(rainier_frame()).ok());
}

}  // namespace
}  // namespace horizon::testing
