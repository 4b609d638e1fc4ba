// scratch_file.hpp — for fuzz targets whose input surface is a file.
#pragma once

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <string>

namespace horizon::fuzz {

// Writes `size` bytes to `name` in this process's own directory under the
// system temp dir ("horizon-fuzz-<tag>-<pid>"), replacing what was there;
// the path, or nothing when it cannot be written.
inline std::optional<std::filesystem::path> write_scratch(const char* tag, const char* name, const std::uint8_t* data,
                                                          std::size_t size) {
  static const std::filesystem::path dir = [tag] {
    auto d = std::filesystem::temp_directory_path() /
             ("horizon-fuzz-" + std::string(tag) + "-" + std::to_string(::getpid()));
    std::filesystem::create_directories(d);
    return d;
  }();
  const std::filesystem::path path = dir / name;
  FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) return std::nullopt;
  std::fwrite(data, 1, size, f);
  std::fclose(f);
  return path;
}

}  // namespace horizon::fuzz
