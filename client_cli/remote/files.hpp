// files.hpp — writing bytes received from the daemon as embedded mode writes
// its outputs: to a temporary name in the target directory, renamed on success.
#pragma once

#include <string>

#include "horizon/common/error.hpp"

namespace horizon::cli::remote {

Status write_file_atomic(const std::string& path, const std::string& bytes);

}  // namespace horizon::cli::remote
