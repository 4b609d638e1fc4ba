// commands/bench_out.hpp — where a bench sweep writes its files: the
// directory --out names (default bench-out), created with its parents
// when missing. The region and mesh sweeps share it.
#pragma once

#include <string>

#include "args.hpp"
#include "horizon/common/error.hpp"

namespace horizon::cli {

// The directory, existing once this returns; kIoError naming --out and the
// path when it cannot be made (a file in the way, no permission).
Result<std::string> bench_out_dir(const Args& args);

}  // namespace horizon::cli
