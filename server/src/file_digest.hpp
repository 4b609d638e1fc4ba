// file_digest.hpp — a file's SHA-256, for datasets.NAME.sha256: a DEM whose
// bytes are not the ones the operator recorded is refused on load.
#pragma once

#include <filesystem>
#include <string>

#include "horizon/common/error.hpp"

namespace horizon::server {

// The file's SHA-256 as 64 lowercase hex digits; kIoError naming the file when it cannot be read.
Result<std::string> sha256_of_file(const std::filesystem::path& path);

// True for 64 hex digits (either case).
bool is_sha256_hex(const std::string& text);

}  // namespace horizon::server
