// scratch_dir.hpp — the daemon's private directory for encoding GeoTIFF and
// PNG bytes (raster_files.hpp).
//
// Made at start inside the configured scratch_dir (often a shared /tmp) as
// "horizond-XXXXXX" by mkdtemp(3): a fresh name, mode 0700, so no other user
// can plant or read a file in it. Removed with everything in it when the
// daemon stops. The writers create their files there exclusively too
// (O_EXCL, O_NOFOLLOW: terrain/atomic_file.hpp).
#pragma once

#include <filesystem>

#include "horizon/common/error.hpp"

namespace horizon::server {

class ScratchDir {
 public:
  // A private directory under `parent`; the error names scratch_dir.
  static Result<ScratchDir> create(const std::filesystem::path& parent);

  ScratchDir() = default;
  ScratchDir(ScratchDir&& other) noexcept : path_(std::move(other.path_)) { other.path_.clear(); }
  ScratchDir& operator=(ScratchDir&& other) noexcept;
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;
  ~ScratchDir();  // removes the directory and what is left in it

  const std::filesystem::path& path() const { return path_; }

 private:
  explicit ScratchDir(std::filesystem::path path) : path_(std::move(path)) {}
  void remove();

  std::filesystem::path path_;
};

}  // namespace horizon::server
