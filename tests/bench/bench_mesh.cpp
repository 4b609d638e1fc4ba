// bench_mesh: TINs built from a DEM and their vertex horizons, timed
// against the figures of Edmondson's thesis (docs/benchmarks.md, "TIN
// horizons").
//
//   build/tests/bench/bench_mesh --dem DEM.tif --vertices N [--sectors S/K ...] [--repeats R] [--threads T]
//
// Builds a TIN of N vertices from the DEM by greedy insertion (timed once;
// its fit to the DEM printed), then computes every vertex's horizons for
// each S/K (sectors/subsectors; default 8/1 8/2 8/4 8/8 16/4 32/2 64/1, the
// thesis's Table 2) R times (default 3) on T threads (default 0: every
// core), printing the median, and the vertices x sectors without one.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "horizon/mesh/horizons.hpp"
#include "horizon/mesh/tin_from_dem.hpp"
#include "horizon/terrain/dem_reader.hpp"

namespace {

using Clock = std::chrono::steady_clock;

[[noreturn]] void usage(const char* why) {
  std::fprintf(stderr,
               "bench_mesh: %s\nusage: bench_mesh --dem DEM.tif --vertices N [--sectors S/K ...] [--repeats R] "
               "[--threads T]\n",
               why);
  std::exit(2);
}

double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

}  // namespace

int main(int argc, char** argv) {
  std::string dem_path;
  long vertices = 0, repeats = 3, threads = 0;
  std::vector<std::pair<int, int>> shapes;
  for (int i = 1; i < argc; ++i) {
    const std::string flag = argv[i];
    if (i + 1 >= argc) usage(("missing the value of " + flag).c_str());
    const char* value = argv[++i];
    if (flag == "--dem") {
      dem_path = value;
    } else if (flag == "--vertices") {
      vertices = std::strtol(value, nullptr, 10);
    } else if (flag == "--repeats") {
      repeats = std::strtol(value, nullptr, 10);
    } else if (flag == "--threads") {
      threads = std::strtol(value, nullptr, 10);
    } else if (flag == "--sectors") {
      int s = 0, k = 0;
      if (std::sscanf(value, "%d/%d", &s, &k) != 2) usage("--sectors takes S/K, e.g. 16/4");
      shapes.emplace_back(s, k);
    } else {
      usage(("unknown flag " + flag).c_str());
    }
  }
  if (dem_path.empty() || vertices < 4) usage("--dem and --vertices (>= 4) are required");
  if (repeats < 1 || threads < 0) usage("--repeats must be >= 1 and --threads >= 0");
  if (shapes.empty()) shapes = {{8, 1}, {8, 2}, {8, 4}, {8, 8}, {16, 4}, {32, 2}, {64, 1}};

  auto dem = horizon::terrain::read_dem(dem_path);
  if (!dem.ok()) usage(dem.error().message.c_str());
  const auto built_at = Clock::now();
  auto tin = horizon::mesh::tin_from_dem(*dem, {static_cast<std::uint32_t>(vertices), 0.0});
  if (!tin.ok()) usage(tin.error().message.c_str());
  std::printf("tin: %zu vertices, %zu triangles from %d x %d cells in %.3f s; fit max %.2f m, RMSE %.3f m\n",
              tin->tin.vertices.size(), tin->tin.triangles.size(), dem->width(), dem->height(),
              seconds_since(built_at), tin->fit.max_error, tin->fit.rmse);
  for (auto [s, k] : shapes) {
    std::vector<double> times;
    std::size_t none = 0, total = 0;
    for (long r = 0; r < repeats; ++r) {
      const auto start = Clock::now();
      auto h = horizon::mesh::compute_horizons(tin->tin.vertices, {s, k, static_cast<unsigned>(threads)});
      times.push_back(seconds_since(start));
      if (!h.ok()) usage(h.error().message.c_str());
      none = static_cast<std::size_t>(std::count(h->horizon.begin(), h->horizon.end(), horizon::mesh::kNoHorizon));
      total = h->horizon.size();
    }
    std::sort(times.begin(), times.end());
    std::printf("horizons %d/%d: median %.3f s of %ld (min %.3f, max %.3f); %zu of %zu without a horizon\n", s, k,
                times[times.size() / 2], repeats, times.front(), times.back(), none, total);
  }
  return 0;
}
