// Clip-map sessions through a real horizond: a flight's answers, applied as
// changes, give a picture that never hides what exact culling sees; the
// session id travels in metadata; the latest pose wins when the client does
// not read; wrong poses and deltas are rejected in-stream; a wrong open ends
// the stream naming the field; sessions are limited in number and memory,
// expire when idle, and end with UNAVAILABLE when the daemon drains.
#include <gtest/gtest.h>

#include <csignal>
#include <map>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "daemon_process.hpp"
#include "horizon/v1/session.grpc.pb.h"
#include "horizon/v1/visibility.grpc.pb.h"
#include "rpc_helpers.hpp"

namespace horizon::testing {
namespace {

using Stream = grpc::ClientReaderWriter<v1::SessionRequest, v1::SessionResponse>;

// Rainier (SRTM3, 400 x 400, EPSG:4326): a flight west to east across the summit.
constexpr double kLat = 46.8529, kLon0 = -121.86, kLonStep = 0.004;

// Absolute 3500 m: the flight crosses voids, where a height above ground has no ground.
v1::Pose pose(double lon, double lat, std::uint64_t seq, double altitude = 3500.0) {
  v1::Pose p;
  *p.mutable_position() = point(lon, lat, altitude, v1::FRAME_WGS84);
  p.mutable_position()->set_height_mode(v1::HEIGHT_MODE_ABSOLUTE);
  p.set_east_m_per_s(250.0);
  p.set_seq(seq);
  return p;
}

std::vector<v1::SessionBox> boxes(int count, std::uint64_t first_id, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> lon(-121.91, -121.61), lat(46.68, 46.99), top(1500.0, 4200.0);
  std::vector<v1::SessionBox> out;
  for (int i = 0; i < count; ++i) {
    v1::SessionBox b;
    b.set_id(first_id + static_cast<std::uint64_t>(i));
    v1::Box* box = b.mutable_box();
    box->set_frame(v1::FRAME_WGS84);
    const double x = lon(rng), y = lat(rng);
    box->set_x_min(x);
    box->set_x_max(x + 0.0015);
    box->set_y_min(y);
    box->set_y_max(y + 0.001);
    box->set_z_min(0.0);
    box->set_z_max(top(rng));
    out.push_back(b);
  }
  return out;
}

v1::SessionRequest open_request(const std::vector<v1::SessionBox>& start, v1::SessionMode mode) {
  v1::SessionRequest r;
  v1::OpenSession* o = r.mutable_open();
  o->set_dataset("rainier");
  o->mutable_clipmap()->set_level_size(64);  // 4 levels: 64, 128, 256 and the whole 400 x 400
  o->mutable_clipmap()->set_subtile(16);
  o->set_mode(mode);
  o->set_rays(512);
  *o->mutable_first_pose() = pose(kLon0, kLat, 1);
  for (const auto& b : start) *o->add_boxes() = b;
  return r;
}

// Exact CullBoxes of `boxes` from (lon, kLat) at 3500 m.
grpc::Status exact_cull(v1::VisibilityService::Stub& stub, double lon, const std::vector<v1::SessionBox>& boxes,
                        v1::CullBoxesResponse& out) {
  v1::CullBoxesRequest request;
  request.set_dataset("rainier");
  *request.mutable_observer() = point(lon, kLat, 3500.0, v1::FRAME_WGS84);
  request.mutable_observer()->set_height_mode(v1::HEIGHT_MODE_ABSOLUTE);
  request.set_algorithm(v1::ALGORITHM_EXACT);
  for (const auto& b : boxes) *request.add_boxes() = b.box();
  auto context = context_with_deadline();
  return stub.CullBoxes(context.get(), request, &out);
}

struct Session {
  std::unique_ptr<v1::SessionService::Stub> stub;
  grpc::ClientContext context;
  std::unique_ptr<Stream> stream;
  explicit Session(const DaemonProcess& daemon, const std::string& id = "") {
    stub = v1::SessionService::NewStub(daemon.channel());
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(60));
    if (!id.empty()) context.AddMetadata("horizon-session-id", id);
    stream = stub->Session(&context);
  }
  v1::SessionResponse read() {
    v1::SessionResponse r;
    EXPECT_TRUE(stream->Read(&r));
    return r;
  }
  grpc::Status close() {
    stream->WritesDone();
    v1::SessionResponse r;
    while (stream->Read(&r)) {
    }
    return stream->Finish();
  }
};

TEST(ServerSession, AFlightsChangesNeverHideWhatExactCullingSees) {
  DaemonProcess daemon;
  ASSERT_TRUE(daemon.ready()) << daemon.error();
  const auto start = boxes(150, 1, 7);
  Session s(daemon, "flight-7");
  ASSERT_TRUE(s.stream->Write(open_request(start, v1::SESSION_MODE_CONSERVATIVE)));
  const v1::SessionResponse opened = s.read();
  ASSERT_TRUE(opened.has_opened()) << opened.DebugString();
  EXPECT_EQ(opened.opened().session_id(), "flight-7");
  EXPECT_EQ(opened.opened().clipmap().levels(), 4u);
  EXPECT_GT(opened.opened().memory_bytes(), 4u * 64u * 64u * 4u);
  const auto metadata = s.context.GetServerInitialMetadata();
  ASSERT_EQ(metadata.count("horizon-session-id"), 1u);
  EXPECT_EQ(std::string(metadata.find("horizon-session-id")->second.data(),
                        metadata.find("horizon-session-id")->second.size()),
            "flight-7");

  std::map<std::uint64_t, v1::BoxState> told;
  std::map<std::uint64_t, double> told_ohf;
  auto apply = [&](const v1::SessionResponse& r) {
    EXPECT_TRUE(r.has_answer()) << r.DebugString();
    for (const auto& c : r.answer().changes()) {
      told[c.id()] = c.state();
      told_ohf[c.id()] = c.ohf_min();
    }
  };
  const v1::SessionResponse first = s.read();
  apply(first);
  EXPECT_EQ(first.answer().seq(), 1u);
  EXPECT_EQ(first.answer().changes_size(), 150) << "the first answer tells every box";
  auto stub = v1::VisibilityService::NewStub(daemon.channel());
  std::size_t hidden = 0;
  for (int step = 1; step <= 30; ++step) {
    const double lon = kLon0 + step * kLonStep;
    ASSERT_TRUE(s.stream->Write([&] {
      v1::SessionRequest r;
      *r.mutable_pose() = pose(lon, kLat, static_cast<std::uint64_t>(step + 1));
      return r;
    }()));
    const v1::SessionResponse answer = s.read();  // one at a time: nothing is dropped
    apply(answer);
    EXPECT_EQ(answer.answer().seq(), static_cast<std::uint64_t>(step + 1));
    EXPECT_EQ(answer.answer().poses_dropped(), 0u);
    ASSERT_EQ(answer.answer().levels_size(), 4);
    EXPECT_EQ(answer.answer().boxes(), 150u);
    if (step % 10 != 0) continue;
    // The same boxes by exact culling (R3's OHF) from the same eye.
    v1::CullBoxesResponse exact;
    ASSERT_TRUE(exact_cull(*stub, lon, start, exact).ok());
    for (int i = 0; i < 150; ++i) {
      const bool session_hidden = told[start[static_cast<std::size_t>(i)].id()] == v1::BOX_STATE_HIDDEN;
      hidden += session_hidden;
      EXPECT_FALSE(session_hidden && exact.boxes(i).visible())
          << "box " << i << " at step " << step << ": z_max " << start[static_cast<std::size_t>(i)].box().z_max()
          << ", exact ohf_min " << exact.boxes(i).ohf_min() << ", session's "
          << told_ohf[start[static_cast<std::size_t>(i)].id()];
    }
  }
  EXPECT_GT(hidden, 10u) << "the terrain hides some boxes";
  EXPECT_TRUE(s.close().ok());
  bool logged = false;
  for (const std::string& line : daemon.request_lines())
    logged |= line.find("\"method\":\"Session\"") != std::string::npos && line.find("\"OK\"") != std::string::npos;
  EXPECT_TRUE(logged) << daemon.log();
}

TEST(ServerSession, AnExactSessionAnswersAsExactCullingDoes) {
  DaemonOptions options;
  options.memory_budget_mb = 320;  // the session's 64 MiB and an exact cull's working set beside it
  options.extra_json = R"("sessions": {"exact_mb": 64},)";
  DaemonProcess daemon(options);
  ASSERT_TRUE(daemon.ready()) << daemon.error();
  const auto start = boxes(80, 1, 3);
  Session s(daemon);
  v1::SessionRequest open = open_request(start, v1::SESSION_MODE_EXACT);
  open.mutable_open()->set_viewshed_radius_m(5000.0);
  ASSERT_TRUE(s.stream->Write(open));
  const v1::SessionResponse opened = s.read();
  ASSERT_TRUE(opened.has_opened()) << opened.DebugString() << s.close().error_message();
  EXPECT_GE(opened.opened().memory_bytes(), 64u << 20) << "sessions.exact_mb reserved";
  std::map<std::uint64_t, v1::BoxState> told;
  auto stub = v1::VisibilityService::NewStub(daemon.channel());
  for (int step = 0; step <= 8; step += 4) {
    if (step > 0) {
      v1::SessionRequest r;
      *r.mutable_pose() = pose(kLon0 + step * kLonStep, kLat, static_cast<std::uint64_t>(step + 1));
      ASSERT_TRUE(s.stream->Write(r));
    }
    const v1::SessionResponse answer = s.read();
    ASSERT_TRUE(answer.has_answer()) << answer.DebugString();
    EXPECT_EQ(answer.answer().seq(), static_cast<std::uint64_t>(step + 1));
    EXPECT_EQ(answer.answer().levels_size(), 0) << "no clip-map";
    const v1::PoseViewshed& seen = answer.answer().viewshed();
    EXPECT_GT(seen.visible_cells(), 1000u);
    EXPECT_GT(seen.hidden_cells(), 0u);
    EXPECT_LE(seen.visible_cells() + seen.hidden_cells(), std::uint64_t{seen.width()} * seen.height());
    for (const auto& c : answer.answer().changes()) told[c.id()] = c.state();
    v1::CullBoxesResponse exact;
    ASSERT_TRUE(exact_cull(*stub, kLon0 + step * kLonStep, start, exact).ok());
    std::size_t hidden = 0;
    for (int i = 0; i < 80; ++i) {
      const bool session_hidden = told[start[static_cast<std::size_t>(i)].id()] == v1::BOX_STATE_HIDDEN;
      hidden += session_hidden;
      EXPECT_EQ(session_hidden, !exact.boxes(i).visible()) << "box " << i << " at step " << step;
    }
    EXPECT_GT(hidden, 0u) << "step " << step;
  }
  EXPECT_TRUE(s.close().ok());
}

TEST(ServerSession, TheLatestPoseWinsWhenTheClientDoesNotRead) {
  DaemonProcess daemon;
  ASSERT_TRUE(daemon.ready()) << daemon.error();
  Session s(daemon);
  ASSERT_TRUE(s.stream->Write(open_request(boxes(2000, 1, 3), v1::SESSION_MODE_FAST)));
  constexpr int kPoses = 400;
  for (int i = 0; i < kPoses; ++i) {
    v1::SessionRequest r;
    *r.mutable_pose() = pose(kLon0 + (i % 50) * kLonStep, kLat, static_cast<std::uint64_t>(i + 2));
    ASSERT_TRUE(s.stream->Write(r));
  }
  s.stream->WritesDone();
  std::uint64_t answers = 0, dropped = 0, last = 0;
  v1::SessionResponse r;
  while (s.stream->Read(&r)) {
    if (!r.has_answer()) continue;
    ++answers;
    dropped += r.answer().poses_dropped();
    EXPECT_GT(r.answer().seq(), last) << "answers only move forward";
    last = r.answer().seq();
  }
  ASSERT_TRUE(s.stream->Finish().ok());
  EXPECT_EQ(last, static_cast<std::uint64_t>(kPoses + 1)) << "the newest pose is always answered";
  EXPECT_EQ(answers + dropped, static_cast<std::uint64_t>(kPoses + 1));
  EXPECT_GT(dropped, 0u) << "a client that does not read gets fewer, fresher answers";
}

TEST(ServerSession, WrongPosesAndDeltasAreRejectedAndTheSessionGoesOn) {
  DaemonProcess daemon;
  ASSERT_TRUE(daemon.ready()) << daemon.error();
  Session s(daemon);
  ASSERT_TRUE(s.stream->Write(open_request(boxes(5, 1, 1), v1::SESSION_MODE_FAST)));
  ASSERT_TRUE(s.read().has_opened());
  ASSERT_TRUE(s.read().has_answer());
  v1::SessionRequest delta;
  for (const auto& b : boxes(3, 10, 2)) *delta.mutable_boxes()->add_add() = b;
  delta.mutable_boxes()->mutable_add(2)->set_id(3);  // already in the session
  ASSERT_TRUE(s.stream->Write(delta));
  v1::SessionResponse rejected = s.read();
  ASSERT_TRUE(rejected.has_rejected()) << rejected.DebugString();
  EXPECT_EQ(rejected.rejected().what(), "boxes");
  EXPECT_EQ(rejected.rejected().field(), "boxes.add[2].id");
  EXPECT_EQ(rejected.rejected().code(), static_cast<int>(grpc::StatusCode::INVALID_ARGUMENT));
  v1::SessionRequest off;
  *off.mutable_pose() = pose(-100.0, kLat, 7);
  ASSERT_TRUE(s.stream->Write(off));
  rejected = s.read();
  ASSERT_TRUE(rejected.has_rejected()) << rejected.DebugString();
  EXPECT_EQ(rejected.rejected().what(), "pose");
  EXPECT_EQ(rejected.rejected().seq(), 7u);
  EXPECT_EQ(rejected.rejected().code(), static_cast<int>(grpc::StatusCode::OUT_OF_RANGE));
  // A good delta and pose after them: the rejected ones changed nothing.
  v1::SessionRequest good;
  for (const auto& b : boxes(2, 20, 4)) *good.mutable_boxes()->add_add() = b;
  // A box off the dataset is not a wrong entry: it is answered out of range.
  v1::SessionBox far = boxes(1, 30, 5)[0];
  far.mutable_box()->set_x_min(-100.0);
  far.mutable_box()->set_x_max(-99.99);
  *good.mutable_boxes()->add_add() = far;
  good.mutable_boxes()->add_remove(1);
  ASSERT_TRUE(s.stream->Write(good));
  v1::SessionRequest next;
  *next.mutable_pose() = pose(kLon0, kLat, 8);
  ASSERT_TRUE(s.stream->Write(next));
  const v1::SessionResponse answer = s.read();
  ASSERT_TRUE(answer.has_answer()) << answer.DebugString();
  EXPECT_EQ(answer.answer().seq(), 8u);
  EXPECT_EQ(answer.answer().boxes(), 7u);  // 5 - 1 + 3
  ASSERT_EQ(answer.answer().changes_size(), 3) << "the three new boxes are told";
  for (const v1::BoxChange& c : answer.answer().changes())
    if (c.id() == 30) {
      EXPECT_EQ(c.state(), v1::BOX_STATE_OUT_OF_RANGE);
    } else {
      EXPECT_NE(c.state(), v1::BOX_STATE_OUT_OF_RANGE) << c.id();
    }
  EXPECT_TRUE(s.close().ok());
}

TEST(ServerSession, AWrongOpenEndsTheStreamNamingTheField) {
  DaemonProcess daemon;
  ASSERT_TRUE(daemon.ready()) << daemon.error();
  {
    Session s(daemon);
    v1::SessionRequest r = open_request({}, v1::SESSION_MODE_FAST);
    r.mutable_open()->mutable_clipmap()->set_level_size(100);
    ASSERT_TRUE(s.stream->Write(r));
    const grpc::Status status = s.close();
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
    EXPECT_EQ(violated_field(status), "open.clipmap.level_size");
  }
  {
    Session s(daemon);
    v1::SessionRequest r = open_request({}, v1::SESSION_MODE_FAST);
    r.mutable_open()->mutable_clipmap()->set_levels(2);  // 64 << 1 = 128 < 400 cells
    ASSERT_TRUE(s.stream->Write(r));
    const grpc::Status status = s.close();
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
    EXPECT_EQ(violated_field(status), "open.clipmap.levels");
    EXPECT_NE(status.error_message().find("at least 4 levels"), std::string::npos) << status.error_message();
  }
  {
    Session s(daemon);
    v1::SessionRequest r;
    *r.mutable_pose() = pose(kLon0, kLat, 1);
    ASSERT_TRUE(s.stream->Write(r));
    const grpc::Status status = s.close();
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
    EXPECT_EQ(violated_field(status), "open");
  }
  {
    Session s(daemon);
    v1::SessionRequest r = open_request({}, v1::SESSION_MODE_FAST);
    r.mutable_open()->set_dataset("nowhere");
    ASSERT_TRUE(s.stream->Write(r));
    EXPECT_EQ(s.close().error_code(), grpc::StatusCode::NOT_FOUND);
  }
}

TEST(ServerSession, SessionsAreLimitedInNumberAndMemoryAndExpireWhenIdle) {
  DaemonOptions options;
  options.extra_json = R"("sessions": {"max": 1, "idle_ms": 1500, "max_level_size": 4096},)";
  DaemonProcess daemon(options);
  ASSERT_TRUE(daemon.ready()) << daemon.error();
  Session first(daemon);
  ASSERT_TRUE(first.stream->Write(open_request({}, v1::SESSION_MODE_FAST)));
  ASSERT_TRUE(first.read().has_opened());
  {
    Session second(daemon);
    ASSERT_TRUE(second.stream->Write(open_request({}, v1::SESSION_MODE_FAST)));
    const grpc::Status status = second.close();
    EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << status.error_message();
    EXPECT_EQ(violated_field(status), "sessions.max");
  }
  // The first one says nothing for longer than idle_ms: it ends.
  const auto started = std::chrono::steady_clock::now();
  v1::SessionResponse r;
  while (first.stream->Read(&r)) {
  }
  const grpc::Status idle = first.stream->Finish();
  EXPECT_EQ(idle.error_code(), grpc::StatusCode::UNAVAILABLE) << idle.error_message();
  EXPECT_NE(idle.error_message().find("idle"), std::string::npos) << idle.error_message();
  EXPECT_LT(std::chrono::steady_clock::now() - started, std::chrono::seconds(10));
  // A clip-map larger than the memory budget (256 MiB): 10 levels of 4096 x 4096 floats.
  Session big(daemon);
  v1::SessionRequest huge = open_request({}, v1::SESSION_MODE_FAST);
  huge.mutable_open()->mutable_clipmap()->set_level_size(4096);
  huge.mutable_open()->mutable_clipmap()->set_levels(10);
  ASSERT_TRUE(big.stream->Write(huge));
  const grpc::Status refused = big.close();
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << refused.error_message();
  EXPECT_EQ(violated_field(refused), "open.clipmap");
}

TEST(ServerSession, DrainingEndsSessionsWithUnavailable) {
  DaemonProcess daemon;
  ASSERT_TRUE(daemon.ready()) << daemon.error();
  Session s(daemon);
  ASSERT_TRUE(s.stream->Write(open_request(boxes(10, 1, 5), v1::SESSION_MODE_FAST)));
  ASSERT_TRUE(s.read().has_opened());
  ASSERT_TRUE(s.read().has_answer());
  std::thread stop([&] { EXPECT_EQ(daemon.signal(SIGTERM), 0); });
  v1::SessionResponse r;
  while (s.stream->Read(&r)) {
  }
  const grpc::Status status = s.stream->Finish();
  stop.join();
  EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAVAILABLE) << status.error_message();
  EXPECT_NE(status.error_message().find("draining"), std::string::npos) << status.error_message();
}

}  // namespace
}  // namespace horizon::testing
