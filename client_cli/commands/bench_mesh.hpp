// commands/bench_mesh.hpp — `horizon bench --mesh`: TIN culling's runtime
// against error (evaluation/mesh_bench.hpp).
#pragma once

#include <string_view>

#include "args.hpp"

namespace horizon::cli {

// Flags of the mesh sweep only.
inline constexpr std::string_view kMeshOnlyFlags[] = {"--vertices", "--sectors", "--cameras", "--exact",
                                                      "--high-eye"};

int run_mesh_bench(const Args& args);

}  // namespace horizon::cli
