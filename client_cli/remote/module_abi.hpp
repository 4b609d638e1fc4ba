// module_abi.hpp — the boundary between `horizon` and libhorizon_remote.so,
// the plugin that holds --server mode (everything under client_cli/remote/).
//
// Why a plugin: gRPC, protobuf and abseil are ~50 shared libraries, and
// loading them costs every run of `horizon` several milliseconds, about a
// quarter of a whole `horizon viewshed` on a small DEM. The executable does
// not link them; remote_loader.cpp opens this module with dlopen only when a
// command is given --server, and remote::run_* (remote.hpp) call through the
// table below.
//
// The module is built by the same build as the executable, from the same
// headers, so C++ references to the CLI's structs cross the boundary. It
// calls back into the executable (the CLI's printers and argument reader,
// the engine's GeoTIFF and PNG writers): `horizon` is linked with
// ENABLE_EXPORTS, and the module links no engine library of its own (the
// engine's static archives are position-dependent code). So every engine
// function the remote code calls must also be linked into the executable;
// today the embedded commands use all of them. If remote code comes to need
// one they do not, the module's dlopen (RTLD_NOW) fails naming the symbol,
// and the CLI test that loads the module fails with it (tests/cli).
//
// The module exports one symbol, horizon_remote_module(); the loader refuses
// a table whose version or Horizon version differs from its own. Bump
// kModuleAbiVersion whenever the table or a type it names changes.
#pragma once

#include <string>

#include "remote/remote.hpp"

namespace horizon::cli::remote {

inline constexpr int kModuleAbiVersion = 1;

// The module's implementations of remote::run_* (remote.hpp), under their
// own names so that the executable's forwarders, which it exports, do not
// interpose on them.
namespace impl {
int run_info(const Args& args, const std::string& dataset, bool json);
int run_viewshed_many(const Args& args, const ManyViewshedInputs& inputs);
int run_viewshed(const Args& args, const ViewshedInputs& inputs);
int run_los(const Args& args, const std::string& dataset, const geodesy::PointSpec& from, const geodesy::PointSpec& to,
            const visibility::LosOptions& options, bool json);
int run_cull(const Args& args, const std::string& dataset, const geodesy::PointSpec& observer,
             const std::vector<visibility::BoxSpec>& boxes, const std::vector<std::uint64_t>& ids,
             const visibility::CullOptions& options, bool json);
int run_datasets(const Args& args, bool json);
int run_mesh_cull(const Args& args, const MeshCullInputs& inputs);
int run_trace(const Args& args, const TraceInputs& inputs);
int run_session(const Args& args, const SessionPlayback& playback, bool json, bool every_pose);
}  // namespace impl

struct ModuleAbi {
  int version;                  // kModuleAbiVersion
  const char* horizon_version;  // HORIZON_VERSION of the build that made the module
  decltype(&impl::run_info) run_info;
  decltype(&impl::run_viewshed_many) run_viewshed_many;
  decltype(&impl::run_viewshed) run_viewshed;
  decltype(&impl::run_los) run_los;
  decltype(&impl::run_cull) run_cull;
  decltype(&impl::run_datasets) run_datasets;
  decltype(&impl::run_mesh_cull) run_mesh_cull;
  decltype(&impl::run_trace) run_trace;
  decltype(&impl::run_session) run_session;
};

// The name of the module's one entry point, as the loader looks it up.
inline constexpr const char* kModuleEntry = "horizon_remote_module";

}  // namespace horizon::cli::remote

// The module's one exported symbol: its table, valid for the life of the process.
extern "C" const horizon::cli::remote::ModuleAbi* horizon_remote_module();
