// commands/bench_out.cpp — the bench sweeps' --out directory (bench_out.hpp).
#include "commands/bench_out.hpp"

#include <filesystem>
#include <system_error>

namespace horizon::cli {

Result<std::string> bench_out_dir(const Args& args) {
  const std::string dir = args.text("--out").value_or("bench-out");
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec || !std::filesystem::is_directory(dir))
    return make_error(ErrorCode::kIoError, "--out: cannot create directory '" + dir + "'", "--out");
  return dir;
}

}  // namespace horizon::cli
