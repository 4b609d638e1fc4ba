// horizon/common/plugin_paths.hpp — where a plugin module is looked for.
//
// Parts with heavy libraries are plugins, opened with dlopen only by a run
// that needs them: OpenImageIO's PNG writer (libhorizon_imageio.so, core)
// and the CLI's --server mode (libhorizon_remote.so, gRPC). Both look in
// the same places, in this order, and the first that loads wins:
//   1. $<env> when set and not empty (then nothing else);
//   2. the module beside the executable;
//   3. ../lib/horizon/<module> from the executable's directory (the
//      installed layout: bin/, lib/horizon/);
//   4. `build_path`, where this build put it (when given), so that every
//      build directory (Release, ASan, TSan) runs its own module.
#pragma once

#include <string>
#include <vector>

namespace horizon {

std::vector<std::string> plugin_candidates(const char* env, const char* module, const char* build_path);

}  // namespace horizon
