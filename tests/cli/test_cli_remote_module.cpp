// test_cli_remote_module.cpp — --server mode lives in the plugin
// libhorizon_remote.so (client_cli/remote/module_abi.hpp): `horizon` must not
// load gRPC on its own, must load the module when given --server (every
// symbol it needs resolved), and must say clearly which paths it tried when
// the module is missing or unusable.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "cli_run.hpp"

namespace horizon::testing {
namespace {

namespace fs = std::filesystem;

const std::string kNoModule = "--server needs the remote module";

// The module the build made (<build>/lib, beside libhorizon_imageio.so).
fs::path built_module() {
  return fs::path(HORIZON_CLI_PATH).parent_path().parent_path() / "lib" / "libhorizon_remote.so";
}

// No daemon listens on port 1: the call fails in gRPC, which proves the
// module was opened and its table called.
const std::vector<std::string> kUnreachable = {"datasets", "--server", "127.0.0.1:1", "--deadline", "5"};

TEST(CliRemoteModule, ServerModeLoadsTheModule) {
  const auto r = horizon(kUnreachable);
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_EQ(r.output.find(kNoModule), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("(UNAVAILABLE from 127.0.0.1:1)"), std::string::npos) << r.output;
}

TEST(CliRemoteModule, EmbeddedModeLoadsNoGrpc) {
  // The dynamic linker lists every object it loads; --version and an
  // embedded command must load neither gRPC, protobuf, abseil nor the module.
  for (const std::vector<std::string>& args :
       {std::vector<std::string>{"--version"},
        std::vector<std::string>{"info", bundled_dem("rainier_summit_srtm3_400x400.tif")}}) {
    const auto r = horizon_with_env("LD_DEBUG", "files", args);
    ASSERT_EQ(r.exit_code, 0) << r.output;
    ASSERT_NE(r.output.find("file=libstdc++"), std::string::npos) << "LD_DEBUG gave no list:\n" << r.output;
    for (const char* library : {"libgrpc", "libgpr", "libprotobuf", "libabsl", "libhorizon_remote"})
      EXPECT_EQ(r.output.find(library), std::string::npos) << args[0] << " loaded " << library;
  }
  // While --server does load them.
  const auto r = horizon_with_env("LD_DEBUG", "files", kUnreachable);
  EXPECT_NE(r.output.find("libhorizon_remote.so"), std::string::npos);
  EXPECT_NE(r.output.find("libgrpc++"), std::string::npos);
}

TEST(CliRemoteModule, MissingModuleNamesThePathTried) {
  TempDir dir;
  const std::string missing = dir.file("nowhere/libhorizon_remote.so");
  const auto r = horizon_with_env("HORIZON_REMOTE_PLUGIN", missing, kUnreachable);
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("horizon: error: " + kNoModule), std::string::npos) << r.output;
  EXPECT_NE(r.output.find(missing + " (absent)"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("HORIZON_REMOTE_PLUGIN"), std::string::npos) << r.output;
  // Embedded mode does not need the module at all.
  const auto v = horizon_with_env("HORIZON_REMOTE_PLUGIN", missing, {"--version"});
  EXPECT_EQ(v.exit_code, 0) << v.output;
}

TEST(CliRemoteModule, UnloadableModuleGivesDlerror) {
  TempDir dir;
  const std::string not_elf = dir.file("libhorizon_remote.so");
  std::ofstream(not_elf) << "not a shared object\n";
  const auto r = horizon_with_env("HORIZON_REMOTE_PLUGIN", not_elf, kUnreachable);
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find(kNoModule), std::string::npos) << r.output;
  // dlerror() names the file and what is wrong with it.
  EXPECT_NE(r.output.find(not_elf + " (" + not_elf + ": "), std::string::npos) << r.output;
}

TEST(CliRemoteModule, ALibraryWithoutTheEntryPointIsRefused) {
  const fs::path other = built_module().parent_path() / "libhorizon_imageio.so";
  ASSERT_TRUE(fs::exists(other)) << other;
  const auto r = horizon_with_env("HORIZON_REMOTE_PLUGIN", other.string(), kUnreachable);
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find(other.string() + " (no horizon_remote_module())"), std::string::npos) << r.output;
}

TEST(CliRemoteModule, InstalledLayoutFindsLibHorizon) {
  // bin/horizon finds ../lib/horizon/libhorizon_remote.so before the build's.
  TempDir dir;
  fs::create_directories(dir.path() / "bin");
  fs::create_directories(dir.path() / "lib" / "horizon");
  const fs::path exe = dir.path() / "bin" / "horizon";
  const fs::path module = dir.path() / "lib" / "horizon" / "libhorizon_remote.so";
  fs::copy_file(HORIZON_CLI_PATH, exe);
  fs::copy_file(built_module(), module);
  const auto r = horizon_with_env("LD_DEBUG", "files", kUnreachable, exe.string());
  EXPECT_NE(r.output.find("(UNAVAILABLE from 127.0.0.1:1)"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("file=" + module.string()), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("file=" + built_module().string()), std::string::npos) << r.output;
}

}  // namespace
}  // namespace horizon::testing
