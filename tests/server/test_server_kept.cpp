// A worker's buffers kept from one call to the next are held in the memory
// budget (server/src/worker_memory.hpp): what they hold is on the books, the
// cap worker_kept_mb frees them past it, and nothing outside the budget
// stays behind a call.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <memory>
#include <string>

#include <grpcpp/create_channel.h>
#include <grpcpp/security/credentials.h>

#include "daemon_process.hpp"
#include "horizon/terrain/geotiff_writer.hpp"
#include "rpc_helpers.hpp"
#include "test_support.hpp"

namespace horizon::testing {
namespace {

// The bundled Ecuador DEM, 383 x 415 cells.
constexpr std::uint64_t kCells = 383ull * 415ull;

// The visible raster of the whole DEM: a mask-only run over the whole read
// window, which takes its read buffer over as its terrain.
v1::ViewshedRequest whole_dem_visible() {
  v1::ViewshedRequest request;
  request.set_dataset("ecuador");
  *request.mutable_observer() = point(713877.7, 9558936.7);
  request.set_raster(v1::RASTER_KIND_VISIBLE);
  request.set_include_raster(true);
  return request;
}

// Runs the request to its end; the status.
grpc::Status run(v1::VisibilityService::Stub& stub, const v1::ViewshedRequest& request) {
  auto context = context_with_deadline(std::chrono::seconds(30));
  auto reader = stub.ComputeViewshed(context.get(), request);
  v1::ViewshedResponse message;
  while (reader->Read(&message)) {
  }
  return reader->Finish();
}

DaemonOptions one_worker(const std::string& extra = "") {
  DaemonOptions options;
  options.datasets = {{"ecuador", "ecuador_andes_utm17s_10m_383x415.tif"}};
  options.worker_threads = 1;  // every call on the same worker, and its workspace
  options.extra_json = R"("engine_threads": 1, "gpu": {"contexts": 0},)" + extra;
  return options;
}

double kept(const DaemonProcess& daemon) {
  return metric(daemon.metrics(), "horizon_worker_kept_bytes");
}

// After the first call the worker keeps the terrain (the read buffer it took
// over, 4 bytes a cell), the mask (1) and the OHF raster that lent its
// memory to the sweep's transposed east and west lines (4); after the
// second also the terrain it displaced, as the next read buffer (4). The
// budget holds exactly that besides the cache and the receive buffers.
TEST(ServerKept, AWorkersKeptBuffersAreHeldInTheBudget) {
  DaemonProcess daemon(one_worker());
  ASSERT_TRUE(daemon.ready()) << daemon.error();
  auto stub = v1::VisibilityService::NewStub(daemon.channel());
  EXPECT_EQ(kept(daemon), 0);

  ASSERT_TRUE(run(*stub, whole_dem_visible()).ok());
  ASSERT_TRUE(daemon.memory_returned()) << daemon.metrics();
  EXPECT_EQ(kept(daemon), static_cast<double>(kCells * 9)) << daemon.metrics();

  ASSERT_TRUE(run(*stub, whole_dem_visible()).ok());
  ASSERT_TRUE(daemon.memory_returned()) << daemon.metrics();
  EXPECT_EQ(kept(daemon), static_cast<double>(kCells * 13)) << daemon.metrics();
  const std::string m = daemon.metrics();
  EXPECT_EQ(metric(m, "horizon_memory_reserved_bytes"), metric(m, "horizon_block_cache_budget_bytes") +
                                                            metric(m, "horizon_receive_buffer_bytes") +
                                                            static_cast<double>(kCells * 13));
}

// worker_kept_mb 1: a 600 m viewshed's buffers (a window of about 120 x 120
// cells, some 0.2 MB) stay; the whole DEM's (1.43 MB) would pass the cap, so
// the worker frees its buffers and holds nothing.
TEST(ServerKept, BuffersPastWorkerKeptMbAreFreed) {
  DaemonProcess daemon(one_worker(R"("worker_kept_mb": 1,)"));
  ASSERT_TRUE(daemon.ready()) << daemon.error();
  auto stub = v1::VisibilityService::NewStub(daemon.channel());
  v1::ViewshedRequest near = whole_dem_visible();
  near.mutable_options()->set_max_distance(600);
  ASSERT_TRUE(run(*stub, near).ok());
  ASSERT_TRUE(daemon.memory_returned()) << daemon.metrics();
  EXPECT_GT(kept(daemon), 0) << daemon.metrics();
  EXPECT_LE(kept(daemon), static_cast<double>(1 << 20)) << daemon.metrics();
  ASSERT_TRUE(run(*stub, whole_dem_visible()).ok());
  ASSERT_TRUE(daemon.memory_returned()) << daemon.metrics();
  EXPECT_EQ(kept(daemon), 0) << daemon.metrics();
}

// A 1000 x 1000 DEM on a 92 MiB budget: 48 MiB overhead, 11 MiB receive
// buffers and a 2 MiB cache leave 31 MiB for calls. A whole-DEM OHF raster
// needs about 12.5 MB of engine buffers and 16 MB of encodings.
class ServerKeptTight : public ::testing::Test {
 protected:
  void SetUp() override {
    const terrain::Dem dem =
        make_dem(1000, 1000, [](int c, int r) { return 500.0 + 80.0 * std::sin(c * 0.02 + r * 0.03); });
    ASSERT_TRUE(terrain::write_geotiff(data_.file("dem.tif"), dem.elevation, dem.georef, std::nullopt).ok());
    DaemonOptions options = one_worker(R"("block_cache_mb": 2, "worker_kept_mb": 92,)");
    options.data_root = data_.path().string();
    options.datasets = {{"dem", "dem.tif"}};
    options.memory_budget_mb = 92;
    daemon_ = std::make_unique<DaemonProcess>(options);
    ASSERT_TRUE(daemon_->ready()) << daemon_->error();
    stub_ = v1::VisibilityService::NewStub(daemon_->channel());
  }
  // The whole DEM's raster `kind`, as a GeoTIFF laid out as `cog` or not.
  v1::ViewshedRequest whole(v1::RasterKind kind, bool cog = false) const {
    v1::ViewshedRequest request;
    request.set_dataset("dem");
    *request.mutable_observer() = point(500000 + 5000.5, 5000000 - 5000.5);
    request.set_raster(kind);
    request.set_include_geotiff(true);
    if (cog) request.set_geotiff_format(v1::GEOTIFF_FORMAT_COG);
    return request;
  }
  // Runs `request`; the kept bytes after it.
  double call(const v1::ViewshedRequest& request) {
    const grpc::Status s = run(*stub_, request);
    EXPECT_TRUE(s.ok()) << s.error_message();
    EXPECT_TRUE(daemon_->memory_returned()) << daemon_->metrics();
    return kept(*daemon_);
  }

  TempDir data_;
  std::unique_ptr<DaemonProcess> daemon_;
  std::unique_ptr<v1::VisibilityService::Stub> stub_;
};

// The kept buffers serve the next run and are counted once: a second and a
// third whole-DEM run fit beside them (counted twice, kept and reserved
// again, 13 + 28.5 MB would not), and keep the read buffer, OHF, terrain and
// mask: 4 + 4 + 4 + 1 bytes a cell. The first run's terrain is its read
// buffer, taken over; the workspace's terrain raster, filled with the
// sweep's east and west lines meanwhile, becomes the next read buffer.
TEST_F(ServerKeptTight, KeptBuffersServeTheNextRunAndAreCountedOnce) {
  EXPECT_EQ(call(whole(v1::RASTER_KIND_OHF)), 13e6);
  EXPECT_EQ(call(whole(v1::RASTER_KIND_OHF)), 13e6);
  EXPECT_EQ(call(whole(v1::RASTER_KIND_OHF)), 13e6);
}

// A call the kept buffers would not leave room for, though it needs less
// than they hold, frees them and runs. A stream its client does not read
// holds its 16 MB of encodings after its engine is done, leaving 15 MiB; a
// 3 km viewshed (600 x 600 cells: ~4.5 MB of engine buffers and 5.8 MB of
// encodings) fits in them, but not beside the 13 MB kept. It keeps its own
// buffers instead.
TEST_F(ServerKeptTight, KeptBuffersNeverRefuseACallThatFitsWithoutThem) {
  call(whole(v1::RASTER_KIND_OHF));
  ASSERT_EQ(call(whole(v1::RASTER_KIND_OHF)), 13e6);

  // The stuck stream: a channel that takes 64 KiB ahead of what is read.
  grpc::ChannelArguments args;
  args.SetInt(GRPC_ARG_HTTP2_BDP_PROBE, 0);
  args.SetInt(GRPC_ARG_HTTP2_STREAM_LOOKAHEAD_BYTES, 64 << 10);
  auto slow = v1::VisibilityService::NewStub(
      grpc::CreateCustomChannel(daemon_->address(), grpc::InsecureChannelCredentials(), args));
  grpc::ClientContext stuck_context;
  v1::ViewshedRequest stuck_request = whole(v1::RASTER_KIND_OHF);
  stuck_request.set_include_raster(true);
  stuck_request.set_max_chunk_bytes(4096);
  auto stuck = slow->ComputeViewshed(&stuck_context, stuck_request);
  v1::ViewshedResponse header;
  ASSERT_TRUE(stuck->Read(&header) && header.has_header()) << "the stream's engine did not finish";
  ASSERT_TRUE(daemon_->wait_for_metrics(
      [](const std::string& m) { return metric(m, "horizon_worker_kept_bytes") == 13e6; }, std::chrono::seconds(5)))
      << daemon_->metrics();

  v1::ViewshedRequest near = whole(v1::RASTER_KIND_VISIBLE);
  near.mutable_options()->set_max_distance(3000);
  auto context = context_with_deadline(std::chrono::seconds(30));
  auto reader = stub_->ComputeViewshed(context.get(), near);
  v1::ViewshedResponse message;
  std::uint64_t cells = 0;
  while (reader->Read(&message))
    if (message.has_header()) cells = std::uint64_t{1} * message.header().width() * message.header().height();
  const grpc::Status s = reader->Finish();
  EXPECT_TRUE(s.ok()) << s.error_message();
  EXPECT_EQ(cells, 600u * 600u);
  // Its own buffers only: the terrain and mask of its window, the OHF
  // raster its sweep's east and west lines filled (a cell more each side),
  // and its (slightly larger) read window.
  EXPECT_GT(kept(*daemon_), static_cast<double>(cells * 13)) << daemon_->metrics();
  EXPECT_LT(kept(*daemon_), static_cast<double>(cells * 14)) << daemon_->metrics();

  stuck_context.TryCancel();
  while (stuck->Read(&message)) {
  }
  EXPECT_EQ(stuck->Finish().error_code(), grpc::StatusCode::CANCELLED);
  EXPECT_TRUE(daemon_->memory_returned()) << daemon_->metrics();
}

}  // namespace
}  // namespace horizon::testing
