// module.cpp — libhorizon_remote.so's entry point: the table of its
// --server implementations (module_abi.hpp).
#include "remote/module_abi.hpp"

#ifndef HORIZON_VERSION
#error "HORIZON_VERSION must be defined by the build"
#endif

namespace horizon::cli::remote {
namespace {

constexpr ModuleAbi kAbi{
    .version = kModuleAbiVersion,
    .horizon_version = HORIZON_VERSION,
    .run_info = &impl::run_info,
    .run_viewshed_many = &impl::run_viewshed_many,
    .run_viewshed = &impl::run_viewshed,
    .run_los = &impl::run_los,
    .run_cull = &impl::run_cull,
    .run_datasets = &impl::run_datasets,
    .run_mesh_cull = &impl::run_mesh_cull,
    .run_trace = &impl::run_trace,
    .run_session = &impl::run_session,
};

}  // namespace
}  // namespace horizon::cli::remote

extern "C" __attribute__((visibility("default"))) const horizon::cli::remote::ModuleAbi* horizon_remote_module() {
  return &horizon::cli::remote::kAbi;
}
