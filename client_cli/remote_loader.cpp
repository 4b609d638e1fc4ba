// remote_loader.cpp — remote::run_* (remote.hpp) in the executable: each
// opens libhorizon_remote.so on first use and calls its implementation
// (module_abi.hpp), so that gRPC is loaded only by a command given --server.
//
// The module is looked for where every plugin is
// (horizon/common/plugin_paths.hpp): $HORIZON_REMOTE_PLUGIN alone when set,
// else beside the executable, in ../lib/horizon/, and where this build put
// it (<build>/lib/), so that every build directory runs its own module.
// A module that is absent, does not load (dlerror), or is not this build's
// gives "horizon: error: --server needs ..." naming every path tried, and exit
// status 1.
#include <dlfcn.h>

#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "commands/command.hpp"
#include "horizon/common/plugin_paths.hpp"
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

Loaded load() {
  std::string tried;
  const auto note = [&tried](const std::string& path, const std::string& why) {
    tried += (tried.empty() ? "" : "; ") + path + " (" + why + ")";
  };
#ifdef HORIZON_REMOTE_BUILD_PATH
  const char* build_path = HORIZON_REMOTE_BUILD_PATH;
#else
  const char* build_path = nullptr;
#endif
  for (const std::string& path : plugin_candidates("HORIZON_REMOTE_PLUGIN", kModule, build_path)) {
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

// Calls the module's `entry`, or gives kExitFailure after printing why
// there is no module.
template <class Entry, class... Params>
int call(Entry ModuleAbi::*entry, const Params&... params) {
  const ModuleAbi* m = module();
  return m ? (m->*entry)(params...) : kExitFailure;
}

}  // namespace

int run_info(const Args& args, const std::string& dataset, bool json) {
  return call(&ModuleAbi::run_info, args, dataset, json);
}

int run_viewshed_many(const Args& args, const ManyViewshedInputs& inputs) {
  return call(&ModuleAbi::run_viewshed_many, args, inputs);
}

int run_viewshed(const Args& args, const ViewshedInputs& inputs) {
  return call(&ModuleAbi::run_viewshed, args, inputs);
}

int run_los(const Args& args, const std::string& dataset, const geodesy::PointSpec& from, const geodesy::PointSpec& to,
            const visibility::LosOptions& options, bool json) {
  return call(&ModuleAbi::run_los, args, dataset, from, to, options, json);
}

int run_cull(const Args& args, const std::string& dataset, const geodesy::PointSpec& observer,
             const std::vector<visibility::BoxSpec>& boxes, const std::vector<std::uint64_t>& ids,
             const visibility::CullOptions& options, bool json) {
  return call(&ModuleAbi::run_cull, args, dataset, observer, boxes, ids, options, json);
}

int run_datasets(const Args& args, bool json) {
  return call(&ModuleAbi::run_datasets, args, json);
}

int run_mesh_cull(const Args& args, const MeshCullInputs& inputs) {
  return call(&ModuleAbi::run_mesh_cull, args, inputs);
}

int run_trace(const Args& args, const TraceInputs& inputs) {
  return call(&ModuleAbi::run_trace, args, inputs);
}

int run_session(const Args& args, const SessionPlayback& playback, bool json, bool every_pose) {
  return call(&ModuleAbi::run_session, args, playback, json, every_pose);
}

}  // namespace horizon::cli::remote
