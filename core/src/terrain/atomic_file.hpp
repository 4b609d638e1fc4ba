// atomic_file.hpp — private helper for writing a file all-or-nothing.
//
// Writers produce "<path>.tmp-<pid>-<n>" in the destination's own directory
// (so rename(2) never crosses a file system), flush it to disk, and rename it
// over `path` only when everything succeeded. POSIX rename is atomic: readers
// see the old file or the new one, never a half-written one. The temporary is
// removed on every failure path by the guard's destructor.
//
// create() makes the temporary before the writer opens it, with O_EXCL and
// O_NOFOLLOW: a name planted in a shared directory (a symlink to someone
// else's file, say) is never written through; the next name is tried.
#pragma once

#include <fcntl.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <string>

#include "horizon/common/error.hpp"

namespace horizon::terrain::detail {

class AtomicFile {
 public:
  explicit AtomicFile(std::string path) : path_(std::move(path)) {}
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;
  ~AtomicFile() {
    if (created_ && !committed_) std::remove(temp_.c_str());
  }

  // Creates the (empty) temporary under a name nothing else holds. `what`
  // prefixes messages ("geotiff", "preview").
  Status create(const char* what) {
    static std::atomic<unsigned> counter{0};
    constexpr int kAttempts = 64;
    int err = 0;
    for (int attempt = 0; attempt < kAttempts; ++attempt) {
      temp_ = path_ + ".tmp-" + std::to_string(::getpid()) + "-" + std::to_string(counter.fetch_add(1));
      const int fd = ::open(temp_.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0666);
      if (fd >= 0) {
        ::close(fd);
        created_ = true;
        return Status::Ok();
      }
      err = errno;
      if (err != EEXIST) break;
    }
    return make_error(ErrorCode::kIoError,
                      std::string(what) + " '" + path_ + "': cannot create a temporary file beside it: " +
                          std::strerror(err),
                      path_);
  }

  const std::string& temp_path() const { return temp_; }  // after create()

  // Flushes the finished temporary to disk and renames it over the target.
  // `what` prefixes messages ("geotiff", "preview").
  Status commit(const char* what) {
    HORIZON_RETURN_IF_ERROR(flush(what));
    return rename_into_place(what);
  }

  // commit()'s two steps, for a caller that flushes a file early and puts
  // it in place later: the temporary's bytes on disk ...
  Status flush(const char* what) {
    const int fd = ::open(temp_.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0 || ::fsync(fd) != 0) {
      const int err = errno;
      if (fd >= 0) ::close(fd);
      return make_error(ErrorCode::kIoError,
                        std::string(what) + " '" + path_ + "': cannot flush temporary file: " + std::strerror(err),
                        path_);
    }
    ::close(fd);
    return Status::Ok();
  }

  // ... and the flushed temporary renamed over the target.
  Status rename_into_place(const char* what) {
    if (std::rename(temp_.c_str(), path_.c_str()) != 0) {
      const int err = errno;
      return make_error(
          ErrorCode::kIoError,
          std::string(what) + " '" + path_ + "': cannot rename temporary file into place: " + std::strerror(err),
          path_);
    }
    committed_ = true;
    return Status::Ok();
  }

 private:
  std::string path_;
  std::string temp_;
  bool created_ = false;
  bool committed_ = false;
};

}  // namespace horizon::terrain::detail
