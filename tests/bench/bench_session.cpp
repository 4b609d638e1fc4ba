// bench_session: a flight through clip-map sessions against the ways a
// simulator could do without them (docs/benchmarks.md, "Clip-map sessions").
//
//   build/tests/bench/bench_session --dem DEM.tif --x X --y Y [options]
//
// The flight starts at (X, Y) (the DEM's CRS), heads east at --speed m/s
// (default 250), --height m above the ground (default 100), one pose every
// 1/--rate s (default 60 Hz) for --poses poses (default 600). --boxes boxes
// (default 10 000) of 20 x 20 m, 0-30 m tall on the ground, are scattered
// within --radius m (default 10 000) of the start. Each pose is answered by
//   --baseline session   the engine's ClipSession: levels loaded on its own
//                        thread on their schedules (the design);
//   --baseline sync-all  the patent's prior art: every level brought to the
//                        pose before each answer, on the answering thread;
//   --baseline cullboxes today's per-request path: plan_cull_boxes +
//                        run_cull_boxes through the warm block cache (no clip-map).
// --sessions K runs K sessions at once, each on its own thread and clock
// (session baselines only). --accuracy N compares every Nth pose's answer
// with exact culling (R3's OHF, bit for bit) of the same boxes: false hidden
// (R3 sees it, reported hidden) and false visible. Prints one line per
// baseline: per-pose time p50 / p99 / max (from the start of the pose's
// work), the poses late for their slot, the time from a pose's slot to its
// answer (p99, max: a queue behind a slow pose shows here), sub-tiles and
// bytes loaded per pose, fallbacks. --viewshed-radius M adds a viewshed
// of the cells within M metres to every answer (timed with it); with
// --accuracy its mask is compared with exact's (run_viewshed, Algorithm::kExact)
// on the cells both answer: IoU of the visible sets, false hidden and visible.
//
// Options: --mode fast|conservative, --levels L --level-size N --subtile T
// (default 0 = enough to cover, 1024, 64), --rays R (1024), --threads N culling threads a session
// (1; 0 = all cores), --cache-mb M (256), --backend cpu|gpu (session
// baselines: trace on a GL context, one per session; prints the answers
// traced there and the level bytes copied to the context a pose), --isa
// scalar|avx2 (caps the clip-map sampler's SIMD form; default: the CPU's best).
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <memory>
#include <mutex>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "horizon/clipmap/clipmap_updater.hpp"
#include "horizon/clipmap/session.hpp"
#include "horizon/gpu/context_pool.hpp"
#include "horizon/terrain/block_cache.hpp"
#include "horizon/terrain/source.hpp"
#include "horizon/terrain/source_pyramid.hpp"
#include "horizon/visibility/plan.hpp"
#include "visibility/simd.hpp"

using namespace horizon;
using Clock = std::chrono::steady_clock;

namespace {

struct Options {
  std::string dem, baseline = "session", mode = "fast", backend = "cpu", isa;
  double x = 0, y = 0, speed = 250, height = 100, rate = 60, radius = 10000, viewshed_radius = 0;
  int poses = 600, boxes = 10000, sessions = 1, accuracy = 0;
  int levels = 0, level_size = 1024, subtile = 64, rays = 1024, cache_mb = 256, threads = 1;
};

[[noreturn]] void usage(const char* why) {
  std::fprintf(stderr, "bench_session: %s\n(see the comment at the top of tests/bench/bench_session.cpp)\n", why);
  std::exit(2);
}

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string flag = argv[i];
    if (i + 1 >= argc) usage(("missing value after " + flag).c_str());
    const char* v = argv[++i];
    auto num = [&] { return std::strtod(v, nullptr); };
    if (flag == "--dem") o.dem = v;
    else if (flag == "--baseline") o.baseline = v;
    else if (flag == "--mode") o.mode = v;
    else if (flag == "--backend") o.backend = v;
    else if (flag == "--isa") o.isa = v;
    else if (flag == "--x") o.x = num();
    else if (flag == "--y") o.y = num();
    else if (flag == "--speed") o.speed = num();
    else if (flag == "--height") o.height = num();
    else if (flag == "--rate") o.rate = num();
    else if (flag == "--radius") o.radius = num();
    else if (flag == "--viewshed-radius") o.viewshed_radius = num();
    else if (flag == "--poses") o.poses = static_cast<int>(num());
    else if (flag == "--boxes") o.boxes = static_cast<int>(num());
    else if (flag == "--sessions") o.sessions = static_cast<int>(num());
    else if (flag == "--accuracy") o.accuracy = static_cast<int>(num());
    else if (flag == "--levels") o.levels = static_cast<int>(num());
    else if (flag == "--level-size") o.level_size = static_cast<int>(num());
    else if (flag == "--subtile") o.subtile = static_cast<int>(num());
    else if (flag == "--rays") o.rays = static_cast<int>(num());
    else if (flag == "--cache-mb") o.cache_mb = static_cast<int>(num());
    else if (flag == "--threads") o.threads = static_cast<int>(num());
    else usage(("unknown flag " + flag).c_str());
  }
  if (o.dem.empty()) usage("--dem is required");
  if (o.baseline != "session" && o.baseline != "sync-all" && o.baseline != "cullboxes") usage("unknown --baseline");
  if (o.backend != "cpu" && o.backend != "gpu") usage("--backend is cpu or gpu");
  if (!o.isa.empty() && o.isa != "scalar" && o.isa != "avx2") usage("--isa is scalar or avx2");
  if (o.backend == "gpu" && o.baseline == "cullboxes") usage("--backend gpu traces sessions: not with --baseline cullboxes");
  if (o.mode != "fast" && o.mode != "conservative") usage("unknown --mode");
  return o;
}

// Boxes within `radius` of (x, y), on the ground (their z from the source).
std::vector<clipmap::SessionBox> make_boxes(const Options& o, const terrain::ElevationSource& source,
                                            terrain::BlockCache& cache, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> angle(0, 2 * M_PI), unit(0, 1), tall(0, 30);
  const terrain::GeoTransform& t = source.header().georef.transform;
  std::vector<clipmap::SessionBox> out;
  while (static_cast<int>(out.size()) < o.boxes) {
    const double r = o.radius * std::sqrt(unit(rng)), a = angle(rng);
    const double bx = o.x + r * std::cos(a), by = o.y + r * std::sin(a);
    const int col = static_cast<int>(std::floor(t.col_at(bx))), row = static_cast<int>(std::floor(t.row_at(by)));
    if (col < 1 || row < 1 || col + 3 >= source.width() || row + 3 >= source.height()) continue;
    auto ground = source.read({col - 1, row - 1, col + 3, row + 3}, &cache);
    if (!ground.ok()) continue;
    float least = INFINITY;
    for (int j = 0; j < ground->height(); ++j)
      for (int i = 0; i < ground->width(); ++i) least = std::min(least, ground->elevation.at(i, j));
    if (!std::isfinite(least)) continue;  // on a void: no ground to stand on
    clipmap::SessionBox b;
    b.id = out.size() + 1;
    b.box = {geodesy::PointFrame::kDatasetCrs, bx - 10, by - 10, bx + 10, by + 10, least, least + tall(rng)};
    out.push_back(b);
  }
  return out;
}

clipmap::SessionPose pose_at(const Options& o, int i) {
  clipmap::SessionPose p;
  p.position.x = o.x + o.speed * i / o.rate;
  p.position.y = o.y;
  p.position.height = o.height;
  p.east_per_s = o.speed;
  p.seq = static_cast<std::uint64_t>(i + 1);
  return p;
}

struct Timing {
  std::vector<double> seconds;  // a pose's answer, from the start of its work
  std::vector<double> lag;      // a pose's answer, from its slot: its wait behind the session's earlier poses too
  std::uint64_t late = 0, subtiles = 0, bytes = 0, samples = 0, fallbacks = 0, answers = 0, rings = 0, tests = 0;
  std::uint64_t on_gpu = 0, uploaded = 0;
  double cull_seconds = 0;
  std::uint64_t false_hidden = 0, false_visible = 0, checked = 0;
  std::uint64_t cells = 0, cells_false_hidden = 0, cells_false_visible = 0, cells_both = 0, cells_either = 0;
  double viewshed_seconds = 0;
  std::mutex mutex;
};

// Exact culling (R3's OHF) of the boxes from a pose: visible or not, per box.
std::vector<bool> exact_states(const terrain::ElevationSource& source, terrain::BlockCache& cache,
                               const clipmap::SessionPose& pose, const std::vector<clipmap::SessionBox>& boxes) {
  visibility::CullQuery q;
  q.observer = pose.position;
  for (const auto& b : boxes) q.boxes.push_back(b.box);
  q.options.viewshed.algorithm = visibility::Algorithm::kExact;
  q.options.viewshed.threads = 0;
  auto plan = visibility::plan_cull_boxes(source, q);
  if (!plan.ok()) usage(plan.error().message.c_str());
  auto run = visibility::run_cull_boxes(*plan, source, &cache);
  if (!run.ok()) usage(run.error().message.c_str());
  std::vector<bool> out;
  for (const auto& b : run->result.boxes) out.push_back(b.state != visibility::Visibility::kOccluded);
  return out;
}

// The session's viewshed mask against exact's from the same pose, on the cells both answer.
void compare_viewshed(const Options& o, const terrain::ElevationSource& source, terrain::BlockCache& cache,
                      const clipmap::SessionPose& pose, const clipmap::ViewshedSummary& ours, Timing& timing) {
  visibility::ViewshedQuery q{pose.position, {}};
  q.options.algorithm = visibility::Algorithm::kExact;
  q.options.max_distance = o.viewshed_radius;
  q.options.threads = 0;
  auto plan = visibility::plan_viewshed(source, q);
  if (!plan.ok()) usage(plan.error().message.c_str());
  auto run = visibility::run_viewshed(*plan, source, &cache);
  if (!run.ok()) usage(run.error().message.c_str());
  const terrain::Grid<std::uint8_t> exact = visibility::visibility_mask(run->result, 0.0);
  for (int r = 0; r < exact.height(); ++r)
    for (int c = 0; c < exact.width(); ++c) {
      const int col = run->window.col0 + c - ours.window.col0, row = run->window.row0 + r - ours.window.row0;
      if (col < 0 || row < 0 || col >= ours.mask.width() || row >= ours.mask.height()) continue;
      const std::uint8_t a = exact.at(c, r), b = ours.mask.at(col, row);
      if (a == visibility::kNoAnswer || b == visibility::kNoAnswer) continue;
      const bool e = a == visibility::kVisible, s = b == visibility::kVisible;
      ++timing.cells;
      timing.cells_false_hidden += e && !s;
      timing.cells_false_visible += !e && s;
      timing.cells_both += e && s;
      timing.cells_either += e || s;
    }
}

void fly_session(const Options& o, const std::shared_ptr<const terrain::ElevationSource>& source,
                 terrain::BlockCache& cache, const std::shared_ptr<const terrain::SourcePyramid>& pyramid,
                 gpu::ContextPool* gpu, unsigned seed, Timing& timing) {
  const std::vector<clipmap::SessionBox> boxes = make_boxes(o, *source, cache, seed);
  clipmap::SessionOptions so;
  so.mode = o.mode == "conservative" ? clipmap::ClipMode::kConservative : clipmap::ClipMode::kFast;
  so.shape.level_size = o.level_size;
  so.shape.subtile = o.subtile;
  so.shape.levels = o.levels ? o.levels : clipmap::levels_to_cover(o.level_size, source->width(), source->height());
  so.rays = o.rays;
  so.threads = static_cast<unsigned>(o.threads);
  so.asynchronous = o.baseline == "session";
  so.viewshed_radius = o.viewshed_radius;
  so.use_gpu = gpu != nullptr;
  so.gpu = gpu;
  if (o.baseline == "sync-all") so.updater.every.assign(static_cast<std::size_t>(so.shape.levels), 1);
  auto session = clipmap::ClipSession::open(source, cache, pyramid, so, pose_at(o, 0));
  if (!session.ok()) usage(session.error().message.c_str());
  if (Status s = (*session)->add_boxes(boxes); !s.ok()) usage(s.error().message.c_str());
  std::map<std::uint64_t, bool> seen;
  const auto start = Clock::now();
  for (int i = 0; i < o.poses; ++i) {
    const auto slot = start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(i / o.rate));
    std::this_thread::sleep_until(slot);
    const auto began = Clock::now();
    auto answer = (*session)->answer(pose_at(o, i));
    const auto ended = Clock::now();
    const double took = std::chrono::duration<double>(ended - began).count();
    if (!answer.ok()) usage(answer.error().message.c_str());
    for (const auto& c : answer->changes) seen[c.id] = c.state != visibility::Visibility::kOccluded;
    std::lock_guard lock(timing.mutex);
    timing.seconds.push_back(took);
    timing.lag.push_back(std::chrono::duration<double>(ended - slot).count());
    timing.late += Clock::now() > slot + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1 / o.rate));
    timing.subtiles += answer->subtiles_loaded;
    timing.bytes += answer->bytes_loaded;
    timing.samples += answer->cull.samples;
    timing.fallbacks += answer->cull.fallbacks;
    timing.rings += answer->cull.rings;
    timing.tests += answer->cull.box_tests;
    timing.cull_seconds += answer->cull.seconds;
    timing.on_gpu += answer->cull.gpu;
    timing.uploaded += answer->cull.bytes_uploaded;
    if (answer->viewshed) timing.viewshed_seconds += answer->viewshed->seconds;
    ++timing.answers;
    if (o.accuracy > 0 && i % o.accuracy == 0 && seed == 1) {
      const std::vector<bool> exact = exact_states(*source, cache, pose_at(o, i), boxes);
      for (std::size_t b = 0; b < boxes.size(); ++b) {
        const bool ours = seen[boxes[b].id];
        timing.false_hidden += exact[b] && !ours;
        timing.false_visible += !exact[b] && ours;
        ++timing.checked;
      }
      if (answer->viewshed) compare_viewshed(o, *source, cache, pose_at(o, i), *answer->viewshed, timing);
    }
  }
}

void fly_cullboxes(const Options& o, const std::shared_ptr<const terrain::ElevationSource>& source,
                   terrain::BlockCache& cache, Timing& timing) {
  const std::vector<clipmap::SessionBox> boxes = make_boxes(o, *source, cache, 1);
  visibility::Workspace workspace;
  const auto start = Clock::now();
  for (int i = 0; i < o.poses; ++i) {
    const auto slot = start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(i / o.rate));
    std::this_thread::sleep_until(slot);
    const auto began = Clock::now();
    visibility::CullQuery q;
    q.observer = pose_at(o, i).position;
    for (const auto& b : boxes) q.boxes.push_back(b.box);
    q.options.conservative = o.mode == "conservative";
    q.options.viewshed.threads = 1;
    q.options.viewshed.backend = visibility::Backend::kCpu;
    auto plan = visibility::plan_cull_boxes(*source, q);
    if (!plan.ok()) usage(plan.error().message.c_str());
    auto run = visibility::run_cull_boxes(*plan, *source, &cache, nullptr, nullptr, nullptr, &workspace);
    if (!run.ok()) usage(run.error().message.c_str());
    const auto ended = Clock::now();
    timing.seconds.push_back(std::chrono::duration<double>(ended - began).count());
    timing.lag.push_back(std::chrono::duration<double>(ended - slot).count());
    timing.late += Clock::now() > slot + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1 / o.rate));
    timing.bytes += run->read.cells_decoded * sizeof(float);
    timing.samples += run->result.stats.dem_cells;
    ++timing.answers;
  }
}

double percentile(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v[std::min(v.size() - 1, static_cast<std::size_t>(p * v.size()))];
}

}  // namespace

int main(int argc, char** argv) {
  const Options o = parse(argc, argv);
  using visibility::sweep::simd::Isa;
  if (!o.isa.empty()) visibility::sweep::simd::isa_limit() = o.isa == "scalar" ? Isa::kScalar : Isa::kAvx2;
  auto source = terrain::ElevationSource::open(o.dem);
  if (!source.ok()) usage(source.error().message.c_str());
  terrain::BlockCache::Options co;
  co.budget_bytes = static_cast<std::uint64_t>(o.cache_mb) << 20;
  terrain::BlockCache cache(co);
  Timing timing;
  const auto started = Clock::now();
  if (o.baseline == "cullboxes") {
    fly_cullboxes(o, *source, cache, timing);
  } else {
    clipmap::ClipmapShape shape;
    shape.level_size = o.level_size;
    shape.subtile = o.subtile;
    shape.levels = o.levels ? o.levels : clipmap::levels_to_cover(o.level_size, (*source)->width(), (*source)->height());
    shape.reduction = o.mode == "conservative" ? terrain::Reduction::kMin : terrain::Reduction::kMean;
    auto pyramid = terrain::SourcePyramid::make(*source, cache, shape.reduction, clipmap::pyramid_options_for(shape));
    if (!pyramid.ok()) usage(pyramid.error().message.c_str());
    std::vector<std::thread> flights;
    std::unique_ptr<gpu::ContextPool> pool;
    if (o.backend == "gpu") {
      auto created = gpu::ContextPool::create({.contexts = o.sessions});
      if (!created.ok()) usage(created.error().message.c_str());
      pool = std::move(created).value();
      std::printf("gpu: %s (%s)\n", pool->device().renderer.c_str(), pool->device().version.c_str());
    }
    for (int s = 0; s < o.sessions; ++s)
      flights.emplace_back(
          [&, s] { fly_session(o, *source, cache, *pyramid, pool.get(), static_cast<unsigned>(s + 1), timing); });
    for (auto& f : flights) f.join();
  }
  const double wall = std::chrono::duration<double>(Clock::now() - started).count();
  const double n = static_cast<double>(std::max<std::uint64_t>(timing.answers, 1));
  std::printf("%s %s sessions=%d poses=%llu rate=%g boxes=%d: p50 %.2f ms, p99 %.2f ms, max %.2f ms; late %llu; "
              "%.1f sub-tiles and %.1f KiB loaded a pose; fallbacks %.3f %% of %llu samples; wall %.1f s",
              o.baseline.c_str(), o.mode.c_str(), o.sessions, static_cast<unsigned long long>(timing.answers), o.rate,
              o.boxes, percentile(timing.seconds, 0.5) * 1e3, percentile(timing.seconds, 0.99) * 1e3,
              percentile(timing.seconds, 1.0) * 1e3, static_cast<unsigned long long>(timing.late),
              static_cast<double>(timing.subtiles) / n, static_cast<double>(timing.bytes) / 1024.0 / n,
              timing.samples ? 100.0 * static_cast<double>(timing.fallbacks) / static_cast<double>(timing.samples) : 0.0,
              static_cast<unsigned long long>(timing.samples), wall);
  std::printf("; from its slot: p99 %.2f ms, max %.2f ms", percentile(timing.lag, 0.99) * 1e3,
              percentile(timing.lag, 1.0) * 1e3);
  if (timing.rings)
    std::printf("; a pose: %.0f rings, %.0f box tests, %.2f ms culling", static_cast<double>(timing.rings) / n,
                static_cast<double>(timing.tests) / n, timing.cull_seconds / n * 1e3);
  if (timing.checked)
    std::printf("; vs exact: %llu false hidden, %llu false visible of %llu (%.3f %% agree)",
                static_cast<unsigned long long>(timing.false_hidden), static_cast<unsigned long long>(timing.false_visible),
                static_cast<unsigned long long>(timing.checked),
                100.0 * (1.0 - static_cast<double>(timing.false_hidden + timing.false_visible) / static_cast<double>(timing.checked)));
  if (o.viewshed_radius > 0) std::printf("; viewshed %.2f ms a pose", timing.viewshed_seconds / n * 1e3);
  if (o.backend == "gpu")
    std::printf("; %llu answers traced on the GPU, %.1f KiB copied to it a pose",
                static_cast<unsigned long long>(timing.on_gpu), static_cast<double>(timing.uploaded) / 1024.0 / n);
  if (timing.cells)
    std::printf("; viewshed vs exact: IoU %.4f, %.3f %% false hidden, %.3f %% false visible of %llu cells",
                static_cast<double>(timing.cells_both) / static_cast<double>(std::max<std::uint64_t>(timing.cells_either, 1)),
                100.0 * static_cast<double>(timing.cells_false_hidden) / static_cast<double>(timing.cells),
                100.0 * static_cast<double>(timing.cells_false_visible) / static_cast<double>(timing.cells),
                static_cast<unsigned long long>(timing.cells));
  std::printf("\n");
  return 0;
}
