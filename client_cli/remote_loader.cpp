// remote_loader.cpp — remote::run_* (remote.hpp) in the executable: each
// opens libhorizon_remote.so on first use and calls its implementation
// (module_abi.hpp), so that gRPC is loaded only by a command given --server.
//
// Where the module is looked for, first found wins:
//   1. $HORIZON_REMOTE_PLUGIN, when set and not empty (then nothing else);
//   2. libhorizon_remote.so beside the executable;
//   3. ../lib/horizon/libhorizon_remote.so from the executable's directory
//      (the installed layout: bin/horizon, lib/horizon/);
//   4. where this build put it (<build>/lib/), so that every build directory
//      (Release, ASan, TSan) runs its own module.
// A module that is absent, does not load (dlerror), or is not this build's
// gives "horizon: error: --server needs ..." naming every path tried, and exit
// status 1.
#include <dlfcn.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "commands/command.hpp"
#include "remote/module_abi.hpp"

#ifndef HORIZON_VERSION
#error "HORIZON_VERSION must be defined by the build"
#endif

namespace horizon::cli::remote {
namespace {

constexpr const char* kModule = "libhorizon_remote.so";

struct Loaded {
  const ModuleAbi* abi = nullptr;
  std::string error;  // why it was not loaded
};

std::vector<std::string> candidates() {
  if (const char* env = std::getenv("HORIZON_REMOTE_PLUGIN"); env && *env) return {env};
  std::vector<std::string> paths;
  std::error_code ec;
  const auto exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const auto dir = exe.parent_path();
    paths.push_back((dir / kModule).string());
    paths.push_back((dir / ".." / "lib" / "horizon" / kModule).lexically_normal().string());
  }
#ifdef HORIZON_REMOTE_BUILD_PATH
  paths.push_back(HORIZON_REMOTE_BUILD_PATH);
#endif
  return paths;
}

Loaded load() {
  std::string tried;
  const auto note = [&tried](const std::string& path, const std::string& why) {
    tried += (tried.empty() ? "" : "; ") + path + " (" + why + ")";
  };
  for (const std::string& path : candidates()) {
    std::error_code ec;
    if (!std::filesystem::exists(path, ec)) {
      note(path, "absent");
      continue;
    }
    // RTLD_NOW: a symbol the module needs and the executable lacks fails
    // here, with dlerror() naming it, not in the middle of a command.
    void* handle = ::dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!handle) {
      const char* why = ::dlerror();
      note(path, why ? why : "dlopen failed");
      continue;
    }
    using Entry = const ModuleAbi* (*)();
    auto entry = reinterpret_cast<Entry>(::dlsym(handle, kModuleEntry));
    const ModuleAbi* abi = entry ? entry() : nullptr;
    if (!abi) {
      note(path, std::string("no ") + kModuleEntry + "()");
    } else if (abi->version != kModuleAbiVersion || std::string(abi->horizon_version) != HORIZON_VERSION) {
      note(path, "built for horizon " + std::string(abi->horizon_version) + ", module ABI " +
                     std::to_string(abi->version) + "; this is horizon " HORIZON_VERSION ", module ABI " +
                     std::to_string(kModuleAbiVersion));
    } else {
      return {abi, {}};  // kept open for the life of the process
    }
    ::dlclose(handle);
  }
  return {nullptr, std::string("--server needs the remote module ") + kModule + ", which could not be loaded (tried: " +
                       (tried.empty() ? "nothing" : tried) + "); set HORIZON_REMOTE_PLUGIN to its path"};
}

// The table, or nullptr after printing why there is none.
const ModuleAbi* module() {
  static const Loaded loaded = load();  // a CLI run loads it at most once, from one thread
  if (!loaded.abi) std::fprintf(stderr, "horizon: error: %s\n", loaded.error.c_str());
  return loaded.abi;
}

}  // namespace

int run_info(const Args& args, const std::string& dataset, bool json) {
  const ModuleAbi* m = module();
  return m ? m->run_info(args, dataset, json) : kExitFailure;
}

int run_viewshed_many(const Args& args, const ManyViewshedInputs& inputs) {
  const ModuleAbi* m = module();
  return m ? m->run_viewshed_many(args, inputs) : kExitFailure;
}

int run_viewshed(const Args& args, const ViewshedInputs& inputs) {
  const ModuleAbi* m = module();
  return m ? m->run_viewshed(args, inputs) : kExitFailure;
}

int run_los(const Args& args, const std::string& dataset, const geodesy::PointSpec& from, const geodesy::PointSpec& to,
            const visibility::LosOptions& options, bool json) {
  const ModuleAbi* m = module();
  return m ? m->run_los(args, dataset, from, to, options, json) : kExitFailure;
}

int run_cull(const Args& args, const std::string& dataset, const geodesy::PointSpec& observer,
             const std::vector<visibility::BoxSpec>& boxes, const std::vector<std::uint64_t>& ids,
             const visibility::CullOptions& options, bool json) {
  const ModuleAbi* m = module();
  return m ? m->run_cull(args, dataset, observer, boxes, ids, options, json) : kExitFailure;
}

int run_datasets(const Args& args, bool json) {
  const ModuleAbi* m = module();
  return m ? m->run_datasets(args, json) : kExitFailure;
}

int run_mesh_cull(const Args& args, const MeshCullInputs& inputs) {
  const ModuleAbi* m = module();
  return m ? m->run_mesh_cull(args, inputs) : kExitFailure;
}

int run_trace(const Args& args, const TraceInputs& inputs) {
  const ModuleAbi* m = module();
  return m ? m->run_trace(args, inputs) : kExitFailure;
}

int run_session(const Args& args, const SessionPlayback& playback, bool json, bool every_pose) {
  const ModuleAbi* m = module();
  return m ? m->run_session(args, playback, json, every_pose) : kExitFailure;
}

}  // namespace horizon::cli::remote
