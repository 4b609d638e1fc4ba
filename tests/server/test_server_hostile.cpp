// What an attacker or a careless operator can do to horizond from outside
// the API: start a second daemon on its port, plant files where it writes
// scratch, hand it a corrupt DEM, flood it with the largest calls it takes.
// Each case must fail loudly and harm nothing.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <future>
#include <iostream>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <google/protobuf/unknown_field_set.h>
#include <grpcpp/create_channel.h>
#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/security/credentials.h>
#include <grpcpp/support/byte_buffer.h>

#include "arena_allocator.hpp"
#include "daemon_process.hpp"
#include "horizon/terrain/dem_reader.hpp"
#include "horizon/terrain/geotiff_writer.hpp"
#include "horizon/visibility/plan.hpp"
#include "memory_budget.hpp"
#include "rpc_helpers.hpp"

namespace horizon::testing {
namespace {

namespace fs = std::filesystem;

// The entries of `dir` whose names start with `prefix`.
std::vector<fs::path> entries(const fs::path& dir, const std::string& prefix) {
  std::vector<fs::path> out;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().filename().string().rfind(prefix, 0) == 0) out.push_back(e.path());
  return out;
}

TEST(ServerHostile, ASecondDaemonOnAPortInUseExitsOneAndTheFirstKeepsServing) {
  DaemonProcess first;
  ASSERT_TRUE(first.ready()) << first.error();
  const CommandResult second = run_command(std::string(HORIZOND_PATH) + " --config " + first.config_path() +
                                           " --listen " + first.address() + " --metrics-listen 127.0.0.1:0");
  EXPECT_EQ(second.exit_code, 1) << second.output;
  EXPECT_NE(second.output.find("cannot listen there"), std::string::npos) << second.output;
  EXPECT_NE(second.output.find(first.address()), std::string::npos) << second.output;
  const CommandResult listed = run_command(std::string(HORIZON_CLI_PATH) + " datasets --server " + first.address());
  EXPECT_EQ(listed.exit_code, 0) << listed.output;
  EXPECT_NE(listed.output.find("rainier"), std::string::npos) << listed.output;
}

// The scratch directory is shared (the daemon's config puts it beside its
// log); names the daemon once used there are planted as symlinks to a file
// of someone else's. Requests that encode a GeoTIFF and a PNG must write
// through none of them.
TEST(ServerHostile, ScratchFilesStayInAPrivateDirectoryAndNeverFollowPlantedNames) {
  DaemonProcess daemon;
  ASSERT_TRUE(daemon.ready()) << daemon.error();
  const fs::path scratch = fs::path(daemon.config_path()).parent_path();
  const fs::path victim = scratch / "victim.txt";
  std::ofstream(victim) << "precious";
  const std::string pid = std::to_string(daemon.pid());
  for (int n = 0; n < 64; ++n)
    for (const std::string& name :
         {"horizond-" + pid + "-" + std::to_string(n) + ".tif",
          "horizond-" + pid + "-" + std::to_string(n) + ".tif.tmp-" + pid + "-" + std::to_string(n),
          "horizond-" + pid + "-" + std::to_string(n) + ".png.tmp-" + pid + "-" + std::to_string(n)})
      fs::create_symlink(victim, scratch / name);

  const auto dirs = entries(scratch, "horizond-");
  std::vector<fs::path> private_dirs;
  for (const fs::path& p : dirs)
    if (fs::is_directory(fs::symlink_status(p))) private_dirs.push_back(p);
  ASSERT_EQ(private_dirs.size(), 1u);
  struct stat st {};
  ASSERT_EQ(::stat(private_dirs[0].c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0700u);

  TempDir out;
  const std::string tif = out.file("v.tif"), png = out.file("v.png");
  const CommandResult r = run_command(std::string(HORIZON_CLI_PATH) + " viewshed rainier --server " + daemon.address() +
                                      " --lat 46.8529 --lon -121.7604 --max-distance 3000 -o " + tif + " --png " + png);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(read_bytes(victim.string()), "precious");
  EXPECT_GT(fs::file_size(tif), 0u);
  EXPECT_GT(fs::file_size(png), 0u);
  EXPECT_TRUE(fs::is_empty(private_dirs[0]));  // every encoding removed after use
  EXPECT_EQ(daemon.signal(SIGTERM), 0);
  EXPECT_FALSE(fs::exists(private_dirs[0]));  // and the directory with the daemon
}

TEST(ServerHostile, CheckConfigRefusesACorruptDemNamingTheFileAndCell) {
  TempDir dir;
  terrain::Grid<float> cells(64, 48, 500.0f);
  cells.at(10, 20) = 3.0e38f;
  terrain::Georeference georef;
  georef.epsg = 32633;
  georef.transform = {500000.0, 30.0, 5000000.0, -30.0};
  ASSERT_TRUE(terrain::write_geotiff(dir.file("bad.tif"), cells, georef, std::nullopt).ok());
  const auto config = [&](const std::string& entry) {
    write_file(dir.file("c.json"),
               "{\"listen\": \"127.0.0.1:0\", \"plaintext\": true, \"memory_budget_mb\": 256, \"data_root\": \"" +
                   dir.path().string() + "\", \"datasets\": {\"bad\": " + entry + "}}");
    return run_command(std::string(HORIZOND_PATH) + " --check-config " + dir.file("c.json"));
  };
  const CommandResult refused = config("\"bad.tif\"");
  EXPECT_EQ(refused.exit_code, 1) << refused.output;
  EXPECT_NE(refused.output.find("datasets.bad"), std::string::npos) << refused.output;
  EXPECT_NE(refused.output.find("bad.tif"), std::string::npos) << refused.output;
  EXPECT_NE(refused.output.find("cell (col 10, row 20) holds 3e+38"), std::string::npos) << refused.output;
  // An operator who knows better widens the range for that dataset.
  const CommandResult widened = config("{\"file\": \"bad.tif\", \"valid_range\": [-1, 3.1e38]}");
  EXPECT_EQ(widened.exit_code, 0) << widened.output;
}

// A byte flipped inside a DEM's elevations still decodes to a plausible
// raster: only the configured digest catches it. The digest sha256sum gives
// is accepted; a changed file, and a digest on a folder, are refused naming
// the dataset and the key.
TEST(ServerHostile, CheckConfigRefusesADemWhoseDigestDiffers) {
  TempDir dir;
  terrain::Grid<float> cells(64, 48, 500.0f);
  terrain::Georeference georef;
  georef.epsg = 32633;
  georef.transform = {500000.0, 30.0, 5000000.0, -30.0};
  ASSERT_TRUE(terrain::write_geotiff(dir.file("dem.tif"), cells, georef, std::nullopt).ok());
  const CommandResult sum = run_command("sha256sum " + dir.file("dem.tif"));
  ASSERT_EQ(sum.exit_code, 0) << sum.output;
  const std::string digest = sum.output.substr(0, 64);
  const auto check = [&](const std::string& entry) {
    write_file(dir.file("c.json"),
               "{\"listen\": \"127.0.0.1:0\", \"plaintext\": true, \"memory_budget_mb\": 256, \"data_root\": \"" +
                   dir.path().string() + "\", \"datasets\": {\"dem\": " + entry + "}}");
    return run_command(std::string(HORIZOND_PATH) + " --check-config " + dir.file("c.json"));
  };
  const CommandResult accepted = check("{\"file\": \"dem.tif\", \"sha256\": \"" + digest + "\"}");
  EXPECT_EQ(accepted.exit_code, 0) << accepted.output;

  // The last byte of the file (an elevation, or its tail) changed; the raster still loads without a digest.
  {
    std::fstream f(dir.file("dem.tif"), std::ios::in | std::ios::out | std::ios::binary);
    f.seekg(-1, std::ios::end);
    const char last = static_cast<char>(f.get());
    f.seekp(-1, std::ios::end);
    f.put(static_cast<char>(last ^ 0x01));
  }
  const CommandResult unchecked = check("\"dem.tif\"");
  EXPECT_EQ(unchecked.exit_code, 0) << unchecked.output;
  const CommandResult refused = check("{\"file\": \"dem.tif\", \"sha256\": \"" + digest + "\"}");
  EXPECT_EQ(refused.exit_code, 1) << refused.output;
  EXPECT_NE(refused.output.find("datasets.dem"), std::string::npos) << refused.output;
  EXPECT_NE(refused.output.find("not the configured " + digest), std::string::npos) << refused.output;

  const CommandResult folder = check("{\"file\": \".\", \"sha256\": \"" + digest + "\"}");
  EXPECT_EQ(folder.exit_code, 1) << folder.output;
  EXPECT_NE(folder.output.find("is a folder of tiles"), std::string::npos) << folder.output;
}

// A client watching the health service (as a load balancer does) keeps a
// stream open for ever; SIGTERM must not wait the whole shutdown grace for it.
TEST(ServerHostile, AnIdleHealthWatchDoesNotHoldShutdownForTheGrace) {
  DaemonOptions options;
  options.extra_json = R"("shutdown_grace_ms": 20000,)";
  DaemonProcess daemon(options);
  ASSERT_TRUE(daemon.ready()) << daemon.error();
  grpc::GenericStub stub(daemon.channel());
  grpc::CompletionQueue cq;
  grpc::ClientContext context;
  auto call = stub.PrepareCall(&context, "/grpc.health.v1.Health/Watch", &cq);
  const auto step = [&cq](void* tag) {
    void* got = nullptr;
    bool ok = false;
    return cq.Next(&got, &ok) && got == tag && ok;
  };
  int tags[4];
  call->StartCall(&tags[0]);
  ASSERT_TRUE(step(&tags[0]));
  grpc::Slice empty("");  // HealthCheckRequest{service: ""}: the whole server
  grpc::ByteBuffer request(&empty, 1), response;
  call->Write(request, &tags[1]);
  ASSERT_TRUE(step(&tags[1]));
  call->Read(&response, &tags[2]);
  ASSERT_TRUE(step(&tags[2]));  // the first status: SERVING
  const auto started = std::chrono::steady_clock::now();
  EXPECT_EQ(daemon.signal(SIGTERM), 0);
  EXPECT_LT(std::chrono::steady_clock::now() - started, std::chrono::seconds(5)) << daemon.log();
  context.TryCancel();
  cq.Shutdown();
  void* tag = nullptr;
  bool ok = false;
  while (cq.Next(&tag, &ok)) {
  }
}


// A CullBoxes request on the bundled Ecuador DEM (dataset "ecuador"): the
// observer 10 m above its centre, `count` boxes 1-4 cells wide scattered
// over a 300 x 300-cell scene around it.
v1::CullBoxesRequest ecuador_boxes(int count) {
  auto dem = terrain::read_dem(bundled_dem("ecuador_andes_utm17s_10m_383x415.tif"));
  EXPECT_TRUE(dem.ok());
  v1::CullBoxesRequest request;
  if (!dem.ok()) return request;
  const auto& t = dem->georef.transform;
  request.set_dataset("ecuador");
  *request.mutable_observer() = point(t.x_at(191), t.y_at(207), 10.0);
  for (int i = 0; i < count; ++i) {
    const std::uint64_t k = static_cast<std::uint64_t>(i);
    const double c = 41.0 + static_cast<double>(k * 7919 % 300), r = 57.0 + static_cast<double>(k * 104729 % 300);
    const double w = 1 + i % 4;
    v1::Box* b = request.add_boxes();
    b->set_x_min(t.x_at(c));
    b->set_x_max(t.x_at(c + w));
    b->set_y_max(t.y_at(r));
    b->set_y_min(t.y_at(r + w));
    b->set_z_min(2000);
    b->set_z_max(2000 + 10 * (i % 200));
  }
  return request;
}

// Small elements make a parsed request many times its wire size: a million
// empty boxes are 2 MB on the wire and ~94 MB once parsed (empty observers
// alike), and gRPC parses a request before any handler sees it. Each is
// weighed first (protos/guard/parse_guard.hpp): refused unparsed, naming
// what it would take, with the daemon's memory where it was.
TEST(ServerHostile, RequestsThatWouldParseBeyondTheBudgetAreRefusedUnparsed) {
  DaemonOptions options;
  options.datasets = {{"ecuador", "ecuador_andes_utm17s_10m_383x415.tif"}};
  options.memory_budget_mb = 128;
  options.extra_json = R"("block_cache_mb": 16, "engine_threads": 1, "gpu": {"contexts": 0},)";
  DaemonProcess daemon(options);
  ASSERT_TRUE(daemon.ready()) << daemon.error();
  const std::uint64_t start = daemon.rss_bytes();
  auto stub = v1::VisibilityService::NewStub(daemon.channel());

  v1::CullBoxesRequest boxes;
  boxes.set_dataset("ecuador");
  *boxes.mutable_observer() = point(713877.7, 9558936.7, 10.0);
  for (int i = 0; i < 1'000'000; ++i) boxes.add_boxes();
  ASSERT_LT(boxes.ByteSizeLong(), 2'100'000u);
  v1::CullBoxesResponse response;
  grpc::Status s = stub->CullBoxes(context_with_deadline(std::chrono::seconds(30)).get(), boxes, &response);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << s.error_message();
  EXPECT_NE(s.error_message().find("1000002 messages would take about"), std::string::npos) << s.error_message();

  v1::ViewshedRequest observers;
  observers.set_dataset("ecuador");
  for (int i = 0; i < 1'000'000; ++i) observers.add_observers();
  auto context = context_with_deadline(std::chrono::seconds(30));
  auto reader = stub->ComputeViewshed(context.get(), observers);
  v1::ViewshedResponse message;
  while (reader->Read(&message)) {
  }
  s = reader->Finish();
  EXPECT_EQ(s.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << s.error_message();
  EXPECT_NE(s.error_message().find("MiB to read"), std::string::npos) << s.error_message();

  // 10 000 boxes of 200 unknown fields each (100 numbers a Box lacks, and
  // x_min sent as a varint 100 times): 5 MB on the wire, ~43 MB parsed.
  v1::CullBoxesRequest unknown;
  unknown.set_dataset("ecuador");
  for (int i = 0; i < 10'000; ++i) {
    google::protobuf::UnknownFieldSet& fields =
        *unknown.add_boxes()->GetReflection()->MutableUnknownFields(unknown.mutable_boxes(i));
    for (int k = 0; k < 100; ++k) {
      fields.AddVarint(1000, 1);
      fields.AddVarint(2, 1);
    }
  }
  ASSERT_LT(unknown.ByteSizeLong(), 5'100'000u);
  s = stub->CullBoxes(context_with_deadline(std::chrono::seconds(30)).get(), unknown, &response);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << s.error_message();
  EXPECT_NE(s.error_message().find("10001 messages would take about"), std::string::npos) << s.error_message();

  // Parsed, the first two would each have raised the daemon's memory by ~94 MB, the third by ~43 MB.
  const std::uint64_t peak = daemon.peak_rss_bytes();
  EXPECT_LT(peak, start + (24ull << 20)) << "peak RSS " << (peak >> 20) << " MiB, at start " << (start >> 20);
  // Still serving, the budget whole.
  EXPECT_TRUE(daemon.memory_returned()) << daemon.metrics();
  boxes.mutable_boxes()->DeleteSubrange(10, 1'000'000 - 10);
  for (auto& b : *boxes.mutable_boxes()) {
    b.set_x_min(713800);
    b.set_x_max(713810);
    b.set_y_min(9558900);
    b.set_y_max(9558910);
    b.set_z_max(5000);
  }
  s = stub->CullBoxes(context_with_deadline().get(), boxes, &response);
  EXPECT_TRUE(s.ok()) << s.error_message();
  EXPECT_EQ(response.boxes_size(), 10);
}

// Clients on connections of their own, each sending the largest CullBoxes
// call the defaults take (100 000 boxes, ~5 MB on the wire; 19 MiB held
// once received and answered, 13 MiB more for its boxes' conversion) at
// once, against a small budget. What is on
// the wire fills gRPC's receive quota (receive_buffer_mb, by default an
// eighth of the budget: 16 MiB here, three such requests), and gRPC sheds
// connections past it (the calls end UNAVAILABLE; a client retries, as the
// service config's retry policy does); received calls are admitted while
// their messages and their boxes' conversion fit and refused
// RESOURCE_EXHAUSTED, before they queue, when not (a client retries after a
// pause, as the refusal says); a call admitted is answered. The daemon's resident memory stays within the budget, it
// gives the flood's memory back once idle, and it keeps answering.
TEST(ServerHostile, AFloodOfTheLargestCallsStaysWithinTheBudget) {
  constexpr int kBudgetMb = 128, kClients = 24, kCallsEach = 3, kBoxes = 100'000;
  DaemonOptions options;
  options.datasets = {{"ecuador", "ecuador_andes_utm17s_10m_383x415.tif"}};
  options.memory_budget_mb = kBudgetMb;
  options.extra_json = R"("block_cache_mb": 16, "engine_threads": 1, "gpu": {"contexts": 0},
                           "limits": {"max_pending": 64},)";
  DaemonProcess daemon(options);
  ASSERT_TRUE(daemon.ready()) << daemon.error();
  const std::uint64_t start = daemon.rss_bytes();
  const v1::CullBoxesRequest request = ecuador_boxes(kBoxes);

  const std::uint64_t on_the_wire = kClients * request.ByteSizeLong();
  std::atomic<int> answered{0}, refused{0}, shed{0}, exhausted{0}, other{0};
  std::string first_other;
  std::mutex note_mutex;
  std::vector<std::thread> clients;
  for (int c = 0; c < kClients; ++c) {
    clients.emplace_back([&, c] {
      grpc::ChannelArguments args;
      args.SetInt("horizon.test.client", c);  // a distinct channel: a connection of its own
      args.SetInt(GRPC_ARG_USE_LOCAL_SUBCHANNEL_POOL, 1);
      auto stub = v1::VisibilityService::NewStub(
          grpc::CreateCustomChannel(daemon.address(), grpc::InsecureChannelCredentials(), args));
      for (int k = 0; k < kCallsEach; ++k) {
        v1::CullBoxesResponse response;
        grpc::Status s;
        // Shed by the receive quota (UNAVAILABLE) or refused for memory
        // (RESOURCE_EXHAUSTED, "retry later"): retried after a pause, as a
        // client following the refusal would.
        for (int attempt = 0; attempt < 5; ++attempt) {
          if (attempt > 0) std::this_thread::sleep_for(std::chrono::milliseconds(50 << attempt));
          s = stub->CullBoxes(context_with_deadline(std::chrono::seconds(120)).get(), request, &response);
          if (s.error_code() == grpc::StatusCode::UNAVAILABLE) {
            ++shed;
          } else if (s.error_code() == grpc::StatusCode::RESOURCE_EXHAUSTED) {
            ++exhausted;
          } else {
            break;
          }
        }
        if (s.ok() && response.boxes_size() == kBoxes) {
          ++answered;
        } else if (s.error_code() == grpc::StatusCode::RESOURCE_EXHAUSTED ||
                   s.error_code() == grpc::StatusCode::UNAVAILABLE) {
          ++refused;
        } else {
          ++other;
          std::lock_guard lock(note_mutex);
          if (first_other.empty()) first_other = std::to_string(s.error_code()) + ": " + s.error_message();
        }
      }
    });
  }
  for (auto& client : clients) client.join();
  EXPECT_EQ(other.load(), 0) << first_other;
  EXPECT_GT(answered.load(), 0);
  EXPECT_GT(refused.load(), 0) << "the flood never met the budget: it tests nothing";
  EXPECT_EQ(answered + refused + other, kClients * kCallsEach);
  // A refusal names the budget and what the call needed.
  const std::string log = daemon.log();
  EXPECT_NE(log.find("this request needs about"), std::string::npos);
  EXPECT_NE(log.find("memory_budget_mb"), std::string::npos);
  // Every call admitted was answered: none was refused the working memory
  // its plan needs because calls queued behind it, or requests being
  // parsed, held the rest (CI once saw all 72 refused so).
  EXPECT_EQ(log.find("of working memory"), std::string::npos) << log.substr(0, 4000);

  // Still serving, and the flood's memory given back.
  v1::CullBoxesRequest small = request;
  small.mutable_boxes()->DeleteSubrange(10, kBoxes - 10);
  v1::CullBoxesResponse response;
  ASSERT_TRUE(v1::VisibilityService::NewStub(daemon.channel())
                  ->CullBoxes(context_with_deadline().get(), small, &response)
                  .ok());
  EXPECT_EQ(response.boxes_size(), 10);
  // Idle now: the heap is trimmed HeapTrimmer::kDelay (100 ms) after the last call.
  std::this_thread::sleep_for(std::chrono::seconds(1));
  const std::uint64_t peak = daemon.peak_rss_bytes(), idle = daemon.rss_bytes();
  std::cout << "flood: " << answered << " answered, " << refused << " refused after 5 attempts; " << shed
            << " attempts shed by the receive quota, " << exhausted << " refused for memory; peak RSS " << (peak >> 20)
            << " MiB, idle " << (idle >> 20) << " MiB (at start " << (start >> 20) << "), budget " << kBudgetMb
            << " MiB, requests on the wire " << (on_the_wire >> 20) << " MiB\n";
#if defined(__SANITIZE_ADDRESS__)
  std::cout << "RSS under AddressSanitizer is not compared with the budget\n";
#else
  EXPECT_LE(peak, std::uint64_t{kBudgetMb} << 20) << "peak RSS " << (peak >> 20) << " MiB";
  // Back to where it started, but for the block cache (16 MiB) it may have filled.
  EXPECT_LE(idle, start + (24ull << 20)) << "idle RSS " << (idle >> 20) << " MiB";
  EXPECT_LE(idle, std::uint64_t{kBudgetMb} << 20) << "idle RSS " << (idle >> 20) << " MiB";
#endif
}

// A CullBoxes call's boxes are paid for before they are converted, at
// admission: with a budget that holds the call's messages but not also the
// boxes' specs, footprints and answers, the call is refused before it
// queues, naming both parts (and long before its plan's OHF).
TEST(ServerHostile, ACullsBoxesArePaidForBeforeTheyAreConverted) {
  constexpr int kBoxes = 100'000;
  const v1::CullBoxesRequest request = ecuador_boxes(kBoxes);
  // What admission holds (VisibilityService::CullBoxes): the request as
  // received on the call's arena and the answer it will build.
  server::ArenaAllocator<v1::CullBoxesRequest, v1::CullBoxesResponse> allocator;
  auto* holder = allocator.AllocateMessages();
  *holder->request() = request;
  const std::uint64_t messages =
      server::held_bytes(*holder->request()) + std::uint64_t{kBoxes} * server::MemoryBudget::kResponseBytesPerBox;
  holder->Release();
  const std::uint64_t boxes = std::uint64_t{kBoxes} * visibility::kCullBytesPerBox;
  ASSERT_GT(boxes, std::uint64_t{4} << 20) << "too few bytes a box to tell the steps apart";
  // Free after the fixed parts: the messages and half the boxes' bytes.
  constexpr std::uint64_t kReceiveMb = 16, kCacheMb = 4;  // the receive quota holds the largest request
  const std::uint64_t fixed = server::MemoryBudget::kBaseBytes + ((kReceiveMb + kCacheMb) << 20);
  const std::uint64_t budget_mb = (fixed + messages + boxes / 2 + (1 << 20) - 1) >> 20;
  DaemonOptions options;
  options.datasets = {{"ecuador", "ecuador_andes_utm17s_10m_383x415.tif"}};
  options.memory_budget_mb = static_cast<int>(budget_mb);
  options.extra_json = "\"receive_buffer_mb\": " + std::to_string(kReceiveMb) +
                       ", \"block_cache_mb\": " + std::to_string(kCacheMb) +
                       R"(, "gpu": {"contexts": 0}, "limits": {"max_lines": 20000},)";
  DaemonProcess daemon(options);
  ASSERT_TRUE(daemon.ready()) << daemon.error();
  v1::CullBoxesResponse response;
  const grpc::Status s = v1::VisibilityService::NewStub(daemon.channel())
                             ->CullBoxes(context_with_deadline(std::chrono::seconds(60)).get(), request, &response);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << s.error_message();
  EXPECT_NE(s.error_message().find("while it waits and runs (its messages"), std::string::npos) << s.error_message();
  EXPECT_NE(s.error_message().find(", converting these 100000 boxes " + std::to_string((boxes + (1 << 20) - 1) >> 20) +
                                   " MiB)"),
            std::string::npos)
      << s.error_message();
  EXPECT_NE(s.error_message().find("memory_budget_mb"), std::string::npos) << s.error_message();
  // A call of fewer boxes fits and is answered.
  v1::CullBoxesRequest few = request;
  few.mutable_boxes()->DeleteSubrange(100, kBoxes - 100);
  const grpc::Status ok = v1::VisibilityService::NewStub(daemon.channel())
                              ->CullBoxes(context_with_deadline(std::chrono::seconds(60)).get(), few, &response);
  EXPECT_TRUE(ok.ok()) << ok.error_message();
  EXPECT_EQ(response.boxes_size(), 100);
}

// Bytes that are no protobuf encoding of the request are answered
// INVALID_ARGUMENT naming the type (gRPC's callback API alone would answer
// UNIMPLEMENTED with no message), a string field that is not UTF-8 naming
// the field, and the daemon goes on serving.
TEST(ServerHostile, ARequestWhoseBytesDoNotParseIsNamedInvalid) {
  DaemonOptions options;
  options.datasets = {{"ecuador", "ecuador_andes_utm17s_10m_383x415.tif"}};
  DaemonProcess daemon(options);
  ASSERT_TRUE(daemon.ready()) << daemon.error();
  grpc::GenericStub stub(daemon.channel());
  // CullBoxes with `bytes` as its request, as they are.
  const auto cull_boxes = [&stub](const std::string& bytes) {
    return testing::raw_unary_call(stub, "/horizon.v1.VisibilityService/CullBoxes", bytes, std::chrono::seconds(10));
  };
  // Field 1 (dataset), a string whose length runs past the end.
  const grpc::Status s = cull_boxes(std::string("\x0a\x40", 2) + "ecuador");
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << s.error_message();
  EXPECT_NE(s.error_message().find("9 bytes are not a valid horizon.v1.CullBoxesRequest"), std::string::npos)
      << s.error_message();
  // A dataset name that is not UTF-8 (protobuf's parse fails on it): named.
  const grpc::Status named =
      cull_boxes(std::string("\x0a\x07"
                             "ecuad\xf3r",
                             9));
  EXPECT_EQ(named.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << named.error_message();
  EXPECT_NE(named.error_message().find("horizon.v1.CullBoxesRequest.dataset is not UTF-8 text"), std::string::npos)
      << named.error_message();
  v1::ListDatasetsResponse datasets;
  EXPECT_TRUE(v1::DatasetService::NewStub(daemon.channel())
                  ->ListDatasets(context_with_deadline().get(), v1::ListDatasetsRequest(), &datasets)
                  .ok());
  EXPECT_EQ(datasets.datasets_size(), 1);
}

// A LineOfSight call's plans are paid for before they are made, at
// admission: with a budget that holds the call's request but not also its
// 20 000 lines' plans (twice the default limit, so that the plans outweigh
// the budget's rounding to MiB), the call is refused before it queues,
// naming the planning.
TEST(ServerHostile, ALineOfSightsPlansArePaidForBeforeTheyAreMade) {
  constexpr int kLines = 20'000;
  auto dem = terrain::read_dem(bundled_dem("ecuador_andes_utm17s_10m_383x415.tif"));
  ASSERT_TRUE(dem.ok());
  const auto& t = dem->georef.transform;
  v1::LineOfSightRequest request;
  request.set_dataset("ecuador");
  for (int i = 0; i < kLines; ++i) {
    v1::SightLine* line = request.add_lines();
    *line->mutable_from() = point(t.x_at(20 + i % 300), t.y_at(30), 5.0);
    *line->mutable_to() = point(t.x_at(40 + i % 300), t.y_at(380), 5.0);
  }
  // What admission holds (VisibilityService::LineOfSight): the request on the call's arena.
  server::ArenaAllocator<v1::LineOfSightRequest, v1::LineOfSightResponse> allocator;
  auto* holder = allocator.AllocateMessages();
  *holder->request() = request;
  const std::uint64_t messages = server::held_bytes(*holder->request());
  holder->Release();
  const std::uint64_t plans = std::uint64_t{kLines} * sizeof(visibility::LinePlan);
  ASSERT_GT(plans, std::uint64_t{2} << 20) << "too few bytes a plan to tell the steps apart";
  // Free after the fixed parts: the messages and half the plans' bytes, or
  // the request's parse bound where that is more (the parse holds it of the
  // budget meanwhile); either way less than the messages and the plans.
  constexpr std::uint64_t kReceiveMb = 16, kCacheMb = 4;
  const std::uint64_t fixed = server::MemoryBudget::kBaseBytes + ((kReceiveMb + kCacheMb) << 20);
  const std::uint64_t free =
      std::max(messages + plans / 2,
               proto::parse_bound(*v1::LineOfSightRequest::descriptor(), request.SerializeAsString()).bytes);
  ASSERT_LT(free + (1 << 20), messages + plans) << "the budget's rounding to MiB could hold the plans too";
  DaemonOptions options;
  options.datasets = {{"ecuador", "ecuador_andes_utm17s_10m_383x415.tif"}};
  options.memory_budget_mb = static_cast<int>((fixed + free + (1 << 20) - 1) >> 20);
  options.extra_json = "\"receive_buffer_mb\": " + std::to_string(kReceiveMb) +
                       ", \"block_cache_mb\": " + std::to_string(kCacheMb) +
                       R"(, "gpu": {"contexts": 0}, "limits": {"max_lines": 20000},)";
  DaemonProcess daemon(options);
  ASSERT_TRUE(daemon.ready()) << daemon.error();
  auto stub = v1::VisibilityService::NewStub(daemon.channel());
  v1::LineOfSightResponse response;
  const grpc::Status s = stub->LineOfSight(context_with_deadline(std::chrono::seconds(60)).get(), request, &response);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << s.error_message();
  EXPECT_NE(s.error_message().find("while it waits and runs (its messages"), std::string::npos) << s.error_message();
  EXPECT_NE(s.error_message().find(", planning these 20000 sight lines " +
                                   std::to_string((plans + (1 << 20) - 1) >> 20) + " MiB)"),
            std::string::npos)
      << s.error_message();
  // A call of fewer lines fits and is answered.
  request.mutable_lines()->DeleteSubrange(100, kLines - 100);
  const grpc::Status ok = stub->LineOfSight(context_with_deadline(std::chrono::seconds(60)).get(), request, &response);
  EXPECT_TRUE(ok.ok()) << ok.error_message();
  EXPECT_EQ(response.results_size(), 100);
}

// Clients that start a large viewshed stream, read its first message and
// then never read again: the daemon's writes wait on the stream's flow
// control, not on a worker, so the other clients are served meanwhile; the
// configured default deadline then ends each stuck call, and its slot and
// memory come back.
TEST(ServerHostile, ReadersThatNeverDrainAStreamHoldNothingPastTheDeadline) {
  TempDir data;
  const terrain::Dem big = make_dem(2000, 2000, [](int c, int r) {
    return 500.0 + 200.0 * std::sin(c * 0.013) * std::cos(r * 0.017) + 30.0 * std::sin(c * 0.21 + r * 0.17);
  });
  ASSERT_TRUE(terrain::write_geotiff(data.file("big.tif"), big.elevation, big.georef, std::nullopt).ok());
  DaemonOptions options;
  options.data_root = data.path().string();
  options.datasets = {{"big", "big.tif"}};
  options.memory_budget_mb = 512;
  options.extra_json = R"("default_deadline_ms": 5000, "block_cache_mb": 32, "engine_threads": 1, "gpu": {"contexts": 0},)";
  DaemonProcess daemon(options);
  ASSERT_TRUE(daemon.ready()) << daemon.error();
  auto stub = v1::VisibilityService::NewStub(daemon.channel());
  // What the budget holds but for the workers' kept buffers (worker_memory.hpp), which calls leave behind.
  const auto held_by_calls = [](const std::string& m) {
    return metric(m, "horizon_memory_reserved_bytes") - metric(m, "horizon_worker_kept_bytes");
  };
  const double reserved_idle = held_by_calls(daemon.metrics());

  // A 7 km viewshed's OHF as float32, 1400 x 1400 cells (7.8 MB) in 4 KiB chunks.
  v1::ViewshedRequest request;
  request.set_dataset("big");
  *request.mutable_observer() = point(500000 + 10000.5, 5000000 - 10000.5);
  request.mutable_options()->set_max_distance(7000);
  request.set_raster(v1::RASTER_KIND_OHF);
  request.set_include_raster(true);
  request.set_max_chunk_bytes(4096);
  constexpr int kSlow = 3;
  std::vector<std::unique_ptr<grpc::ClientContext>> contexts;
  std::vector<std::unique_ptr<grpc::ClientReader<v1::ViewshedResponse>>> readers;
  // The readers' channel takes no more than 64 KiB ahead of what is read
  // (no window growth), as a reader on a slow link would.
  grpc::ChannelArguments args;
  args.SetInt(GRPC_ARG_HTTP2_BDP_PROBE, 0);
  args.SetInt(GRPC_ARG_HTTP2_STREAM_LOOKAHEAD_BYTES, 64 << 10);
  auto slow = v1::VisibilityService::NewStub(
      grpc::CreateCustomChannel(daemon.address(), grpc::InsecureChannelCredentials(), args));
  for (int i = 0; i < kSlow; ++i) {
    contexts.push_back(std::make_unique<grpc::ClientContext>());  // no deadline of its own
    readers.push_back(slow->ComputeViewshed(contexts.back().get(), request));
  }
  ASSERT_TRUE(daemon.wait_for_in_flight(kSlow)) << daemon.metrics();
  for (auto& reader : readers) {
    v1::ViewshedResponse first;
    ASSERT_TRUE(reader->Read(&first)) << reader->Finish().error_message();
    EXPECT_TRUE(first.has_header());
  }
  const auto stuck_at = std::chrono::steady_clock::now();

  // Served meanwhile.
  for (int i = 0; i < 4; ++i) {
    v1::LineOfSightRequest los;
    los.set_dataset("big");
    auto* line = los.add_lines();
    *line->mutable_from() = point(500000 + 5000.5, 5000000 - 5000.5);
    *line->mutable_to() = point(500000 + 6000.5 + 100 * i, 5000000 - 7000.5);
    v1::LineOfSightResponse response;
    const grpc::Status s = stub->LineOfSight(context_with_deadline(std::chrono::seconds(5)).get(), los, &response);
    EXPECT_TRUE(s.ok()) << s.error_message();
  }
  EXPECT_EQ(metric(daemon.metrics(), "horizon_requests_in_flight"), kSlow) << "the slow readers' calls ended early";

  // The default deadline ends the stuck calls: no slot and no memory held.
  // A call leaves the in-flight gauge a moment before its reactor (and its
  // reservation) goes, so both are waited for.
  daemon.wait_for_metrics(
      [&](const std::string& m) {
        return metric(m, "horizon_requests_in_flight") == 0 && held_by_calls(m) == reserved_idle;
      },
      std::chrono::duration_cast<std::chrono::milliseconds>(stuck_at + std::chrono::seconds(10) -
                                                            std::chrono::steady_clock::now()));
  const std::string settled = daemon.metrics();
  EXPECT_EQ(metric(settled, "horizon_requests_in_flight"), 0);
  EXPECT_EQ(held_by_calls(settled), reserved_idle);
  int ended = 0;
  for (const std::string& line : daemon.request_lines())
    if (line.find("ComputeViewshed") != std::string::npos &&
        line.find("\"status\":\"DEADLINE_EXCEEDED\"") != std::string::npos)
      ++ended;
  EXPECT_EQ(ended, kSlow) << daemon.log();
  for (auto& c : contexts) c->TryCancel();
  for (auto& r : readers) EXPECT_FALSE(r->Finish().ok());
}

}  // namespace
}  // namespace horizon::testing
