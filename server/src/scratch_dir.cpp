#include "scratch_dir.hpp"

#include <stdlib.h>  // mkdtemp

#include <cerrno>
#include <cstring>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

namespace horizon::server {

Result<ScratchDir> ScratchDir::create(const std::filesystem::path& parent) {
  std::string name = (parent / "horizond-XXXXXX").string();
  std::vector<char> buffer(name.begin(), name.end());
  buffer.push_back('\0');
  if (::mkdtemp(buffer.data()) == nullptr) {
    const int err = errno;
    return make_error(
        ErrorCode::kIoError,
        "scratch_dir '" + parent.string() + "': cannot make a private directory in it: " + std::strerror(err),
        "scratch_dir");
  }
  return ScratchDir(std::filesystem::path(buffer.data()));
}

ScratchDir& ScratchDir::operator=(ScratchDir&& other) noexcept {
  if (this != &other) {
    remove();
    path_ = std::move(other.path_);
    other.path_.clear();
  }
  return *this;
}

ScratchDir::~ScratchDir() {
  remove();
}

void ScratchDir::remove() {
  if (path_.empty()) return;
  std::error_code ec;
  std::filesystem::remove_all(path_, ec);
  path_.clear();
}

}  // namespace horizon::server
