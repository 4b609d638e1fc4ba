// files.hpp — writing bytes received from the daemon as embedded mode writes
// its outputs: to a temporary name in the target directory, renamed on success.
#pragma once

#include <cstdint>
#include <string>

#include "horizon/common/error.hpp"

namespace horizon::cli::remote {

Status write_file_atomic(const std::string& path, const std::string& bytes);
// `width` x `height` RGB pixels (row-major from the top-left) encoded as a
// PNG by the same writer as embedded mode's (imageio::write_png), the same way.
Status write_png_atomic(const std::string& path, int width, int height, const std::uint8_t* rgb);

}  // namespace horizon::cli::remote
