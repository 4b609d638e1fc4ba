// What an attacker or a careless operator can do to horizond from outside
// the API: start a second daemon on its port, plant files where it writes
// scratch, hand it a corrupt DEM. Each case must fail loudly and harm nothing.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <chrono>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/support/byte_buffer.h>

#include "daemon_process.hpp"
#include "horizon/terrain/geotiff_writer.hpp"

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

}  // namespace
}  // namespace horizon::testing
