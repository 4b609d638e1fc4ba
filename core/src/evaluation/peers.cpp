// peers.cpp — gdal_viewshed and GRASS r.viewshed as subprocesses (peers.hpp).
//
// Commands are built from numbers and paths only; every path is single-quoted
// for the shell. Timing is wall time (steady_clock) around the process for
// GDAL, and the `date +%s.%N` stamps printed around r.viewshed inside the
// GRASS session.
#include "horizon/evaluation/peers.hpp"

#include <sys/wait.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace horizon::evaluation {
namespace {

std::string quote(const std::string& s) {
  std::string out = "'";
  for (char c : s) {
    if (c == '\'')
      out += "'\\''";
    else
      out += c;
  }
  return out + "'";
}

std::string num(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

struct Output {
  int status = -1;
  std::string text;
};

// Runs `command` through /bin/sh, stdout and stderr captured together.
Output run_shell(const std::string& command) {
  Output out;
  FILE* pipe = ::popen((command + " 2>&1").c_str(), "r");
  if (!pipe) return out;
  std::array<char, 4096> buf{};
  std::size_t n = 0;
  while ((n = std::fread(buf.data(), 1, buf.size(), pipe)) > 0) out.text.append(buf.data(), n);
  const int status = ::pclose(pipe);
  out.status = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return out;
}

std::string tail(const std::string& text, std::size_t n = 600) {
  return text.size() <= n ? text : "..." + text.substr(text.size() - n);
}

void median_min(std::vector<double> times, PeerRun& run) {
  std::sort(times.begin(), times.end());
  run.seconds_min = times.front();
  const std::size_t m = times.size() / 2;
  run.seconds_median = times.size() % 2 ? times[m] : 0.5 * (times[m - 1] + times[m]);
}

}  // namespace

bool peer_installed(std::string_view peer) {
  const std::string program = peer == "gdal" ? "gdal_viewshed" : peer == "grass" ? "grass" : "";
  if (program.empty()) return false;
  return run_shell("command -v " + program + " >/dev/null").status == 0;
}

Result<PeerRun> run_gdal_viewshed(const PeerRequest& q) {
  if (!peer_installed("gdal"))
    return make_error(ErrorCode::kNotFound, "gdal_viewshed is not installed (Debian package gdal-bin)", "gdal");
  PeerRun run;
  run.timing = "process";
  run.mask_path = q.work_dir + "/gdal_mask.tif";
  run.heights_path = q.work_dir + "/gdal_heights.tif";
  std::string common = "gdal_viewshed -q -ox " + num(q.x) + " -oy " + num(q.y) + " -oz " + num(q.observer_height) +
                       " -tz " + num(q.target_height) + " -cc " + num(q.curvature);
  if (std::isfinite(q.max_distance)) common += " -md " + num(q.max_distance);
  const std::string timed = common + " -vv 1 -iv 0 -ov 255 " + quote(q.dem_path) + " " + quote(run.mask_path);
  run.command = timed;
  std::vector<double> times;
  for (int i = 0; i < std::max(1, q.repeats); ++i) {
    std::remove(run.mask_path.c_str());
    const auto start = std::chrono::steady_clock::now();
    const Output out = run_shell(timed);
    times.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    if (out.status != 0)
      return make_error(ErrorCode::kInternal,
                        "gdal_viewshed failed (exit " + std::to_string(out.status) + "): " + tail(out.text), "gdal");
  }
  median_min(times, run);
  // Heights for the OHF error, untimed. GROUND is the minimum visible target
  // height above the ground (0 where visible); DEM mode is not that.
  std::remove(run.heights_path.c_str());
  const Output heights = run_shell(common + " -om GROUND " + quote(q.dem_path) + " " + quote(run.heights_path));
  if (heights.status != 0) run.heights_path.clear();
  return run;
}

Result<PeerRun> run_grass_viewshed(const PeerRequest& q) {
  if (!peer_installed("grass"))
    return make_error(ErrorCode::kNotFound, "GRASS is not installed (Debian package grass-core)", "grass");
  PeerRun run;
  run.timing = "r.viewshed module";
  run.mask_path = q.work_dir + "/grass_mask.tif";
  std::string viewshed = "r.viewshed -b";
  if (q.curvature > 0) viewshed += " -c -r refraction_coeff=" + num(1.0 - q.curvature);
  viewshed += " input=dem output=vs coordinates=" + num(q.x) + "," + num(q.y) +
              " observer_elevation=" + num(q.observer_height) + " target_elevation=" + num(q.target_height) +
              " memory=2000 --quiet --overwrite";
  if (std::isfinite(q.max_distance)) viewshed += " max_distance=" + num(q.max_distance);
  run.command = viewshed;
  const std::string script_path = q.work_dir + "/grass_viewshed.sh";
  {
    std::ofstream script(script_path);
    script << "set -e\n"
           << "r.in.gdal -o input=" << quote(q.dem_path) << " output=dem --quiet --overwrite\n"
           << "g.region raster=dem\n"
           << "for i in $(seq " << std::max(1, q.repeats) << "); do\n"
           << "  t0=$(date +%s.%N)\n"
           << "  " << viewshed << "\n"
           << "  t1=$(date +%s.%N)\n"
           << "  echo \"HORIZON_TIME $t0 $t1\"\n"
           << "done\n"
           << "r.out.gdal -f input=vs output=" << quote(run.mask_path)
           << " format=GTiff type=Byte nodata=255 --quiet --overwrite\n";
    if (!script) return make_error(ErrorCode::kIoError, "cannot write " + script_path, "work_dir");
  }
  std::remove(run.mask_path.c_str());
  const Output out = run_shell("grass --tmp-location " + quote(q.dem_path) + " --exec bash " + quote(script_path));
  std::remove(script_path.c_str());
  std::vector<double> times;
  std::istringstream lines(out.text);
  for (std::string line; std::getline(lines, line);) {
    if (!line.starts_with("HORIZON_TIME ")) continue;
    double t0 = 0, t1 = 0;
    if (std::sscanf(line.c_str() + 13, "%lf %lf", &t0, &t1) == 2) times.push_back(t1 - t0);
  }
  if (out.status != 0 || times.empty())
    return make_error(ErrorCode::kInternal,
                      "GRASS r.viewshed failed (exit " + std::to_string(out.status) + "): " + tail(out.text), "grass");
  median_min(times, run);
  return run;
}

}  // namespace horizon::evaluation
