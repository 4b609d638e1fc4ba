#include "remote/files.hpp"

#include <unistd.h>

#include <cstdio>
#include <filesystem>

#include "horizon/imageio/imageio.hpp"

namespace horizon::cli::remote {

Status write_file_atomic(const std::string& path, const std::string& bytes) {
  const std::string temporary = path + ".tmp-" + std::to_string(::getpid());
  std::FILE* f = std::fopen(temporary.c_str(), "wb");
  if (!f) return make_error(ErrorCode::kIoError, "'" + path + "': cannot be created", path);
  const bool written = std::fwrite(bytes.data(), 1, bytes.size(), f) == bytes.size();
  const bool closed = std::fclose(f) == 0;
  std::error_code ec;
  if (!written || !closed) {
    std::filesystem::remove(temporary, ec);
    return make_error(ErrorCode::kIoError, "'" + path + "': write failed", path);
  }
  std::filesystem::rename(temporary, path, ec);
  if (ec) {
    std::filesystem::remove(temporary, ec);
    return make_error(ErrorCode::kIoError, "'" + path + "': cannot rename into place: " + ec.message(), path);
  }
  return Status::Ok();
}

Status write_png_atomic(const std::string& path, int width, int height, const std::uint8_t* rgb) {
  const std::string temporary = path + ".tmp-" + std::to_string(::getpid());
  std::error_code ec;
  if (Status written = imageio::write_png(temporary, width, height, 3, rgb); !written.ok()) {
    std::filesystem::remove(temporary, ec);
    return written;
  }
  std::filesystem::rename(temporary, path, ec);
  if (ec) {
    std::filesystem::remove(temporary, ec);
    return make_error(ErrorCode::kIoError, "'" + path + "': cannot rename into place: " + ec.message(), path);
  }
  return Status::Ok();
}

}  // namespace horizon::cli::remote
