// bench_mesh: TINs built from a DEM and their vertex horizons, timed
// against the figures of Edmondson's thesis (docs/benchmarks.md, "TIN
// horizons").
//
//   build/tests/bench/bench_mesh --dem DEM.tif --vertices N [--sectors S/K ...] [--repeats R] [--threads T]
//
// Builds a TIN of N vertices from the DEM by greedy insertion (timed once;
// its fit to the DEM printed; a geographic DEM's TIN is then taken to the
// local metric frame, local_frame.hpp), then computes every vertex's horizons for
// each S/K (sectors/subsectors; default 8/1 8/2 8/4 8/8 16/4 32/2 64/1, the
// thesis's Table 2) R times (default 3) on T threads (default 0: every
// core), printing the median, and the vertices x sectors without one.
//
// With --prepare, each S/K is then prepared whole (horizons, crystal groups
// with --seeds (default 500) and --max-groups (default 1000), hierarchy;
// the thesis's Table 3 times its grouping) and culled from --cameras
// (default 200) cameras 2 m above random vertices (a fixed seed), each
// query repeated --cull-repeats (default 50) times on one thread: the
// median microseconds a query, groups tested and the share of triangles
// culled, in the approximate and then the conservative mode. --exact C checks the culls of the first C cameras against
// exact sight lines (tin_visibility.hpp) at each culled triangle's
// corners and centroid, printing the false-hidden triangles.
//
// --isa scalar,avx2,avx512 times the cull's forms (cull.hpp) in the same
// run: each camera's queries go to every form in turn, so noise falls on
// all alike; each form's median is printed with its ratio to the first
// form's, and the forms' answers are checked equal (default: the CPU's
// best form alone; a form the CPU lacks is refused). --view W gives each
// camera a view W degrees wide facing a random way (default: all around).
#include <algorithm>
#include <chrono>
#include <random>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "horizon/mesh/cull.hpp"
#include "horizon/mesh/horizons.hpp"
#include "horizon/mesh/local_frame.hpp"
#include "horizon/mesh/prepared_mesh.hpp"
#include "horizon/mesh/tin_visibility.hpp"
#include "horizon/mesh/tin_from_dem.hpp"
#include "horizon/terrain/dem_reader.hpp"
#include "common/simd_isa.hpp"  // core/src: the cull's instruction-set cap, for --isa

namespace {

using Clock = std::chrono::steady_clock;

[[noreturn]] void usage(const char* why) {
  std::fprintf(stderr,
               "bench_mesh: %s\nusage: bench_mesh --dem DEM.tif --vertices N [--sectors S/K ...] [--repeats R] "
               "[--threads T] [--prepare [--seeds N] [--max-groups G] [--cameras C] [--cull-repeats R] [--exact C] [--isa scalar,avx2,avx512] [--view W]]\n",
               why);
  std::exit(2);
}

double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

using horizon::simd_isa::Isa;

const char* isa_name(Isa isa) {
  return isa == Isa::kScalar ? "scalar" : isa == Isa::kAvx2 ? "avx2" : "avx512";
}

struct CullBench {
  long seeds = 500, max_groups = 1000, cameras = 200, cull_repeats = 50, exact = 0;
  std::vector<Isa> forms;  // empty: the CPU's best
  double view = 0.0;       // degrees; 0: all around
};

bool same_answer(const horizon::mesh::CullAnswer& a, const horizon::mesh::CullAnswer& b) {
  return a.visible_groups == b.visible_groups && a.groups_tested == b.groups_tested &&
         a.groups_culled == b.groups_culled && a.frustum_culled == b.frustum_culled &&
         a.triangles_culled == b.triangles_culled && a.triangles_visible == b.triangles_visible;
}

void prepare_and_cull(const horizon::mesh::Tin& tin, int s, int k, long threads, const CullBench& o) {
  using namespace horizon::mesh;
  PrepareOptions options;
  options.horizons = {s, k, static_cast<unsigned>(threads)};
  options.crystals.seeds = static_cast<int>(o.seeds);
  options.crystals.max_groups = static_cast<int>(o.max_groups);
  const auto start = Clock::now();
  auto mesh = prepare_mesh(tin, options);
  const double total = seconds_since(start);
  if (!mesh.ok()) usage(mesh.error().message.c_str());
  std::printf("prepare %d/%d: %.3f s (horizons %.3f, grouping %.3f, hierarchy %.3f, walls %.3f); %u groups, %zu nodes, %u levels, "
              "%zu top-level, %d orphan passes, %u always-visible triangles\n",
              s, k, total, mesh->stats.horizon_seconds, mesh->stats.grouping_seconds, mesh->stats.hierarchy_seconds,
              mesh->stats.wall_seconds, mesh->stats.leaf_groups, mesh->groups.size(), mesh->stats.levels, mesh->top_level.size(),
              mesh->stats.orphan_passes, mesh->always_visible_count);
  const TinVisibility vis(mesh->tin);
  const std::vector<Isa> forms = o.forms.empty() ? std::vector<Isa>{horizon::simd_isa::cpu_isa()} : o.forms;
  for (CullMode mode : {CullMode::kApproximate, CullMode::kConservative}) {
  const char* mode_name = mode == CullMode::kApproximate ? "approximate" : "conservative";
  std::mt19937_64 rng(1);
  std::uniform_int_distribution<std::size_t> pick(0, tin.vertices.size() - 1);
  std::uniform_real_distribution<double> facing(0.0, 360.0);
  std::vector<std::vector<double>> micros(forms.size());
  std::uint64_t tested = 0, culled = 0, triangles = 0, frustum = 0, disagree = 0;
  std::uint64_t checked = 0, false_hidden = 0;
  for (long c = 0; c < o.cameras; ++c) {
    TinVertex camera = tin.vertices[pick(rng)];
    camera.z += 2.0;
    CullQuery query{camera, {}, {}, mode};
    if (o.view > 0.0) {
      query.azimuth_from = facing(rng);
      query.azimuth_to = *query.azimuth_from + o.view;
    }
    CullAnswer answer, first;
    for (std::size_t f = 0; f < forms.size(); ++f) {
      horizon::simd_isa::isa_limit() = forms[f];
      const auto at = Clock::now();
      for (long r = 0; r < o.cull_repeats; ++r) answer = std::move(*cull(*mesh, query));
      micros[f].push_back(seconds_since(at) / static_cast<double>(o.cull_repeats) * 1e6);
      if (f == 0)
        first = answer;
      else if (!same_answer(first, answer))
        ++disagree;
    }
    horizon::simd_isa::isa_limit() = Isa::kAvx512;
    answer = std::move(first);
    tested += answer.groups_tested;
    frustum += answer.frustum_culled;
    culled += answer.triangles_culled;
    triangles += mesh->tin.triangles.size();
    if (c >= o.exact) continue;
    const std::vector<std::uint8_t> drawn = triangle_states(*mesh, answer);
    for (std::size_t t = 0; t < drawn.size(); ++t) {
      if (drawn[t]) continue;
      ++checked;
      const TinTriangle& tri = mesh->tin.triangles[t];
      const TinVertex& a = mesh->tin.vertices[tri[0]];
      const TinVertex& b = mesh->tin.vertices[tri[1]];
      const TinVertex& d = mesh->tin.vertices[tri[2]];
      const TinVertex centroid{(a.x + b.x + d.x) / 3, (a.y + b.y + d.y) / 3, (a.z + b.z + d.z) / 3};
      if (vis.visible(camera, a) || vis.visible(camera, b) || vis.visible(camera, d) || vis.visible(camera, centroid))
        ++false_hidden;
    }
  }
  double first_median = 0.0;
  for (std::size_t f = 0; f < forms.size(); ++f) {
    std::vector<double>& m = micros[f];
    std::sort(m.begin(), m.end());
    const double median = m[m.size() / 2];
    if (f == 0) first_median = median;
    std::printf("cull %d/%d %s [%s]: median %.2f us a query (p90 %.2f, max %.2f) over %ld cameras", s, k, mode_name,
                isa_name(forms[f]), median, m[m.size() * 9 / 10], m.back(), o.cameras);
    if (f > 0) std::printf(", %.2fx the %s median", first_median / median, isa_name(forms[0]));
    std::printf("\n");
  }
  std::printf("cull %d/%d %s: %.1f groups tested; %.2f %% of triangles culled", s, k, mode_name,
              static_cast<double>(tested) / static_cast<double>(o.cameras),
              100.0 * static_cast<double>(culled) / static_cast<double>(triangles));
  if (o.view > 0.0)
    std::printf("; %.1f groups culled by the %.0f-degree view", static_cast<double>(frustum) / static_cast<double>(o.cameras),
                o.view);
  if (forms.size() > 1) std::printf("; forms disagreeing: %llu of %ld cameras", static_cast<unsigned long long>(disagree), o.cameras);
  if (o.exact > 0)
    std::printf("; exact check of %ld cameras: %llu of %llu culled triangles seen", std::min(o.exact, o.cameras),
                static_cast<unsigned long long>(false_hidden), static_cast<unsigned long long>(checked));
  std::printf("\n");
  }
}

}  // namespace

int main(int argc, char** argv) {
  std::string dem_path;
  long vertices = 0, repeats = 3, threads = 0;
  std::vector<std::pair<int, int>> shapes;
  bool prepare = false;
  CullBench cull_bench;
  for (int i = 1; i < argc; ++i) {
    const std::string flag = argv[i];
    if (flag == "--prepare") {
      prepare = true;
      continue;
    }
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
    } else if (flag == "--seeds") {
      cull_bench.seeds = std::strtol(value, nullptr, 10);
    } else if (flag == "--max-groups") {
      cull_bench.max_groups = std::strtol(value, nullptr, 10);
    } else if (flag == "--cameras") {
      cull_bench.cameras = std::strtol(value, nullptr, 10);
    } else if (flag == "--cull-repeats") {
      cull_bench.cull_repeats = std::strtol(value, nullptr, 10);
    } else if (flag == "--exact") {
      cull_bench.exact = std::strtol(value, nullptr, 10);
    } else if (flag == "--view") {
      cull_bench.view = std::strtod(value, nullptr);
      if (!(cull_bench.view > 0.0 && cull_bench.view < 360.0)) usage("--view takes degrees in (0, 360)");
    } else if (flag == "--isa") {
      std::string list = value;
      for (std::size_t at = 0; at <= list.size();) {
        const std::size_t comma = std::min(list.find(',', at), list.size());
        const std::string name = list.substr(at, comma - at);
        const Isa isa = name == "scalar" ? Isa::kScalar : name == "avx2" ? Isa::kAvx2 : name == "avx512" ? Isa::kAvx512
                                                                                               : static_cast<Isa>(-1);
        if (static_cast<int>(isa) < 0) usage(("--isa takes scalar, avx2 and avx512, not '" + name + "'").c_str());
        if (horizon::simd_isa::cpu_isa() < isa) usage(("this CPU does not run " + name).c_str());
        cull_bench.forms.push_back(isa);
        at = comma + 1;
      }
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
  if (cull_bench.cameras < 1 || cull_bench.cull_repeats < 1 || cull_bench.exact < 0)
    usage("--cameras and --cull-repeats must be >= 1, --exact >= 0");
  if (shapes.empty()) shapes = {{8, 1}, {8, 2}, {8, 4}, {8, 8}, {16, 4}, {32, 2}, {64, 1}};

  auto dem = horizon::terrain::read_dem(dem_path);
  if (!dem.ok()) usage(dem.error().message.c_str());
  const auto built_at = Clock::now();
  auto tin = horizon::mesh::tin_from_dem(*dem, {static_cast<std::uint32_t>(vertices), 0.0});
  if (!tin.ok()) usage(tin.error().message.c_str());
  // Horizons compare slopes: a geographic DEM's TIN goes to metres first.
  auto frame = horizon::mesh::LocalFrame::for_dem(*dem);
  if (!frame.ok()) usage(frame.error().message.c_str());
  frame->to_local(tin->tin);
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
    if (prepare) prepare_and_cull(tin->tin, s, k, threads, cull_bench);
  }
  return 0;
}
