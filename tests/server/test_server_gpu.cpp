// The daemon's GPU backend through its gRPC API: config "gpu" opens the
// contexts at start, a fast viewshed asked for on the GPU runs there (Mesa's
// llvmpipe on a machine without one) and equals the CPU's answer, GPU with
// another algorithm is refused naming options.backend, a daemon without
// contexts answers on the CPU and says why (response, log line, metrics), and
// `horizon viewshed --server` carries the backend flags both ways; a
// session asked for on the GPU traces there and answers as a CPU session.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <iostream>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "daemon_process.hpp"
#include "horizon/v1/session.grpc.pb.h"
#include "horizon/visibility/viewshed.hpp"
#include "rpc_helpers.hpp"

namespace horizon::testing {
namespace {

using Json = nlohmann::json;

// Rainier (EPSG:4326, 3" cells): a viewpoint near the summit.
constexpr double kRainierLon = -121.7604, kRainierLat = 46.8529;

struct Viewshed {
  grpc::Status status;
  v1::ViewshedHeader header;
  v1::ViewshedSummary summary;
  std::string raster;  // uint8: 1 visible, 0 hidden, 255 no answer
};

// Two daemons holding Rainier, each started when a test first needs it and
// shared by the rest (starting and stopping one takes ~2 s): one with a GL
// context, one with the GPU turned off.
class ServerGpu : public ::testing::Test {
 protected:
  static void TearDownTestSuite() {
    delete gpu_;
    delete cpu_only_;
    gpu_ = cpu_only_ = nullptr;
  }
  static DaemonProcess& daemon(DaemonProcess*& slot, const std::string& gpu_json) {
    if (!slot) {
      DaemonOptions o;
      o.datasets = {{"rainier", "rainier_summit_srtm3_400x400.tif"}};
      o.extra_json = gpu_json + R"( "engine_threads": 1,)";
      slot = new DaemonProcess(o);
    }
    EXPECT_TRUE(slot->ready()) << slot->error();
    return *slot;
  }
  static DaemonProcess& with_gpu() { return daemon(gpu_, R"("gpu": {"contexts": 1},)"); }
  static DaemonProcess& cpu_only() { return daemon(cpu_only_, R"("gpu": {"contexts": 0},)"); }

  static v1::ViewshedRequest rainier(v1::Backend backend, v1::Algorithm algorithm = v1::ALGORITHM_FAST) {
    v1::ViewshedRequest r;
    r.set_dataset("rainier");
    *r.mutable_observer() = point(kRainierLon, kRainierLat, 2.0, v1::FRAME_WGS84);
    r.mutable_options()->set_max_distance(6000);
    r.mutable_options()->set_algorithm(algorithm);
    r.mutable_options()->set_backend(backend);
    r.set_include_raster(true);
    return r;
  }

  static Viewshed run(const DaemonProcess& daemon, const v1::ViewshedRequest& request) {
    Viewshed out;
    auto stub = v1::VisibilityService::NewStub(daemon.channel());
    auto context = context_with_deadline();
    auto reader = stub->ComputeViewshed(context.get(), request);
    v1::ViewshedResponse message;
    while (reader->Read(&message)) {
      if (message.has_header()) out.header = message.header();
      if (message.has_raster_chunk()) out.raster += message.raster_chunk().data();
      if (message.has_summary()) out.summary = message.summary();
    }
    out.status = reader->Finish();
    return out;
  }

  static DaemonProcess* gpu_;       // with_gpu()
  static DaemonProcess* cpu_only_;  // cpu_only()
};
DaemonProcess* ServerGpu::gpu_ = nullptr;
DaemonProcess* ServerGpu::cpu_only_ = nullptr;

TEST_F(ServerGpu, StartsWithTheContextsItWasGiven) {
  const std::string log = with_gpu().log();
  EXPECT_NE(log.find("\"event\":\"gpu_ready\""), std::string::npos) << log;
  EXPECT_NE(log.find("\"contexts\":1"), std::string::npos) << log;
  EXPECT_EQ(cpu_only().log().find("\"event\":\"gpu_"), std::string::npos) << cpu_only().log();
}

TEST_F(ServerGpu, FastOnTheGpuEqualsTheCpuAndIsCounted) {
  const std::string before = with_gpu().metrics();
  const Viewshed gpu = run(with_gpu(), rainier(v1::BACKEND_GPU));
  ASSERT_TRUE(gpu.status.ok()) << gpu.status.error_message();
  EXPECT_EQ(gpu.summary.stats().backend(), "gpu");
  EXPECT_EQ(gpu.summary.stats().gpu_fallback(), "");
  EXPECT_EQ(gpu.header.backend(), "gpu");
  const Viewshed cpu = run(with_gpu(), rainier(v1::BACKEND_CPU));
  ASSERT_TRUE(cpu.status.ok()) << cpu.status.error_message();
  EXPECT_EQ(cpu.summary.stats().backend(), "cpu");
  EXPECT_EQ(cpu.header.backend(), "cpu");

  // Same window and the same answers. llvmpipe rounds as the CPU does, so
  // the masks are identical there; a hardware GPU may round a few ties the
  // other way: IoU of the visible sets >= 99.9 %.
  ASSERT_EQ(gpu.header.width(), cpu.header.width());
  ASSERT_EQ(gpu.header.height(), cpu.header.height());
  ASSERT_EQ(gpu.raster.size(), cpu.raster.size());
  ASSERT_EQ(gpu.raster.size(), static_cast<std::size_t>(cpu.header.width()) * cpu.header.height());
  std::uint64_t both = 0, either = 0, answered_differently = 0;
  for (std::size_t i = 0; i < cpu.raster.size(); ++i) {
    const auto g = static_cast<std::uint8_t>(gpu.raster[i]), c = static_cast<std::uint8_t>(cpu.raster[i]);
    both += g == visibility::kVisible && c == visibility::kVisible;
    either += g == visibility::kVisible || c == visibility::kVisible;
    answered_differently += (g == visibility::kNoAnswer) != (c == visibility::kNoAnswer);
  }
  EXPECT_EQ(answered_differently, 0u);
  ASSERT_GT(either, 0u);
  EXPECT_GE(static_cast<double>(both) / static_cast<double>(either), 0.999) << both << " of " << either;
  EXPECT_EQ(gpu.summary.evaluated_cells(), cpu.summary.evaluated_cells());
  if (with_gpu().log().find("\"software\":true") != std::string::npos) {
    EXPECT_TRUE(gpu.raster == cpu.raster) << "llvmpipe: " << both << " cells visible to both of " << either;
  }

  const auto lines = with_gpu().request_lines();
  ASSERT_GE(lines.size(), 2u);
  const std::string& gpu_line = lines[lines.size() - 2];
  EXPECT_NE(gpu_line.find("\"level\":\"info\""), std::string::npos) << gpu_line;
  EXPECT_NE(gpu_line.find("\"backend\":\"gpu\",\"gpu_fallback\":\"\""), std::string::npos) << gpu_line;
  EXPECT_NE(lines.back().find("\"backend\":\"cpu\",\"gpu_fallback\":\"\""), std::string::npos) << lines.back();
  const std::string after = with_gpu().metrics();
  const std::string on_gpu = R"(horizon_backend_requests_total{backend="gpu"})";
  const std::string on_cpu = R"(horizon_backend_requests_total{backend="cpu"})";
  EXPECT_EQ(metric(after, on_gpu) - metric(before, on_gpu), 1.0) << after;
  EXPECT_EQ(metric(after, on_cpu) - metric(before, on_cpu), 1.0) << after;
  EXPECT_EQ(metric(after, "horizon_gpu_fallbacks_total"), 0.0) << after;
}

TEST_F(ServerGpu, GpuWithAnotherAlgorithmOrAnUnknownValueNamesTheField) {
  const Viewshed exact = run(with_gpu(), rainier(v1::BACKEND_GPU, v1::ALGORITHM_EXACT));
  EXPECT_EQ(exact.status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << exact.status.error_message();
  EXPECT_EQ(violated_field(exact.status), "options.backend") << exact.status.error_message();

  const Viewshed unknown = run(with_gpu(), rainier(static_cast<v1::Backend>(7)));
  EXPECT_EQ(unknown.status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(violated_field(unknown.status), "options.backend") << unknown.status.error_message();

  v1::ViewshedRequest method = rainier(v1::BACKEND_GPU);
  method.mutable_options()->set_gpu_method(static_cast<v1::GpuMethod>(9));
  const Viewshed bad_method = run(with_gpu(), method);
  EXPECT_EQ(bad_method.status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(violated_field(bad_method.status), "options.gpu_method") << bad_method.status.error_message();
}

TEST_F(ServerGpu, WithoutContextsTheCpuAnswersAndSaysWhy) {
  const std::string before = cpu_only().metrics();
  v1::ViewshedRequest request = rainier(v1::BACKEND_GPU);
  request.mutable_options()->set_gpu_method(v1::GPU_METHOD_COMPUTE);
  request.mutable_options()->set_gpu_log_step(false);
  const Viewshed answer = run(cpu_only(), request);
  ASSERT_TRUE(answer.status.ok()) << answer.status.error_message();
  EXPECT_EQ(answer.summary.stats().backend(), "cpu");
  EXPECT_FALSE(answer.summary.stats().gpu_fallback().empty());
  EXPECT_EQ(answer.header.backend(), "cpu");
  EXPECT_GT(answer.summary.visible_cells(), 0u);

  const auto lines = cpu_only().request_lines();
  ASSERT_FALSE(lines.empty());
  EXPECT_NE(lines.back().find("\"level\":\"warn\""), std::string::npos) << lines.back();
  EXPECT_NE(lines.back().find("\"gpu_fallback\":\"" + answer.summary.stats().gpu_fallback() + "\""), std::string::npos)
      << lines.back();
  EXPECT_NE(lines.back().find("\"status\":\"OK\""), std::string::npos) << lines.back();
  const std::string after = cpu_only().metrics();
  EXPECT_EQ(metric(after, "horizon_gpu_fallbacks_total") - metric(before, "horizon_gpu_fallbacks_total"), 1.0) << after;
  const std::string on_cpu = R"(horizon_backend_requests_total{backend="cpu"})";
  EXPECT_EQ(metric(after, on_cpu) - metric(before, on_cpu), 1.0) << after;
}

// On llvmpipe the GL images are the daemon's memory, inside memory_budget_mb:
// a GPU viewshed whose images do not fit what the budget leaves (64 MB: the
// 48 MiB base, 11 MiB of receive buffers and 2 MiB of cache leave 3 MiB;
// ray disks at ray_spacing 0.02 need about 12 MiB) is answered on the CPU and says
// why; one that fits runs on the GPU, and the images its context keeps stay
// counted as reserved (horizon_gpu_image_bytes) until freed.
TEST(ServerGpuMemory, GlImagesAreTakenFromTheBudget) {
  DaemonOptions o;
  o.datasets = {{"rainier", "rainier_summit_srtm3_400x400.tif"}};
  o.memory_budget_mb = 64;
  o.extra_json = R"("gpu": {"contexts": 1}, "engine_threads": 1,)";
  DaemonProcess daemon(o);
  ASSERT_TRUE(daemon.ready()) << daemon.error();
  if (daemon.log().find("\"software\":true") == std::string::npos)
    GTEST_SKIP() << "a hardware GPU's images are its own memory: no gate";
  auto stub = v1::VisibilityService::NewStub(daemon.channel());
  auto viewshed = [&](double max_distance, double ray_spacing, v1::ViewshedSummary& summary) {
    v1::ViewshedRequest r;
    r.set_dataset("rainier");
    *r.mutable_observer() = point(kRainierLon, kRainierLat, 2.0, v1::FRAME_WGS84);
    r.mutable_options()->set_max_distance(max_distance);
    r.mutable_options()->set_ray_spacing(ray_spacing);
    r.mutable_options()->set_backend(v1::BACKEND_GPU);
    auto context = context_with_deadline();
    auto reader = stub->ComputeViewshed(context.get(), r);
    v1::ViewshedResponse message;
    while (reader->Read(&message))
      if (message.has_summary()) summary = message.summary();
    return reader->Finish();
  };

  v1::ViewshedSummary refused;
  ASSERT_TRUE(viewshed(3000, 0.02, refused).ok());
  EXPECT_EQ(refused.stats().backend(), "cpu");
  EXPECT_NE(refused.stats().gpu_fallback().find("MiB of GL images, more than the memory budget leaves"),
            std::string::npos)
      << refused.stats().gpu_fallback();
  EXPECT_GT(refused.visible_cells(), 0u);
  EXPECT_EQ(metric(daemon.metrics(), "horizon_gpu_image_bytes"), 0.0);
  std::cout << "refused: " << refused.stats().gpu_fallback() << '\n';

  v1::ViewshedSummary fits;
  ASSERT_TRUE(viewshed(1500, 1.0, fits).ok());
  EXPECT_EQ(fits.stats().backend(), "gpu") << fits.stats().gpu_fallback();
  const double images = metric(daemon.metrics(), "horizon_gpu_image_bytes");
  EXPECT_GT(images, 0.0);
  EXPECT_LT(images, 3u << 20);
  EXPECT_TRUE(daemon.memory_returned()) << daemon.metrics();
}

// `horizon viewshed --server` sends the backend flags and reports where the
// daemon computed, warning when its GPU could not answer.
TEST_F(ServerGpu, CliSendsTheBackendAndReportsTheFallback) {
  TempDir dir;
  const auto horizon = [&](const DaemonProcess& daemon, const std::string& flags) {
    return run_command(std::string(HORIZON_CLI_PATH) + " viewshed rainier --server " + daemon.address() +
                       " --lat 46.8529 --lon -121.7604 --max-distance 3000 --json -o " + dir.file("v.tif") + flags);
  };
  // stderr is merged in: the document is the first '{' on.
  const auto json_of = [](const CommandResult& r) {
    const auto start = r.output.find('{');
    return start == std::string::npos ? Json() : Json::parse(r.output.substr(start), nullptr, false);
  };

  const auto gpu = horizon(with_gpu(), " --backend gpu --gpu-method compute --gpu-propagation one-step");
  ASSERT_EQ(gpu.exit_code, 0) << gpu.output;
  EXPECT_EQ(gpu.output.find("warning"), std::string::npos) << gpu.output;
  const Json j = json_of(gpu);
  EXPECT_EQ(j["stats"]["backend"], "gpu") << gpu.output;
  EXPECT_TRUE(j["stats"]["gpu_fallback"].is_null()) << gpu.output;
  EXPECT_EQ(j["options"]["gpu_method"], "compute");
  EXPECT_EQ(j["options"]["gpu_propagation"], "one-step");
  EXPECT_NE(with_gpu().request_lines().back().find("\"backend\":\"gpu\""), std::string::npos);

  const auto exact = horizon(with_gpu(), " --backend gpu --algorithm exact");
  EXPECT_EQ(exact.exit_code, 2) << exact.output;  // refused before any call
  EXPECT_NE(exact.output.find("--backend"), std::string::npos) << exact.output;

  const auto cpu = horizon(cpu_only(), " --backend gpu");
  ASSERT_EQ(cpu.exit_code, 0) << cpu.output;
  EXPECT_NE(cpu.output.find("horizon: warning: GPU failed ("), std::string::npos) << cpu.output;
  EXPECT_NE(cpu.output.find("); answered on the CPU"), std::string::npos) << cpu.output;
  const Json k = json_of(cpu);
  EXPECT_EQ(k["stats"]["backend"], "cpu") << cpu.output;
  EXPECT_FALSE(k["stats"]["gpu_fallback"].is_null()) << cpu.output;
}

// 300 boxes along a diagonal over the summit, ids 1..300.
std::vector<v1::SessionBox> session_boxes() {
  std::vector<v1::SessionBox> out(300);
  for (int i = 0; i < 300; ++i) {
    out[static_cast<std::size_t>(i)].set_id(static_cast<std::uint64_t>(i + 1));
    v1::Box* box = out[static_cast<std::size_t>(i)].mutable_box();
    box->set_frame(v1::FRAME_WGS84);
    const double x = -121.91 + 0.001 * i, y = 46.70 + 0.00093 * i;
    box->set_x_min(x);
    box->set_x_max(x + 0.0015);
    box->set_y_min(y);
    box->set_y_max(y + 0.001);
    box->set_z_min(0.0);
    box->set_z_max(1500.0 + 9.0 * i);
  }
  return out;
}

// A flight of 12 poses east across the summit with session_boxes(); every answer.
std::vector<v1::PoseAnswer> fly(const DaemonProcess& daemon, v1::Backend backend, v1::SessionMode mode,
                                grpc::Status& status) {
  auto stub = v1::SessionService::NewStub(daemon.channel());
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(60));
  auto stream = stub->Session(&context);
  auto pose = [](int i) {
    v1::Pose p;
    *p.mutable_position() = point(-121.86 + 0.01 * i, kRainierLat, 3500.0, v1::FRAME_WGS84);
    p.mutable_position()->set_height_mode(v1::HEIGHT_MODE_ABSOLUTE);
    p.set_east_m_per_s(250.0);
    p.set_seq(static_cast<std::uint64_t>(i + 1));
    return p;
  };
  v1::SessionRequest open;
  v1::OpenSession* o = open.mutable_open();
  o->set_dataset("rainier");
  o->mutable_clipmap()->set_level_size(64);
  o->mutable_clipmap()->set_subtile(16);
  o->set_mode(mode);
  o->set_rays(512);
  o->set_backend(backend);
  *o->mutable_first_pose() = pose(0);
  for (const v1::SessionBox& b : session_boxes()) *o->add_boxes() = b;
  std::vector<v1::PoseAnswer> answers;
  EXPECT_TRUE(stream->Write(open));
  v1::SessionResponse r;
  // Each pose after the last answer: none is dropped, so both flights answer the same poses.
  for (int i = 1; i <= 12 && stream->Read(&r); ++i) {
    if (r.has_opened() && !stream->Read(&r)) break;
    if (r.has_answer()) answers.push_back(r.answer());
    v1::SessionRequest next;
    *next.mutable_pose() = pose(i);
    if (i < 12) {
      EXPECT_TRUE(stream->Write(next));
    }
  }
  stream->WritesDone();
  while (stream->Read(&r))
    if (r.has_answer()) answers.push_back(r.answer());
  status = stream->Finish();
  return answers;
}

TEST_F(ServerGpu, ASessionOnTheGpuTracesThereAndNeverHidesWhatExactCullingSees) {
  grpc::Status gpu_status, fallback_status, exact_status;
  const auto gl = fly(with_gpu(), v1::BACKEND_GPU, v1::SESSION_MODE_CONSERVATIVE, gpu_status);
  ASSERT_TRUE(gpu_status.ok()) << gpu_status.error_message();
  ASSERT_EQ(gl.size(), 12u);
  // The client's picture, from the changes, against exact culling at each pose.
  auto stub = v1::VisibilityService::NewStub(with_gpu().channel());
  std::map<std::uint64_t, v1::BoxState> state;
  std::size_t hidden = 0, false_hidden = 0;
  for (std::size_t i = 0; i < gl.size(); ++i) {
    EXPECT_EQ(gl[i].backend(), "gpu") << gl[i].gpu_fallback();
    EXPECT_TRUE(gl[i].gpu_fallback().empty()) << gl[i].gpu_fallback();
    for (const v1::BoxChange& c : gl[i].changes()) state[c.id()] = c.state();
    v1::CullBoxesRequest request;
    request.set_dataset("rainier");
    *request.mutable_observer() = point(-121.86 + 0.01 * static_cast<double>(gl[i].seq() - 1), kRainierLat, 3500.0,
                                        v1::FRAME_WGS84);
    request.mutable_observer()->set_height_mode(v1::HEIGHT_MODE_ABSOLUTE);
    request.set_algorithm(v1::ALGORITHM_EXACT);
    for (const v1::SessionBox& b : session_boxes()) *request.add_boxes() = b.box();
    v1::CullBoxesResponse exact;
    auto context = context_with_deadline();
    ASSERT_TRUE(stub->CullBoxes(context.get(), request, &exact).ok());
    ASSERT_EQ(exact.boxes_size(), 300);
    for (int b = 0; b < 300; ++b) {
      const bool session_hidden = state[static_cast<std::uint64_t>(b + 1)] == v1::BOX_STATE_HIDDEN;
      hidden += session_hidden;
      false_hidden += session_hidden && exact.boxes(b).state() != v1::BOX_STATE_HIDDEN;
    }
  }
  EXPECT_EQ(false_hidden, 0u);
  EXPECT_GT(hidden, 0u) << "the flight must hide boxes to mean anything";
  // No contexts: the CPU answers, and says why.
  const auto fallback = fly(cpu_only(), v1::BACKEND_GPU, v1::SESSION_MODE_FAST, fallback_status);
  ASSERT_TRUE(fallback_status.ok()) << fallback_status.error_message();
  ASSERT_FALSE(fallback.empty());
  EXPECT_EQ(fallback[0].backend(), "cpu");
  EXPECT_FALSE(fallback[0].gpu_fallback().empty());
  // Exact sessions run on the CPU only.
  const auto exact = fly(with_gpu(), v1::BACKEND_GPU, v1::SESSION_MODE_EXACT, exact_status);
  EXPECT_EQ(exact_status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(exact_status.error_message().find("exact sessions run on the CPU"), std::string::npos)
      << exact_status.error_message();
  EXPECT_EQ(violated_field(exact_status), "open.backend");
}

}  // namespace
}  // namespace horizon::testing
