// The places a plugin module is looked for (horizon/common/plugin_paths.hpp).
#include "horizon/common/plugin_paths.hpp"

#include <cstdlib>
#include <filesystem>
#include <system_error>

namespace horizon {

std::vector<std::string> plugin_candidates(const char* env, const char* module, const char* build_path) {
  if (const char* set = std::getenv(env); set && *set) return {set};
  std::vector<std::string> paths;
  std::error_code ec;
  const auto exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const auto dir = exe.parent_path();
    paths.push_back((dir / module).string());
    paths.push_back((dir / ".." / "lib" / "horizon" / module).lexically_normal().string());
  }
  if (build_path) paths.push_back(build_path);
  return paths;
}

}  // namespace horizon
